"""What keeps the NLOS network from learning in seen rooms: one change at a time, same data and budget.

Every variant trains on the first N pool people of each training room (``train.recipe``'s split:
the same validation and test people for all) under the room's oracle spot and is scored on the
test people. The baseline is the learning curve's recipe (``learning_curve.py``, this folder); each
other variant changes one thing:

* ``per-room``: one network per room (what ``nlos fit`` trains) instead of one for all rooms;
* ``mixed-batches``: every batch mixes the rooms (``scenes_per_step`` = rooms), so batch norm's
  training statistics are those it uses at test time (one room per batch trains on per-room
  statistics and tests on their running mix);
* ``cifar-stem``, ``half-stem``: the small-image stem (stride 1 or 2) instead of the ImageNet one (stride 4);
* ``spatial``, ``spatial4``: the half (cifar) stem and the last feature map pooled to 2 x 2 (4 x 4)
  cells instead of globally, so the heads see where the light fell;
* ``norm-background``: the difference scaled by the empty-room photograph's RMS (keeps how bright
  the person is) instead of by its own RMS;
* ``coord``: CoordConv channels;
* ``chandran``: Chandran & Jayasuriya's CNN (keeps a 4 x 4 map of where the light falls).

Variants compose with ``+`` (e.g. ``mixed-batches+cifar-stem``). Resumable (the runs of
``train.recipe``); writes ``--out``/learning-ablation.csv.

    python experiments/seen-rooms-learning-curve/learning_ablation.py --data out/lc/data --n 1000 --capture noise-free \\
        --variants baseline,per-room,mixed-batches
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.data.tensors import load_split
from nlos_spotlight.train.recipe import run_seen, seen_config, split_room
from nlos_spotlight.train.config import TrainConfig

COLUMNS = ["variant", "capture", "people_per_room", "min_steps", "rooms", "posture_accuracy", "posture3_accuracy", "error_cm",
           "mean_answer_cm", "steps", "seconds", "seed"]


def net_change(**kw):
    return lambda cfg, rooms: dataclasses.replace(cfg, net=dataclasses.replace(cfg.net, **kw))


CHANGES = {
    "baseline": lambda cfg, rooms: cfg,
    "per-room": lambda cfg, rooms: cfg,  # handled by the runner: one run per room
    "mixed-batches": lambda cfg, rooms: dataclasses.replace(cfg, scenes_per_step=len(rooms)),
    "cifar-stem": net_change(stem="cifar"),
    "half-stem": net_change(stem="half"),
    "spatial": net_change(stem="half", pool_grid=2),
    "spatial4": net_change(stem="cifar", pool_grid=4),
    "norm-background": net_change(normalize="background"),
    "coord": net_change(coord_channels=True),
    "chandran": lambda cfg, rooms: dataclasses.replace(cfg, arch="chandran"),
}
"""Variant -> the one change it makes to the baseline config."""


def base_config(args, seed: int, noise: bool) -> TrainConfig:
    """The learning curve's old recipe under the oracle spot: ``train.recipe.seen_config`` with one
    room per batch and the ImageNet stem."""
    return seen_config(1, seed, noise, stem="imagenet", batch=args.batch, lr=args.lr, patience=args.patience)


def run_variant(args, rooms, variant: str, seed: int) -> dict:
    parts = variant.split("+")
    unknown = [p for p in parts if p not in CHANGES]
    if unknown:
        raise SystemExit(f"error: unknown variant {unknown[0]!r} (choose from {', '.join(CHANGES)})")
    cfg = base_config(args, seed, args.capture == "default")
    for p in parts:
        cfg = CHANGES[p](cfg, rooms)
    key = f"{args.capture}-{args.n}-{variant}-s{seed}" + (f"-min{args.min_steps}" if args.min_steps else "")
    groups = [[r] for r in rooms] if "per-room" in parts else [rooms]
    res = [run_seen(cfg, g, args.n, Path(args.runs) / (key + (f"-room{i}" if len(groups) > 1 else "")), args.epochs,
                    progress=not args.quiet, min_steps=args.min_steps) for i, g in enumerate(groups)]
    w = np.array([sum(r.test.num_samples for r in g) for g in groups], float)
    avg = lambda k: float(np.average([getattr(r, k) for r in res], weights=w))
    return {"variant": variant, "capture": args.capture, "people_per_room": args.n, "min_steps": args.min_steps,
            "rooms": len(rooms),
            "posture_accuracy": round(avg("posture_accuracy"), 2), "posture3_accuracy": round(avg("posture3_accuracy"), 2),
            "error_cm": round(avg("error_cm"), 2), "mean_answer_cm": round(avg("mean_answer_cm"), 2),
            "steps": int(sum(r.steps for r in res)), "seconds": round(sum(r.seconds for r in res), 1), "seed": seed}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="dataset whose train split holds the rooms")
    ap.add_argument("--n", type=int, default=1000, help="training people per room")
    ap.add_argument("--capture", choices=("noise-free", "default"), default="noise-free")
    ap.add_argument("--variants", default="baseline,per-room,mixed-batches")
    ap.add_argument("--rooms", type=int, default=0, help="use only the first ROOMS rooms (0: all)")
    ap.add_argument("--epochs", type=float, default=30)
    ap.add_argument("--min-steps", type=int, default=0, help="train at least this many steps")
    ap.add_argument("--patience", type=int, default=8)
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--runs", default="out/learning-ablation/runs")
    ap.add_argument("--out", default="docs/results")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    rooms = [split_room(s) for s in load_split(Path(args.data), "train", ["normals"], samples="images")]
    rooms = rooms[:args.rooms] if args.rooms else rooms
    if args.n > min(r.pool.num_samples for r in rooms):
        raise SystemExit(f"error: the rooms hold {min(r.pool.num_samples for r in rooms)} pool people, fewer than "
                         f"--n {args.n}")
    out = Path(args.out) / "learning-ablation.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    rows = list(csv.DictReader(out.open())) if out.exists() else []
    for variant in args.variants.split(","):
        for seed in range(args.seeds):
            row = run_variant(args, rooms, variant, seed)
            print(" ".join(f"{k}={row[k]}" for k in COLUMNS), flush=True)
            same = lambda r: all(str(r[k]) == str(row[k]) for k in ("variant", "capture", "people_per_room", "min_steps",
                                                                     "rooms", "seed"))
            rows = [r for r in rows if not same(r)] + [row]
            with out.open("w", newline="") as f:
                wr = csv.DictWriter(f, COLUMNS)
                wr.writeheader()
                wr.writerows(rows)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
