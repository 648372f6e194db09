"""Gather robustness runs into ``docs/results/robustness.csv``: each run's rows of one reading, renamed.

``experiments/camera-photographs/robustness.py`` writes one CSV a run; the issue's table is one file. Each ``--take
CSV:READING=NAME`` puts that run's rows of READING under NAME, replacing the file's earlier rows of
the same room and NAME (so a rerun replaces, never duplicates).

    python experiments/dark-clothing/gather_rows.py --take out/robustness14/copyroom-clothlog.csv:clothlog=camera-log \\
        --out docs/results/robustness.csv
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

from nlos_spotlight.data.store import atomic_csv

COLUMNS = ["room", "reading", "condition", "magnitude", "posture_accuracy", "posture3_accuracy", "error_cm", "people"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--take", action="append", required=True, metavar="CSV:READING=NAME")
    ap.add_argument("--out", type=Path, default=Path("docs/results/robustness.csv"))
    args = ap.parse_args()
    new = []
    for spec in args.take:
        try:
            path, rename = spec.rsplit(":", 1)
            reading, name = rename.split("=")
            with open(path, newline="") as f:
                got = [{**r, "reading": name} for r in csv.DictReader(f) if r["reading"] == reading]
        except (ValueError, OSError, KeyError) as exc:
            raise SystemExit(f"--take {spec}: expected CSV:READING=NAME of a robustness run ({exc})") from None
        if not got:
            raise SystemExit(f"--take {spec}: no rows of reading {reading!r}")
        new += got
    replaced = {(r["room"], r["reading"]) for r in new}
    old = []
    if args.out.exists():
        with args.out.open(newline="") as f:
            old = [r for r in csv.DictReader(f) if (r["room"], r["reading"]) not in replaced]
    atomic_csv(args.out, COLUMNS, [{k: r.get(k, "") for k in COLUMNS} for r in old + new])
    print(f"{args.out}: {len(new)} rows of {len(replaced)} (room, reading) pairs replaced or added, {len(old)} kept")


if __name__ == "__main__":
    main()
