"""Rooms no network trained in, each fitted by ``nlos fit`` itself: the product's command, not the
variant grammar of ``unseen_room_fit.py``.

Every room of an ``unseen-test.yaml`` dataset is an nlos-scene/1 directory, so ``nlos fit`` takes it
as a user's room: it renders its people in it, picks the spot, trains and scores its own held-out
people (its report). For each room and ``--method`` (the registry's names: ``ours``, ``chandran``,
``tancik``, ...) this runs::

    nlos fit TEST/scenes/test-NNNNN --preset PRESET --method METHOD --out OUT/test-NNNNN/METHOD [FIT FLAGS]

in this process (resumable: a finished room is read, a started one resumed; a finished one made
with another preset or other flags is refused), then keeps one row a room and method in
``OUT/rooms.csv`` (six-way and 3-way posture, error, the mean answer, minutes; rows of earlier runs
into the same ``OUT`` kept) and prints the mean over rooms with the rooms' 95% interval
(``evaluate.room_fits.room_interval``).
The recorded rows of ``unseen_room_fit.py`` stay its own (their recipe); new per-room fits run here.

    python experiments/unseen-room-fit/nlos_fit_rooms.py --test out/unseen/test --rooms 0-3 --preset demo \\
        --out out/unseen/nlos-fit-demo
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import numpy as np

from nlos_spotlight.data.store import atomic_csv, atomic_json, scene_id
from nlos_spotlight.errors import NlosError
from nlos_spotlight.evaluate.room_fits import room_interval, room_range

FIELDS = ("room", "method", "preset", "fit_flags", "people", "posture_pct", "posture3_pct", "error_cm",
          "mean_answer_cm", "minutes")


def fit_room_model(room: Path, out: Path, method: str, preset: str, flags: list[str]) -> dict:
    """The room model's report, fitting (or resuming) it first with ``nlos fit``."""
    from nlos_spotlight.cli import main

    said = out.with_name(out.name + ".asked.json")  # what this driver asked nlos fit for (beside: --out stays nlos fit's)
    asked = {"preset": preset, "method": method, "flags": flags}
    if said.exists() and json.loads(said.read_text()) != asked:
        raise NlosError(f"{out}: fitted with {json.loads(said.read_text())}, not {asked}; choose another --out")
    if not (out / "report.json").exists():
        out.parent.mkdir(parents=True, exist_ok=True)
        atomic_json(said, asked)
        resume = ["--resume"] if (out / "fit.json").exists() else []
        code = main(["fit", str(room), "--preset", preset, "--method", method, "--out", str(out), "--quiet",
                     *resume, *flags])  # nlos fit itself refuses a resume under other settings
        if code != 0:
            raise NlosError(f"{room.name}: nlos fit --method {method} failed (exit {code}); rerun to resume")
    return json.loads((out / "report.json").read_text())


def row(room: str, method: str, flags: list[str], report: dict) -> dict:
    h = report["heldout"]
    return {"room": room, "method": method, "preset": report["config"]["name"], "fit_flags": " ".join(flags),
            "people": h["people"],
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
    try:
        run(args, flags)
    except NlosError as exc:
        raise SystemExit(f"error: {exc}") from None


def run(args, flags: list[str]) -> None:
    table = args.out / "rooms.csv"
    rows = []
    if table.exists():
        with table.open(newline="") as f:
            rows = list(csv.DictReader(f))
    methods = [m for m in args.methods.split(",") if m]
    if not methods:
        raise NlosError(f"--methods: expected names of nlos fit --method, got {args.methods!r}")
    for i in room_range(args.rooms):
        room = args.test / "scenes" / scene_id("test", i)
        if not (room / "done.json").exists():
            raise SystemExit(f"{room}: not generated (nlos generate benchmarks/configs/unseen-test.yaml "
                             f"--out {args.test} --shard {i}/40)")
        for method in methods:
            report = fit_room_model(room, args.out / room.name / method, method, args.preset, flags)
            rows = [r for r in rows if (r["room"], r["method"]) != (room.name, method)]
            rows.append(row(room.name, method, flags, report))
            atomic_csv(table, list(FIELDS), rows)
            print(f"{room.name} {method}: {rows[-1]['posture_pct']}% six-way, {rows[-1]['error_cm']} cm")
    print("\n".join(summary(rows)))


if __name__ == "__main__":
    main()
