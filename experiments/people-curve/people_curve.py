"""The per-room fit against people per room: held-out posture and position as ``nlos fit`` renders more.

For each room (a committed config, ``benchmarks/configs/rooms/NAME.yaml``) and each people count,
one ``nlos fit --config ROOM.yaml --people N`` (the default recipe: 16-frame capture, oracle spot,
60 epochs; resumed where it stopped), then a row of its report: held-out six-way and three-way
posture (%), mean error (cm), seconds rendering (people + their shadows) and training, and the
device that rendered. Rooms whose name starts with ``unseen`` also give a ``mean-unseen`` row per
count (the issue's mean over unseen test rooms; none are committed configs yet).

    python experiments/people-curve/people_curve.py [--rooms copyroom] [--people 1000,3000,6000]
        [--out out/people-curve] [--csv docs/results/people-curve.csv] [--device cpu]
"""

from __future__ import annotations

import argparse
import csv
import json
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "benchmarks" / "configs" / "rooms"
FIELDS = ["room", "people", "posture_accuracy", "posture3_accuracy", "error_cm", "render_s", "train_s", "device"]
"""Columns of the curve (issue 38)."""


def row(room: str, model: Path) -> dict:
    """A curve row from a finished room model's ``report.json`` and ``fit.json``."""
    r = json.loads((model / "report.json").read_text())
    settings = json.loads((model / "fit.json").read_text())["settings"]
    h, t = r["heldout"], r["timing_s"]
    device = settings.get("render_device", "cpu")
    if device != "cpu":
        import torch

        device = torch.cuda.get_device_name(0) if torch.cuda.is_available() else device
    return {"room": room, "people": r["training"]["people"],
            "posture_accuracy": round(100 * h["posture_accuracy"], 1),
            "posture3_accuracy": round(100 * h["posture3_accuracy"], 1), "error_cm": round(h["error_cm"], 1),
            "render_s": round(t.get("generate_s", 0.0) + t.get("shadow_s", 0.0), 1), "train_s": round(t.get("train_s", 0.0), 1),
            "device": device}


def mean_unseen(rows: list[dict]) -> list[dict]:
    """One ``mean-unseen`` row per people count over the rooms named ``unseen*``."""
    out = []
    for n in sorted({r["people"] for r in rows}):
        sel = [r for r in rows if r["people"] == n and r["room"].startswith("unseen")]
        if sel:
            m = {k: round(sum(r[k] for r in sel) / len(sel), 1) for k in FIELDS[2:7]}
            out.append({"room": "mean-unseen", "people": n, **m, "device": sel[0]["device"]})
    return out


def main(argv: list[str] | None = None) -> None:
    from nlos_spotlight.cli import main as nlos

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rooms", default="copyroom")
    ap.add_argument("--people", default="1000,3000,6000", help="people per room (training + held out)")
    ap.add_argument("--out", default="out/people-curve")
    ap.add_argument("--csv", default=str(ROOT / "docs" / "results" / "people-curve.csv"))
    ap.add_argument("--device", default="cpu", help="nlos fit --device")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    out, rows = Path(args.out), []
    for room in args.rooms.split(","):
        for n in (int(x) for x in args.people.split(",")):
            model = out / f"{room}-{n}"
            cmd = ["fit", "--config", str(CONFIGS / f"{room}.yaml"), "--out", str(model), "--people", str(n),
                   "--device", args.device] + (["--quiet"] if args.quiet else [])
            print("nlos " + " ".join(shlex.quote(c) for c in cmd), flush=True)
            if not (model / "report.json").exists():
                if nlos(cmd + (["--resume"] if (model / "fit.json").exists() else [])) != 0:
                    sys.exit(f"{room}, {n} people: nlos fit failed")
            rows.append(row(room, model))
            print(rows[-1], flush=True)
    rows += mean_unseen(rows)
    path = Path(args.csv)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS)
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
