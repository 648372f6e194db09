"""Rooms never seen in training: the image-only and the geometry-aware network against training rooms.

Trains the NLOS network on the first R rooms of a training dataset (``benchmarks/configs/
unseen-train.yaml``), for every R in ``--rooms`` (the learning curve over rooms), choosing the best
weights on the dataset's validation rooms, and scores it on the rooms of a test dataset
(``unseen-test.yaml``) it never saw, under each spot policy of ``--policies`` there:

* ``image``: the photograph minus the empty-room photograph (the seen-rooms recipe's network,
  ``train.recipe.seen_config``);
* ``geometry``: the same network with the room's per-pixel geometry and the spot's lit fraction
  (``data.geometry``) as ten more input channels.
* ``chandran``, ``tancik``, ``dlnlos``: the published baselines' networks (docs/baselines.md), Chandran's
  under every stored spot like the two above, Tancik's under the flash and DL-NLOS's under the
  room's ambient light only (and scored under those).

Both train on the same people under the same budget, every room lit by a stored spot drawn afresh
each step (``spot_augment``: each person gives the network ~10 illuminations, and a network can be
scored under any policy's spot). With ``--ien`` the IEN is trained across the training rooms on
their full-transport people (its SNR target: two-stage training's first stage) and scored on the
test rooms as the fraction of the oracle spot's SNR, beside Adaptive Lighting, center and random;
its spot then joins ``--policies``.

Writes ``--out``/unseen-rooms.csv (``net,capture,policy,train_rooms,seed,posture_accuracy,
posture3_accuracy,error_cm,mean_answer_cm,steps,seconds``), ``--out``/spot-snr.csv, and a plot of
the learning curve over rooms. Resumable: every run keeps its weights and scores in ``--runs``.

    python experiments/unseen-rooms/unseen_rooms.py --train out/unseen/train --test out/unseen/test \\
        [--rooms 25,50,100,200] [--nets image,geometry,chandran,tancik,dlnlos] [--policies oracle,adaptive,center,random] [--ien] \
        [--epochs 40 | --steps 2400]
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

from nlos_spotlight.data.tensors import finished_scene_dirs, load_scene_tensors
from nlos_spotlight.data.store import atomic_npz
from nlos_spotlight.train.recipe import seen_config
from nlos_spotlight.evaluate.seen import score_rooms
from nlos_spotlight.evaluate.unseen import as_pairs, mean_answer, room_lights, snr_fraction, train_unseen

COLUMNS = ["net", "capture", "policy", "train_rooms", "seed", "posture_accuracy", "posture3_accuracy", "error_cm",
           "mean_answer_cm", "steps", "seconds"]


def load_rooms(data: Path, split: str, samples: str, limit: int = 0, features: tuple = ("normals",)) -> list:
    """The split's rooms (the first ``limit``); on a dataset still being generated, its finished rooms."""
    dirs = finished_scene_dirs(data, split)
    if not (data / "manifest.json").exists():
        print(f"{data}: unfinished dataset, {len(dirs)} finished {split} rooms so far", flush=True)
    dirs = dirs[:limit] if limit else dirs
    return [load_scene_tensors(d, list(features), samples) for d in dirs]


BASELINE_LIGHT = {"chandran": None, "tancik": "flash", "dlnlos": "ambient"}
"""Baseline network (docs/baselines.md) -> the illumination it is built for (None: any stored spot)."""


def net_config(args, net: str, rooms: int, seed: int, noise: bool):
    """The training config of ``net``: 'image' and 'geometry' (the lighter ResNet without and with the
    geometry channels) and the spot baselines train under every stored spot (``spot_augment``); the
    flash and ambient baselines under their own illumination only."""
    light = BASELINE_LIGHT.get(net)
    cfg = seen_config(rooms, seed, noise=noise, policy=light or "oracle", batch=args.batch, lr=args.lr,
                      patience=args.patience, backbone=args.backbone, pool_grid=args.pool_grid,
                      arch=net if net in BASELINE_LIGHT else "resnet18")
    cfg = dataclasses.replace(cfg, spot_augment=light is None, holdout_every=0,
                              scenes_per_step=min(rooms, args.scenes_per_step),
                              net=dataclasses.replace(cfg.net, geometry=net == "geometry"))
    return cfg


def net_policies(net: str, policies: list[str]) -> list[str]:
    """The test-room policies a network is scored under (a flash or ambient baseline: its own)."""
    light = BASELINE_LIGHT.get(net)
    return [light] if light else policies


