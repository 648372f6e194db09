"""Posture across rooms with thousands of people a room: one network on several fitted rooms' renders,
scored in fitted rooms it never trained in (issue 12).

Across the 200 training rooms (40 people each, 8,000 in all) posture stays at chance in new rooms,
while one room fitted with 5,584 of its own people reads it at 63% (``unseen_room_fit.py``). Which
of the two is missing across rooms: people or rooms? Hypothesis: if people bind, one network trained
on the renders of a few fitted rooms (``--train-rooms``, thousands of people each) reads posture in
the other fitted rooms (``--eval-rooms``) well above chance; if rooms bind, it reads them only in the
rooms it trained in.

Data: ``unseen_room_fit.py``'s renders under ``--fits`` (per room ``data`` and ``data-2``, people
rendered in a test room's scan from their own master seeds; none is a test person), the same
training pools, validation and held-out people as the per-room fits. Each room is lit by the spot
its fit chose from its own simulated people (the room-fit CSV's ``fit:`` spot). The network is the
seen-rooms recipe with every batch mixing all training rooms, the geometry-aware input by default
(``--net``), the 16-frame still capture; best weights by the training rooms' validation people.

Scored, with the per-room fits' sensor noise (so each person's photograph is the fit's):
- ``unseen`` rows: each evaluation room's 30 static test people (``kind=test``) and 100 held-out
  simulated people (``kind=simulated``), rooms the network never saw;
- ``seen`` rows: the training rooms' own held-out simulated and test people.

    python experiments/unseen-room-fit/fitted_rooms_transfer.py --fits out/unseen/room-fit-3000 --test out/unseen/test \\
        --train-rooms 0-5 --eval-rooms 6-11 --out out/unseen/transfer/a

Writes ``--out``/transfer.csv (room, role, kind, spot, people, posture_accuracy, posture3_accuracy,
error_cm, mean_answer_cm, train_s), ``summary.md`` beside the per-room fits on the same rooms
(``--compare`` variant), the run (``run/``: resumable checkpoints, ``best.pt``) and its config.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.data.store import atomic_csv
from nlos_spotlight.errors import NlosError
from nlos_spotlight.evaluate.room_fits import (first_seconds, read_fit_rows, room_interval, room_range,
                                               static_people, training_split)

COLUMNS = ["room", "role", "kind", "spot", "people", "posture_accuracy", "posture3_accuracy", "error_cm",
           "mean_answer_cm", "train_s"]


def fit_rows(fits: Path, variant: str) -> dict:
    """{(room, kind): row} of the per-room fits of ``variant`` (kind 'test' or 'simulated')."""
    out = {}
    for path in sorted(fits.glob("room-fit-*.csv")):
        for r in read_fit_rows(path):
            kind = {"fit": "test", "heldout": "simulated"}.get(r["spot"].split(":")[0])
            if r["variant"] == variant and kind:
                out[r["room"], kind] = r
    return out


@dataclasses.dataclass
class FittedRoom:
    """One fitted room's people and the spot its fit chose."""

    name: str
    split: object
    """``train.recipe.RoomSplit``: training pool (every render), validation, 100 held-out simulated people."""
    test: object
    """The test room's 30 static test people."""
    spot: int
    """Face index of the fit's spot."""


def load_room(args, i: int, fits: dict, renders: int) -> FittedRoom:
    """Room ``i``'s renders (``renders`` of them pooled for training), its test people and the spot
    its fit chose from its own simulated people (``fits``: :func:`fit_rows`, its ``fit:`` row)."""
    from nlos_spotlight.data.store import scene_id

    name = scene_id("test", i)
    if (name, "test") not in fits:
        raise SystemExit(f"{args.fits}: no fit of {name} with variant {args.compare} (unseen_room_fit.py first)")
    out = args.fits / name
    split = training_split(out / "data")
    for r in range(2, renders + 1):
        if not (out / f"data-{r}" / "manifest.json").exists():
            raise SystemExit(f"{out}/data-{r}: not rendered (unseen_room_fit.py --variants 16+e120+x{r})")
        split = dataclasses.replace(split, pool=split.pool.concat(training_split(out / f"data-{r}").pool))
    return FittedRoom(name, split, static_people(args.test / "scenes" / name),
                      int(fits[name, "test"]["spot"].split(":")[1]))


