"""Merge ``experiments/unseen-rooms/unseen_rooms.py`` results: one CSV, a markdown table (mean +- std over seeds)
and the rooms curve.

Several runs of ``unseen_rooms.py`` (different nets, room counts, seeds or captures, run side by
side on the cores) each write their own ``unseen-rooms.csv``; this reads them all, keeps one row
per (net, capture, policy, rooms, seed), and writes:

* ``--out``/unseen-rooms.csv: every row;
* ``--out``/unseen-rooms.md: per (net, capture, rooms) and policy, error and posture accuracy as
  mean +- standard deviation over the seeds, with the mean answer;
* ``--out``/unseen-rooms.png: error and posture against training rooms, oracle spot, seed means.

    python experiments/unseen-rooms/unseen_rooms_table.py docs/results/unseen-*/unseen-rooms.csv --out docs/results/unseen-rooms
"""

from __future__ import annotations

import argparse
import csv
from collections import defaultdict
from pathlib import Path

import numpy as np

KEY = ("net", "capture", "policy", "train_rooms", "seed")


def read(paths: list[Path]) -> list[dict]:
    rows = {}
    for p in paths:
        with p.open() as f:
            for r in csv.DictReader(f):
                rows[tuple(r[k] for k in KEY)] = r
    return sorted(rows.values(), key=lambda r: (r["net"], r["capture"], -int(r["train_rooms"]), r["policy"],
                                                int(r["seed"])))


def groups(rows: list[dict]) -> dict:
    out = defaultdict(list)
    for r in rows:
        out[(r["net"], r["capture"], int(r["train_rooms"]), r["policy"])].append(r)
    return out


def stat(rs: list[dict], key: str) -> str:
    v = np.array([float(r[key]) for r in rs])
    return f"{v.mean():.1f}" + (f" +- {v.std(ddof=1):.1f}" if len(v) > 1 else "")


def markdown(rows: list[dict]) -> str:
    policies = [p for p in ("oracle", "ien", "adaptive", "center", "random") if any(r["policy"] == p for r in rows)]
    g = groups(rows)
    head = "| network | capture | rooms | seeds | " + " | ".join(f"{p}: error cm / posture %" for p in policies) \
        + " | mean answer |"
    lines = [head, "|" + "---|" * (5 + len(policies))]
    for net, cap, rooms in sorted({k[:3] for k in g}, key=lambda k: (k[0], k[1], -k[2])):
        cells = []
        for p in policies:
            rs = g.get((net, cap, rooms, p), [])
            cells.append(f"{stat(rs, 'error_cm')} / {stat(rs, 'posture_accuracy')}" if rs else "")
        any_rs = next(rs for (n, c, k, _), rs in g.items() if (n, c, k) == (net, cap, rooms))
        lines.append(f"| {net} | {cap} | {rooms} | {len(any_rs)} | " + " | ".join(cells)
                     + f" | {float(any_rs[0]['mean_answer_cm']):.1f} |")
    return "\n".join(lines) + "\n"


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    g = groups([r for r in rows if r["policy"] == "oracle"])
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.5))
    for net, cap in sorted({k[:2] for k in g}):
        rooms = sorted(k[2] for k in g if k[:2] == (net, cap))
        for a, key in zip(ax, ("posture_accuracy", "error_cm")):
            m = [np.mean([float(r[key]) for r in g[(net, cap, k, "oracle")]]) for k in rooms]
            a.plot(rooms, m, "o-", label=f"{net}, {cap}")
    mean = [float(r["mean_answer_cm"]) for r in rows]
    ax[1].axhline(np.mean(mean), color="k", ls="--", label="mean answer")
    ax[0].axhline(100 / 6, color="k", ls=":", label="chance")
    ticks = sorted({k[2] for k in g})
    for a, lab in zip(ax, ("posture accuracy (6-way), %", "localization error, cm")):
        a.set_xscale("log")
        a.set_xticks(ticks, [str(t) for t in ticks])
        a.minorticks_off()
        a.set_xlabel("training rooms")
        a.set_ylabel(lab)
        a.legend(fontsize=7)
    fig.suptitle("40 unseen test rooms, oracle spot (seed means)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csvs", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    rows = read(args.csvs)
    args.out.mkdir(parents=True, exist_ok=True)
    with (args.out / "unseen-rooms.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    md = markdown(rows)
    (args.out / "unseen-rooms.md").write_text(md)
    plot(rows, args.out / "unseen-rooms.png")
    print(md)


if __name__ == "__main__":
    main()