def train_ien(args, rooms: list, out: Path):
    """The IEN trained on its SNR target across ``rooms`` (their full-transport people)."""
    from nlos_spotlight.models.ien import IENConfig
    from nlos_spotlight.train.config import TrainConfig
    from nlos_spotlight.train.loop import Trainer

    path = out / "ien.pt"
    cfg = TrainConfig(name="unseen-ien", seed=0, policy="ien", spot_steps=args.ien_steps, steps=1, snr_weight=1.0,
                      scenes_per_step=min(len(rooms), 8), batch_size=8, device="auto",
                      ien=IENConfig(prior_weight=args.ien_prior_weight))
    tr = Trainer(cfg, rooms, out)
    if path.exists():
        tr.ien.load_state_dict(torch.load(path, weights_only=True))
        return tr.ien.eval()
    t0 = time.perf_counter()
    while tr.in_spot_stage:
        tr.spot_step()
    out.mkdir(parents=True, exist_ok=True)
    torch.save(tr.ien.state_dict(), path)
    print(f"IEN: {cfg.spot_steps} steps on {len(rooms)} rooms in {time.perf_counter() - t0:.0f} s", flush=True)
    return tr.ien.eval()


def scores(args, tr, cfg, test_rooms, policy: str, lights, out: Path) -> dict:
    """The run's scores under ``policy``'s spots; every person's prediction goes to
    ``predictions-POLICY-NROOMS.npz`` beside them (``unseen_rooms_table.py --per-class``)."""
    path = out / f"scores-{policy}-{len(test_rooms)}rooms.json"
    npz = path.with_name(f"predictions-{policy}-{len(test_rooms)}rooms.npz")
    if path.exists() and npz.exists():
        return json.loads(path.read_text())
    res = score_rooms(tr.net, cfg.net, tr.sensor, test_rooms, as_pairs(test_rooms, lights), cfg.sensor_noise,
                      cfg.seed)
    per = res.pop("per_person")
    res.pop("photos")
    per["trajectory"] = torch.cat([s.trajectory for s in test_rooms]).numpy()  # (N, 2) walk id, frame
    atomic_npz(npz, **per)
    path.write_text(json.dumps(res, indent=1))
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", type=Path, required=True, help="training dataset (train and val splits)")
    ap.add_argument("--test", type=Path, required=True, help="test dataset of other rooms (test split)")
    ap.add_argument("--rooms", default="25,50,100,200", help="training rooms per run (the first R)")
    ap.add_argument("--nets", default="image,geometry")
    ap.add_argument("--policies", default="oracle,adaptive,center,random", help="test-room spot policies")
    ap.add_argument("--captures", default="default", help="noise-free and/or default")
    ap.add_argument("--test-rooms", type=int, default=0, help="score on the first N test rooms only (0: all)")
    ap.add_argument("--test-split", default="test", help="split of --test to score on")
    ap.add_argument("--test-offset", type=int, default=0,
                    help="skip the first N rooms of that split (quick checks on later training rooms)")
    ap.add_argument("--test-samples", default="transport",
                    help="sample kind of the test rooms: transport (any spot) or images (stored spots only)")
    ap.add_argument("--ien", action="store_true", help="train the IEN across rooms and score its spot too")
    ap.add_argument("--ien-steps", type=int, default=2000)
    ap.add_argument("--ien-features", default="normals",
                    help="the IEN's vertex features (experiments/ien-across-rooms/ien_across_rooms.py), "
                         "e.g. normals,adaptive")
    ap.add_argument("--ien-prior-weight", type=float, default=0.0,
                    help="with 'adaptive' features: this times the log prior in the IEN's logits")
    ap.add_argument("--epochs", type=float, default=40.0, help="passes over the training people")
    ap.add_argument("--steps", type=int, default=0,
                    help="steps per run whatever the rooms (the same budget at every point of the curve); 0: --epochs")
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--scenes-per-step", type=int, default=16, help="rooms mixed in each batch")
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--patience", type=int, default=0)
    ap.add_argument("--val-every", type=int, default=0, help="steps between validation passes (0: ~25 a run)")
    ap.add_argument("--backbone", default="resnet10-narrow", help="feature extractor (models.resnet.BACKBONES)")
    ap.add_argument("--pool-grid", type=int, default=1, help="last feature map pooled to g x g (1: global average)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--runs", type=Path, default=Path("out/unseen/runs"))
    ap.add_argument("--out", type=Path, default=Path("docs/results/unseen"))
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    sizes = [int(r) for r in args.rooms.split(",")]
    policies = [p for p in args.policies.split(",") if p]
    nets = [n for n in args.nets.split(",") if n]
    bad = [n for n in nets if n not in ("image", "geometry", *BASELINE_LIGHT)]
    if bad:
        raise SystemExit(f"--nets: unknown network '{bad[0]}' (image, geometry, {', '.join(BASELINE_LIGHT)})")
    train_all = load_rooms(args.train, "train", "images", max(sizes))
    sizes = [r for r in sizes if r <= len(train_all)] or [len(train_all)]
    val = load_rooms(args.train, "val", "images")
    feats = tuple(f for f in args.ien_features.split(",") if f) if args.ien else ("normals",)
    test = load_rooms(args.test, args.test_split, args.test_samples,
                      args.test_offset + args.test_rooms if args.test_rooms else 0, feats)
    test = test[args.test_offset:]
    if args.test == args.train and args.test_split == "train" and args.test_offset < max(sizes):
        raise SystemExit("--test-offset: the test rooms must come after every training room")
    print(f"{len(train_all)} training rooms, {len(val)} validation rooms, {len(test)} test rooms "
          f"({sum(s.num_samples for s in test)} test people)", flush=True)
    extra = [BASELINE_LIGHT[n] for n in nets if BASELINE_LIGHT.get(n)]
    lights = {p: room_lights(test, p, 0) for p in policies + extra}
    if args.ien:
        tag = "-".join(feats) + (f"-prior{args.ien_prior_weight:g}" if args.ien_prior_weight else "")
        ien = train_ien(args, load_rooms(args.train, "train", "transport", max(sizes), feats),
                        args.runs / f"ien-{tag}-{args.ien_steps}steps")
        lights["ien"] = room_lights(test, "ien", 0, ien)
        policies.append("ien")
    write_snr(args, test, {p: lights[p] for p in policies})
    rows = []
    for capture in args.captures.split(","):
        for net in nets:
            for r in sizes:
                for seed in range(args.seeds):
                    rows += run(args, net, capture, r, seed, train_all[:r], val, test, policies, lights)
                    write_rows(args.out, rows)
    plot(rows, args.out / "unseen-rooms.png")