def train_config(args, rooms: int, people: int):
    """The per-room fits' recipe (``unseen_room_fit.py`` variant 16+e120), every batch mixing the
    rooms; ``--steps``, or ``--epochs`` passes over the ``people``."""
    from nlos_spotlight.train.recipe import seen_config

    cfg = seen_config(rooms, args.seed, noise=True, policy="oracle")
    steps = args.steps or max(1, round(args.epochs * people / cfg.batch_size))
    every = max(1, steps // 25)
    return dataclasses.replace(cfg, sensor={"burst_frames": args.frames}, steps=steps, eval_every=every,
                               ckpt_every=every, log_every=every, select="metrics",
                               net=dataclasses.replace(cfg.net, geometry=args.net == "geometry"))


def train(args, rooms: list[FittedRoom]):
    """One network on the training rooms' pools, each room under its fitted spot; resumable."""
    from nlos_spotlight.train.recipe import resume_validated, train_validated
    from nlos_spotlight.lighting import Illumination
    from nlos_spotlight.train.loop import Trainer

    people = sum(r.split.pool.num_samples for r in rooms)
    cfg = train_config(args, len(rooms), people)
    run = args.out / "run"
    run.mkdir(parents=True, exist_ok=True)
    (run / "config.json").write_text(json.dumps({"train": cfg.to_dict(), "train_rooms": [r.name for r in rooms],
                                                 "renders": args.renders, "people": people}, indent=1))
    t0 = time.perf_counter()
    tr = Trainer(cfg, [r.split.pool for r in rooms], run, val_scenes=[r.split.val for r in rooms])
    # the fits' spots, not a fresh oracle: the comparison with the per-room fits holds the light fixed
    tr.fixed = [Illumination("spot", face=r.spot) for r in rooms]
    resume_validated(tr, run)
    train_validated(tr, run, progress=not args.quiet)
    return tr, first_seconds(run / "train_seconds.json", t0), people


def score(args, tr, room: FittedRoom, role: str, people: int, train_s: float, mean: torch.Tensor) -> list[dict]:
    """The room's test and held-out simulated people under its fitted spot, the fits' noise draws;
    ``mean`` (2,): the training people's mean position (the mean answer)."""
    from nlos_spotlight.evaluate.seen import score_rooms

    y = torch.nn.functional.one_hot(torch.tensor(room.spot), len(room.test.faces)).float()
    rows = []
    for kind, group in (("test", room.test), ("simulated", room.split.test)):
        res = score_rooms(tr.net, tr.cfg.net, tr.sensor, [group], [(y, "spot")], True, args.seed)
        rows.append(dict(room=room.name, role=role, kind=kind, spot=room.spot, people=people,
                         posture_accuracy=round(res["posture_accuracy"], 2),
                         posture3_accuracy=round(res["posture3_accuracy"], 2), error_cm=round(res["error_cm"], 2),
                         mean_answer_cm=round(100 * float((group.target - mean).norm(dim=1).mean()), 2),
                         train_s=round(train_s)))
        print(" ".join(f"{k}={v}" for k, v in rows[-1].items()), flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fits", type=Path, default=Path("out/unseen/room-fit-3000"), help="unseen_room_fit.py --out")
    ap.add_argument("--test", type=Path, default=Path("out/unseen/test"), help="the test dataset")
    ap.add_argument("--train-rooms", default="0-5", help="test-room indices to train on (A-B or A,B,C)")
    ap.add_argument("--eval-rooms", default="6-11", help="fitted rooms to score as unseen")
    ap.add_argument("--renders", type=int, default=2, help="renders of each training room pooled (data, data-2, ...)")
    ap.add_argument("--net", choices=("geometry", "image"), default="geometry",
                    help="the geometry-aware input or the image alone")
    ap.add_argument("--frames", type=int, default=16, help="frames a still capture averages (train and test)")
    ap.add_argument("--epochs", type=float, default=20.0, help="passes over all training people")
    ap.add_argument("--steps", type=int, default=0, help="optimizer steps (overrides --epochs)")
    ap.add_argument("--compare", default="16+e120+x2", help="the per-room fits' variant: spots and the summary")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--quiet", action="store_true", help="no progress lines")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--summary-only", action="store_true")
    args = ap.parse_args()
    if args.summary_only:
        return summary(args)
    torch.set_num_threads(args.threads)
    train_ids, eval_ids = room_range(args.train_rooms), room_range(args.eval_rooms)
    if set(train_ids) & set(eval_ids):
        raise SystemExit("--train-rooms and --eval-rooms overlap: the unseen rooms must be new to the network")
    try:
        fits = fit_rows(args.fits, args.compare)
        train_rooms = [load_room(args, i, fits, args.renders) for i in train_ids]
        mean = torch.cat([r.split.pool.target for r in train_rooms]).mean(0)
        tr, train_s, people = train(args, train_rooms)
        rows = []
        for role, ids, loaded in (("seen", train_ids, train_rooms), ("unseen", eval_ids, None)):
            for k, i in enumerate(ids):
                room = loaded[k] if loaded else load_room(args, i, fits, renders=1)  # scored people: first render
                rows += score(args, tr, room, role, people, train_s, mean)
                atomic_csv(args.out / "transfer.csv", COLUMNS, rows)
    except NlosError as exc:
        raise SystemExit(str(exc)) from None
    summary(args)


def summary(args) -> None:
    """Each role's mean over rooms beside the per-room fits (``--compare``) on the same rooms."""
    if not (args.out / "transfer.csv").exists() or not (args.out / "run" / "config.json").exists():
        raise SystemExit(f"{args.out}: no transfer.csv and run/config.json yet (run without --summary-only first)")
    with (args.out / "transfer.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    fits = fit_rows(args.fits, args.compare)
    cfg = json.loads((args.out / "run" / "config.json").read_text())
    lines = [f"One {'geometry-aware' if cfg['train']['net'].get('geometry') else 'image-only'} network on "
             f"{cfg['people']} people of {len(cfg['train_rooms'])} fitted rooms ({', '.join(cfg['train_rooms'])}), "
             f"{cfg['train']['steps']} steps; per-room fits: variant {args.compare} (one network per room). "
             "Scored: each room's 30 static test people or 100 held-out simulated people; mean answer: the "
             "network's training people's mean position",
             "| rooms | people scored | network | six-way | six-way, 95% interval over rooms | "
             "upright/sitting/crouching | error | mean answer |", "|---|---|---|---|---|---|---|---|"]
    for role in ("seen", "unseen"):
        for kind in ("test", "simulated"):
            sel = [r for r in rows if r["role"] == role and r["kind"] == kind]
            if not sel:
                continue
            for name, group in (("across rooms", sel), ("per-room fit", [fits.get((r["room"], kind)) for r in sel])):
                if any(g is None for g in group):
                    continue
                acc = [float(g["posture_accuracy"]) for g in group]
                mean = lambda k: np.mean([float(g[k]) for g in group])
                lines.append(f"| {role} ({len(sel)}) | {kind} | {name} | {np.mean(acc):.1f}% | {room_interval(acc)} | "
                             f"{mean('posture3_accuracy'):.1f}% | {mean('error_cm'):.1f} cm | "
                             f"{mean('mean_answer_cm'):.1f} cm |")
    lines += ["", "Per room, six-way on test / simulated people (across rooms; per-room fit):",
              "| room | role | across rooms | per-room fit |", "|---|---|---|---|"]
    for room in sorted({r["room"] for r in rows}):
        got = {r["kind"]: r for r in rows if r["room"] == room}
        cell = lambda g: (f"{float(g['test']['posture_accuracy']):.1f}% / {float(g['simulated']['posture_accuracy']):.0f}%"
                          if "test" in g and "simulated" in g and all(g.values()) else "")
        lines.append(f"| {room} | {got['test']['role'] if 'test' in got else ''} | {cell(got)} | "
                     f"{cell({k: fits.get((room, k)) for k in ('test', 'simulated')})} |")
    text = "\n".join(lines)
    print(text)
    (args.out / "summary.md").write_text(text + "\n")


if __name__ == "__main__":
    try:
        main()
    except NlosError as exc:  # a malformed variant or room range: one line
        raise SystemExit(f"error: {exc}") from None
