"""Fit the three real scans of ``../shared/data/real-scans`` with ``nlos fit`` and tabulate them.

Each room's setup (camera, projector, hidden region: what a person would pick) is a committed
config, ``benchmarks/configs/rooms/NAME.yaml`` (``nlos fit --config``); every fit resumes where it stopped. Writes
``--out``/real-scan-fits.csv (room, people, posture and grouped accuracy, error, mean-position
answer, spot, pan/tilt, burst, generation and total time) and prints the command of each fit.

    python experiments/real-scan-fits/real_scan_fits.py [--rooms copyroom,icl_livingroom2,icl_office2] [--people N]
"""

from __future__ import annotations

import argparse
import csv
import json
import shlex
import sys
from pathlib import Path

CONFIGS = Path(__file__).resolve().parents[2] / "benchmarks" / "configs" / "rooms"  # the setups stay with the benchmarks


def fit_command(name: str, out: Path, extra: list[str]) -> list[str]:
    """The ``nlos fit`` arguments of a committed room config (``nlos fit --config``)."""
    return ["fit", "--config", str(CONFIGS / f"{name}.yaml"), "--out", str(out / name)] + extra


def main(argv: list[str] | None = None) -> None:
    from nlos_spotlight.cli import main as nlos

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rooms", default="copyroom,icl_livingroom2,icl_office2")
    ap.add_argument("--out", default="out/fits")
    ap.add_argument("--people", type=int, help="override the fit's default")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    out = Path(args.out)
    rows = []
    for name in args.rooms.split(","):
        extra = (["--people", str(args.people)] if args.people else []) + (["--quiet"] if args.quiet else [])
        cmd = fit_command(name, out, extra)
        print("nlos " + " ".join(shlex.quote(c) for c in cmd), flush=True)
        resume = ["--resume"] if (out / name / "fit.json").exists() else []
        if nlos(cmd + resume) != 0:
            sys.exit(f"{name}: nlos fit failed")
        r = json.loads((out / name / "report.json").read_text())
        h, s, c, t = r["heldout"], r["spot"], r["capture"], r["timing_s"]
        rows.append({"room": name, "people": r["training"]["people"], "heldout": h["people"],
                     "posture_accuracy": round(100 * h["posture_accuracy"], 1),
                     "posture3_accuracy": round(100 * h["posture3_accuracy"], 1), "error_cm": round(h["error_cm"], 1),
                     "median_error_cm": round(h["median_error_cm"], 1), "mean_answer_cm": round(h["mean_answer_cm"], 1),
                     "spot_face": s["face"], "pan_deg": round(s["pan_deg"], 1), "tilt_deg": round(s["tilt_deg"], 1),
                     "burst_frames": c["burst_frames"], "exposure_ms": round(1000 * c["exposure_s"], 1),
                     "generate_min": round(t["generate_s"] / 60, 1), "total_min": round(t["total_s"] / 60, 1)})
    out.mkdir(parents=True, exist_ok=True)
    with (out / "real-scan-fits.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    for row in rows:
        print(row)


if __name__ == "__main__":
    main()
