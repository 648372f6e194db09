"""Rooms no network trained in, each fitted by ``nlos fit`` itself: the product's command, not the
variant grammar of ``unseen_room_fit.py``.

Every room of an ``unseen-test.yaml`` dataset is an nlos-scene/1 directory, so ``nlos fit`` takes it
as a user's room: it renders its people in it, picks the spot, trains and scores its own held-out
people (its report). For each room and ``--method`` (the registry's names: ``ours``, ``chandran``,
``tancik``, ...) this runs::

    nlos fit TEST/scenes/test-NNNNN --preset PRESET --method METHOD --out OUT/test-NNNNN/METHOD [FIT FLAGS]

in this process (resumable: a finished room is read, a started one resumed), then writes one row a
room and method to ``OUT/rooms.csv`` (six-way and 3-way posture, error, the mean answer, minutes)
and prints the mean over rooms with the rooms' 95% interval (``evaluate.room_fits.room_interval``).
The recorded rows of ``unseen_room_fit.py`` stay its own (their recipe); new per-room fits run here.

    python experiments/unseen-room-fit/nlos_fit_rooms.py --test out/unseen/test --rooms 0-3 --preset demo \\
        --out out/unseen/nlos-fit-demo
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from nlos_spotlight.data.store import atomic_csv, scene_id
from nlos_spotlight.errors import NlosError
from nlos_spotlight.evaluate.room_fits import room_interval, room_range

FIELDS = ("room", "method", "preset", "people", "posture_pct", "posture3_pct", "error_cm", "mean_answer_cm",
          "minutes")


def fit_room_model(room: Path, out: Path, method: str, preset: str, flags: list[str]) -> dict:
    """The room model's report, fitting (or resuming) it first with ``nlos fit``."""
    from nlos_spotlight.cli import main

    if not (out / "report.json").exists():
        resume = ["--resume"] if (out / "fit.json").exists() else []
        code = main(["fit", str(room), "--preset", preset, "--method", method, "--out", str(out), "--quiet",
                     *resume, *flags])
        if code != 0:
            raise NlosError(f"{room.name}: nlos fit --method {method} failed (exit {code}); rerun to resume")
    return json.loads((out / "report.json").read_text())


def row(room: str, method: str, preset: str, report: dict) -> dict:
    h = report["heldout"]
    return {"room": room, "method": method, "preset": preset, "people": h["people"],
            "posture_pct": round(100 * h["posture_accuracy"], 2), "posture3_pct": round(100 * h["posture3_accuracy"], 2),
            "error_cm": round(h["error_cm"], 2), "mean_answer_cm": round(h["mean_answer_cm"], 2),
            "minutes": round(report["timing_s"]["total_s"] / 60, 2)}


def summary(rows: list[dict]) -> list[str]:
    """Per method: the mean over rooms and the rooms' 95% interval of six-way posture, and the mean error."""
    lines = []
    for method in dict.fromkeys(r["method"] for r in rows):
        rs = [r for r in rows if r["method"] == method]
        acc = [float(r["posture_pct"]) for r in rs]
        interval = room_interval(acc)
        lines.append(f"{method}: {len(rs)} rooms, six-way {np.mean(acc):.1f}%"
                     f"{f' ({interval} over rooms)' if interval else ''}, 3-way "
                     f"{np.mean([float(r['posture3_pct']) for r in rs]):.1f}%, error "
                     f"{np.mean([float(r['error_cm']) for r in rs]):.1f} cm (mean answer "
                     f"{np.mean([float(r['mean_answer_cm']) for r in rs]):.1f} cm), "
                     f"{np.mean([float(r['minutes']) for r in rs]):.1f} min a room")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--test", type=Path, required=True, help="dataset of unseen-test.yaml (its rooms generated)")
    ap.add_argument("--rooms", default="0-3", help="test rooms by index: A-B or A,B,C (default 0-3)")
    ap.add_argument("--methods", default="ours", help="comma-separated methods of nlos fit --method (default ours)")
    ap.add_argument("--preset", default="demo", help="nlos fit --preset (default demo: 600 people)")
    ap.add_argument("--out", type=Path, required=True, help="one room model a room and method, and rooms.csv")
    args, flags = ap.parse_known_args()  # the rest goes to nlos fit as it is
    rows = []
    for i in room_range(args.rooms):
        room = args.test / "scenes" / scene_id("test", i)
        if not (room / "done.json").exists():
            raise SystemExit(f"{room}: not generated (nlos generate benchmarks/configs/unseen-test.yaml "
                             f"--out {args.test} --shard {i}/40)")
        for method in args.methods.split(","):
            report = fit_room_model(room, args.out / room.name / method, method, args.preset, flags)
            rows.append(row(room.name, method, args.preset, report))
            atomic_csv(args.out / "rooms.csv", list(FIELDS), rows)
            print(f"{room.name} {method}: {rows[-1]['posture_pct']}% six-way, {rows[-1]['error_cm']} cm")
    print("\n".join(summary(rows)))


if __name__ == "__main__":
    main()