def run(args, net, capture, r, seed, train, val, test, policies, lights) -> list[dict]:
    noise = capture != "noise-free"
    cfg = net_config(args, net, r, seed, noise)
    people = sum(s.num_samples for s in train)
    per_epoch = max(1, people // cfg.batch_size)
    steps = args.steps or max(1, round(args.epochs * per_epoch))
    every = args.val_every or max(per_epoch, steps // 25)
    cfg = dataclasses.replace(cfg, steps=steps, eval_every=every, ckpt_every=every, log_every=every)
    variant = "" if net in BASELINE_LIGHT else ("" if args.backbone == "resnet10-narrow" else f"-{args.backbone}") + \
        ("" if args.pool_grid == 1 else f"-pool{args.pool_grid}")
    out = args.runs / f"{capture}-{net}{variant}-{r}rooms-s{seed}"
    t0 = time.perf_counter()
    tr = train_unseen(cfg, train, val, room_lights(val, BASELINE_LIGHT.get(net) or "oracle", seed), out, progress=True)
    seconds = time.perf_counter() - t0
    rows = []
    for p in net_policies(net, policies):
        res = scores(args, tr, cfg, test, p, lights[p], out)
        rows.append({"net": net + variant, "capture": capture, "policy": p, "train_rooms": r, "seed": seed,
                     "posture_accuracy": round(res["posture_accuracy"], 2),
                     "posture3_accuracy": round(res["posture3_accuracy"], 2), "error_cm": round(res["error_cm"], 2),
                     "mean_answer_cm": round(mean_answer(train, test), 2), "steps": cfg.steps,
                     "seconds": round(seconds)})
        print(" ".join(f"{k}={v}" for k, v in rows[-1].items()), flush=True)
    return rows


def write_rows(out: Path, rows: list[dict]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / ".unseen-rooms.csv.tmp"
    with tmp.open("w", newline="") as f:
        w = csv.DictWriter(f, COLUMNS)
        w.writeheader()
        w.writerows(rows)
    tmp.replace(out / "unseen-rooms.csv")


def write_snr(args, test, lights: dict) -> None:
    args.out.mkdir(parents=True, exist_ok=True)
    with (args.out / "spot-snr.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["policy", "test_rooms", "snr_fraction_mean", "snr_fraction_median"])
        for p, ls in lights.items():
            frac = snr_fraction(test, ls)
            w.writerow([p, len(test), round(float(frac.mean()), 3), round(float(np.median(frac)), 3)])
            print(f"spot SNR / oracle's on {len(test)} test rooms: {p} {frac.mean():.3f}", flush=True)


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in rows if r["policy"] == "oracle"]
    if not rows:
        return
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.5))
    for net in sorted({r["net"] for r in rows}):
        for capture in sorted({r["capture"] for r in rows}):
            rs = sorted((r for r in rows if r["net"] == net and r["capture"] == capture), key=lambda r: r["train_rooms"])
            x = [r["train_rooms"] for r in rs]
            ax[0].plot(x, [r["posture_accuracy"] for r in rs], "o-", label=f"{net}, {capture}")
            ax[1].plot(x, [r["error_cm"] for r in rs], "o-", label=f"{net}, {capture}")
    ax[1].plot(x, [rs[0]["mean_answer_cm"]] * len(x), "k--", label="mean answer")
    for a, lab in zip(ax, ("posture accuracy (6-way), %", "localization error, cm")):
        a.set_xscale("log")
        a.set_xlabel("training rooms")
        a.set_ylabel(lab)
    ax[0].legend(fontsize=7)
    ax[1].legend(fontsize=7)
    fig.suptitle("unseen test rooms, oracle spot")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
