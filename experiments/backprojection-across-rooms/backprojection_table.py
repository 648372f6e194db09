"""Merge ``backprojection_net.py`` runs (this folder) into one table: mean +- std over seeds.

Each run directory holds ``backprojection-net.csv`` and ``run.json`` (its arguments: templates,
seed, steps, capture). Floor-net rows are grouped by (capture, templates, steps, policy); the
matched filter and the mean answer by (capture, policy), one run per seed.

    python experiments/backprojection-across-rooms/backprojection_table.py out/backprojection-net/* \\
        --out docs/results/backprojection-net
"""

from __future__ import annotations

import argparse
import csv
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

POLICIES = ("oracle", "ien", "adaptive", "center", "random")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    groups = defaultdict(list)
    for run in args.runs:
        if not (run / "backprojection-net.csv").exists():
            continue
        a = json.loads((run / "run.json").read_text())["args"]
        with open(run / "backprojection-net.csv") as f:
            for r in csv.DictReader(f):
                net = r["method"] == "floor-net"  # the others do not depend on the network's settings
                mask = a.get("mask", "placement")
                capture = a.get("capture", "photo") + ("" if mask == "placement" else f", mask {mask}")
                key = (capture, int(a.get("templates", 1)) if net else 0, int(a["steps"]) if net else 0,
                       r["policy"], r["method"])
                if any(v[0] == int(a["seed"]) for v in groups[key]):
                    continue  # the same seed's filter twice (runs of two networks)
                groups[key].append((int(a["seed"]), float(r["error_cm"]),
                                    float(r["posture_accuracy"]) if r["posture_accuracy"] else None,
                                    float(r["posture3_accuracy"]) if r.get("posture3_accuracy") else None))
    rows = []
    for (capture, templates, steps, policy, method), vals in sorted(groups.items()):
        err = np.array([v[1] for v in vals])
        acc = [v[2] for v in vals if v[2] is not None]
        acc3 = [v[3] for v in vals if v[3] is not None]
        rows.append(dict(capture=capture, templates=templates, steps=steps, policy=policy, method=method,
                         seeds=len(vals),
                         error_cm=round(err.mean(), 2), error_std=round(err.std(ddof=1), 2) if len(err) > 1 else "",
                         posture_accuracy=round(float(np.mean(acc)), 1) if acc else "",
                         posture3_accuracy=round(float(np.mean(acc3)), 1) if acc3 else ""))
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "backprojection-net.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    lines = ["| capture | method | templates | steps | seeds | " + " | ".join(p for p in POLICIES) + " |",
             "|---" * (5 + len(POLICIES)) + "|"]
    configs = sorted({(r["capture"], r["method"], r["templates"], r["steps"]) for r in rows},
                     key=lambda c: (c[0], c[1] != "floor-net", c))
    for capture, method, templates, steps in configs:
        cells, seeds = [], 0
        for p in POLICIES:
            r = next((r for r in rows if (r["capture"], r["method"], r["templates"], r["steps"], r["policy"]) ==
                      (capture, method, templates, steps, p)), None)
            if r is None:
                cells.append("")
                continue
            seeds = max(seeds, r["seeds"])
            e = f"{r['error_cm']:.1f}" + (f" +- {r['error_std']:.1f}" if r["error_std"] != "" else "") + " cm"
            cells.append(e + (f" / {r['posture_accuracy']:.1f}%" if r["posture_accuracy"] != "" else "")
                         + (f" / {r['posture3_accuracy']:.1f}%" if r["posture3_accuracy"] != "" else ""))
        t, n = (templates, steps) if templates else ("-", "-")
        lines.append(f"| {capture} | {method} | {t} | {n} | {seeds} | " + " | ".join(cells) + " |")
    (args.out / "backprojection-net.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
