"""Is a fitted room's network short of data or short of fitting? Its training people against new ones.

``unseen_room_fit.py`` fits one network per test room on 2,792 simulated people. With a 16-frame
still capture it reads 60% six-way posture on 100 more simulated people of the room, where the ideal
observer reads 97%. Two explanations predict different things:

* **short of data** (it memorizes the people it saw): accuracy on its own training people, photographed
  with fresh sensor noise, is well above the held-out people's;
* **short of fitting** (optimization, capacity or training length): the two are close, so more people
  would not help and a longer or bigger fit might.

Per fitted room and variant: the best weights (``best.pt``) scored on the first ``--train-people``
training people and on the 100 held-out people, both under the fitted spot with fresh noise draws.

    python experiments/unseen-room-fit/room_fit_gap.py --fits out/unseen/room-fit-3000 --variants 16 16+e120 \
        --out docs/results/unseen-room-fit-3000/gap.csv

Writes the CSV (room, variant, split, people, posture_accuracy, posture3_accuracy, error_cm) and
prints the per-variant means.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.data.store import atomic_csv
from nlos_spotlight.errors import NlosError
from nlos_spotlight.evaluate.room_fits import parse_variant, run_dir, training_split

COLUMNS = ["room", "variant", "split", "people", "posture_accuracy", "posture3_accuracy", "error_cm"]


def score_room(room: Path, variant: str, train_people: int, seed: int) -> list[dict]:
    """The run's best weights on its first ``train_people`` training people and on its held-out people."""
    from nlos_spotlight.evaluate.seen import score_rooms
    from nlos_spotlight.train.config import TrainConfig
    from nlos_spotlight.train.loop import Trainer

    run = run_dir(room, variant)
    if not (run / "best.pt").exists():
        raise SystemExit(f"{run}: no best.pt (fit the room first: experiments/unseen-room-fit/unseen_room_fit.py)")
    if parse_variant(variant).renders > 1:  # its spot was chosen on the renders together
        raise SystemExit(f"--variants {variant}: people of several renders are not scored here")
    cfg = TrainConfig.from_dict(json.loads((run / "config.json").read_text())["train"])
    split = training_split(room / "data")
    tr = Trainer(cfg, [split.pool], run, val_scenes=[split.val])  # writes nothing; scored, not trained
    tr.load(run / "best.pt")
    (y, _, _), = tr.illuminations([tr.scenes[0]], train=False)
    seen = split.pool.subset(torch.arange(min(train_people, split.pool.num_samples)))
    rows = []
    for name, people in (("train", seen), ("heldout", split.test)):
        # seed + 1: noise draws that no training step and no earlier score used
        res = score_rooms(tr.net, cfg.net, tr.sensor, [people], [(y, "spot")], True, seed + 1)
        rows.append(dict(room=room.name, variant=variant, split=name, people=people.num_samples,
                         posture_accuracy=round(res["posture_accuracy"], 2),
                         posture3_accuracy=round(res["posture3_accuracy"], 2), error_cm=round(res["error_cm"], 2)))
        print(" ".join(f"{k}={v}" for k, v in rows[-1].items()), flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fits", type=Path, required=True, help="unseen_room_fit.py's --out")
    ap.add_argument("--variants", nargs="+", default=["16+e120"])
    ap.add_argument("--rooms", nargs="*", default=None, help="room names (default: every fitted room)")
    ap.add_argument("--train-people", type=int, default=500)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    rooms = [args.fits / r for r in args.rooms] if args.rooms else sorted(
        p for p in args.fits.iterdir() if (p / "data").is_dir())
    rows = []
    for room in rooms:
        for v in args.variants:
            if (run_dir(room, v) / "best.pt").exists():
                rows += score_room(room, v, args.train_people, args.seed)
    if not rows:
        raise SystemExit(f"{args.fits}: no fitted run of variants {args.variants}")
    atomic_csv(args.out, COLUMNS, rows)
    for v in args.variants:
        for split in ("train", "heldout"):
            r = [x for x in rows if x["variant"] == v and x["split"] == split]
            if r:
                acc = np.average([x["posture_accuracy"] for x in r], weights=[x["people"] for x in r])
                err = np.average([x["error_cm"] for x in r], weights=[x["people"] for x in r])
                print(f"{v} {split}: {len(r)} rooms, six-way {acc:.1f}%, error {err:.1f} cm")


if __name__ == "__main__":
    try:
        main()
    except NlosError as exc:  # a malformed variant or room range: one line
        raise SystemExit(f"error: {exc}") from None
