"""The ceiling in seen rooms: posture accuracy and localization error against people per room.

In every training room of a dataset (``nlos_spotlight.train.recipe``: 10 % of each room's people
held out as test, 10 % as validation), train the NLOS network on the first N people of each room:

* the oracle spot, N in ``--sizes``, noise-free and with the default capture;
* the IEN (two-stage: SNR target, then frozen), Adaptive Lighting, center and random spots at the
  largest N with the default capture;
* ResNet-18 (the paper's backbone) once at the largest N beside the lighter backbone;
* with ``--burst N``, the oracle spot at the largest N with a still capture of N frames averaged.

``--per-room`` trains one network per room (what ``nlos fit`` does for a user's room) instead of one
network on every room's people; its scores pool the rooms' test people, and its chance level is each
room's own mean-position answer.

Each run is resumable and keeps its scores in ``--runs``/KEY/result.json; the table is
``--out``/learning-curve.csv (``protocol,capture,policy,people_per_room,posture_accuracy,
posture3_accuracy,error_cm,crb_cm,seeds``; accuracies in %, errors in cm), with ``arch`` and
``mean_answer_cm`` columns beside them, a JSON of the confusion matrices and a plot. ``crb_cm`` comes
from ``experiments/physics-bounds/position_crb.py`` (``--crb`` its JSON) where it was run.

    python experiments/seen-rooms-learning-curve/learning_curve.py --data out/lc/data [--sizes 100,300,1000,3000] [--epochs 30]
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.train.recipe import run_seen, seen_config, split_room
from nlos_spotlight.models.baselines import BASELINES
from nlos_spotlight.train.config import TrainConfig
from nlos_spotlight.data.tensors import load_scene_tensors, split_ids

COLUMNS = ["protocol", "capture", "policy", "people_per_room", "posture_accuracy", "posture3_accuracy", "error_cm",
           "crb_cm", "seeds", "arch", "mean_answer_cm", "steps", "seconds"]


def base_config(args, seed: int, backbone: str, rooms: int) -> TrainConfig:
    """The seen-rooms recipe (``train.recipe.seen_config``) with our network on ``backbone``
    (ResNet-18 with its small-image stem, the lighter one with ``--stem`` and ``--pool-grid``), or a
    baseline network of ``models.registry.NETWORKS`` by name."""
    if backbone in BASELINES:
        return seen_config(rooms, seed, arch=backbone, batch=args.batch, lr=args.lr, patience=args.patience)
    light = backbone != "resnet18"
    return seen_config(rooms, seed, backbone=backbone, stem=args.stem if light else "cifar",
                       pool_grid=args.pool_grid if light else 1, batch=args.batch, lr=args.lr, patience=args.patience)


def arch_label(backbone: str, stem: str, grid: int = 1) -> str:
    return backbone if backbone in ("resnet18", *BASELINES) else f"{backbone}/{stem}" + (f"/grid{grid}" if grid > 1 else "")


def plan(args) -> list[dict]:
    sizes = [int(v) for v in args.sizes.split(",")]
    runs = [dict(capture=c, policy="oracle", n=n, backbone=args.backbone) for n in sizes
            for c in ("noise-free", "default")]
    policy_capture = f"burst-{args.burst}" if args.policies_burst and args.burst > 1 else "default"
    runs += [dict(capture=policy_capture, policy=p, n=sizes[-1], backbone=args.backbone)
             for p in args.policies.split(",") if p]
    runs += [dict(capture=f"burst-{args.burst}", policy="oracle", n=sizes[-1], backbone=args.backbone)] \
        if args.burst > 1 else []
    runs = [] if args.other_networks_only else runs
    runs = [r for r in runs if r["capture"] in args.only.split(",")] if args.only else runs
    other_n = args.other_networks_size or sizes[-1]
    if args.resnet18:
        runs.append(dict(capture="default", policy="oracle", n=other_n, backbone="resnet18"))
    runs += [dict(capture="default", policy="oracle", n=other_n, backbone=a) for a in args.baselines.split(",") if a]
    return runs


def run_one(args, rooms, spec: dict, seed: int):
    """One run of the plan: a network on every room, or with ``--per-room`` one per room, pooled."""
    if not args.per_room:
        return run_spec(args, rooms, spec, seed, "")
    keep = [int(i) for i in args.room_indices.split(",")] if args.room_indices else range(len(rooms))
    return pool_results([run_spec(args, [rooms[i]], spec, seed, f"/room-{i}", room_index=i) for i in keep],
                        [rooms[i].test.num_samples for i in keep])


def pool_results(res: list, tests: list[int]):
    """Per-room results as one: scores weighted by each room's test people, confusions summed,
    steps and seconds summed (the compute of all the rooms' networks)."""
    w = np.asarray(tests, float) / sum(tests)
    avg = lambda k: float(np.dot(w, [getattr(r, k) for r in res]))
    return dataclasses.replace(
        res[0], **{k: avg(k) for k in ("posture_accuracy", "posture3_accuracy", "error_cm", "mean_answer_cm")},
        confusion=np.sum([r.confusion for r in res], axis=0).tolist(), spots=[s for r in res for s in r.spots],
        steps=sum(r.steps for r in res), seconds=sum(r.seconds for r in res))


def run_spec(args, rooms, spec: dict, seed: int, sub: str, room_index: int | None = None):
    """One training run on ``rooms``; ``room_index``: the one room's position in the train split
    (``--per-room``), whose key a random policy draws with (``lighting.policy_rng``), as the
    stored image samples were drawn."""
    cfg = base_config(args, seed, spec["backbone"], len(rooms))
    cfg = dataclasses.replace(cfg, sensor_noise=spec["capture"] != "noise-free")
    if spec["capture"].startswith("burst-"):  # a still capture averaging N frames (DESIGN section 6)
        cfg = dataclasses.replace(cfg, sensor={"burst_frames": int(spec["capture"].split("-")[1])})
    if spec["policy"] == "ien":
        cfg = dataclasses.replace(cfg, policy="ien", spot_steps=args.spot_steps)
    else:
        cfg = dataclasses.replace(cfg, policy=spec["policy"])
    if args.select != "loss":
        cfg = dataclasses.replace(cfg, select=args.select)
    if args.aux_weight > 0:  # facing and height as auxiliary targets
        cfg = dataclasses.replace(cfg, aux_weight=args.aux_weight, net=dataclasses.replace(cfg.net, aux_head=True))
    label = arch_label(spec["backbone"], args.stem, args.pool_grid).replace("/", "-")
    key = f"{spec['capture']}-{spec['policy']}-{spec['n']}-{label}-s{seed}" + ("-per-room" if args.per_room else "") \
        + (f"-aux{args.aux_weight:g}" if args.aux_weight > 0 else "") + (f"-sel-{args.select}" if args.select != "loss" else "")
    epochs = args.epochs * (args.resnet18_epoch_scale if spec["backbone"] == "resnet18" else 1.0)
    spots = None
    if room_index is not None and spec["policy"] != "ien":  # the room's own draw, not room 0's
        from nlos_spotlight.lighting import POLICIES, policy_rng

        s = rooms[0].pool
        spots = [POLICIES[spec["policy"]](s, Path(s.scene_dir), policy_rng(cfg.seed, room_index)).face]
    return run_seen(cfg, rooms, spec["n"], Path(args.runs) / (key + sub), epochs, progress=not args.quiet,
                    min_steps=args.min_steps, spots=spots)


def load_rooms(data: Path) -> list:
    """The training rooms' image samples; a dataset still being generated (no manifest yet) gives the
    rooms whose stored spots exist, with the people written so far (a prefix in index order)."""
    if (data / "manifest.json").exists():
        ids = split_ids(data, "train")
    else:
        ids = sorted(p.name for p in (data / "scenes").glob("train-*") if (p / "spots.json").exists())
        print(f"{data}: unfinished dataset, using {len(ids)} rooms as generated so far", flush=True)
    return [load_scene_tensors(data / "scenes" / sid, ["normals"], samples="images") for sid in ids]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="dataset whose train split holds the rooms")
    ap.add_argument("--sizes", default="100,300,1000,3000", help="training people per room")
    ap.add_argument("--policies", default="ien,adaptive,center,random", help="other spots at the largest size")
    ap.add_argument("--backbone", default="resnet10-narrow")
    ap.add_argument("--stem", default="half", help="stem of the lighter backbone: half (stride 2; the best in "
                                                   "experiments/seen-rooms-learning-curve/learning_ablation.py), "
                                                   "imagenet (stride 4) or cifar")
    ap.add_argument("--pool-grid", type=int, default=1, help="lighter backbone: last map pooled to g x g cells")
    ap.add_argument("--min-steps", type=int, default=0, help="train at least this many steps at any size")
    ap.add_argument("--resnet18", action="store_true", help="also ResNet-18 once at the largest size")
    ap.add_argument("--resnet18-epoch-scale", type=float, default=0.5)
    ap.add_argument("--baselines", default="", help="baseline networks (e.g. chandran) also run at the largest size")
    ap.add_argument("--other-networks-size", type=int, default=0,
                    help="people per room of the ResNet-18 and baseline runs (default: the largest size)")
    ap.add_argument("--burst", type=int, default=0,
                    help="also the oracle spot at the largest size with a still capture of this many frames")
    ap.add_argument("--policies-burst", action="store_true",
                    help="the other spots with the --burst capture instead of the default one")
    ap.add_argument("--other-networks-only", action="store_true",
                    help="only the ResNet-18 and baseline runs (a second process beside the curve's)")
    ap.add_argument("--per-room", action="store_true",
                    help="one network per room (as nlos fit trains), scores pooled over the rooms")
    ap.add_argument("--room-indices", default="", help="--per-room: only these rooms (comma-separated indices)")
    ap.add_argument("--select", default="loss", choices=["loss", "metrics", "last"],
                    help="best weights by validation loss, by posture and position errors, or the last ones")
    ap.add_argument("--aux-weight", type=float, default=0.0,
                    help="facing and height as auxiliary targets with this loss weight (0: none)")
    ap.add_argument("--only", default="", help="only these captures of the plan, comma-separated (e.g. burst-16)")
    ap.add_argument("--epochs", type=float, default=40)
    ap.add_argument("--patience", type=int, default=8)
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--spot-steps", type=int, default=300)
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--runs", default="out/learning-curve/runs")
    ap.add_argument("--out", default="docs/results")
    ap.add_argument("--crb", default="", help="JSON of experiments/physics-bounds/position_crb.py: crb_cm per policy")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    rooms = [split_room(s) for s in load_rooms(Path(args.data))]
    print(f"{len(rooms)} rooms; pool/val/test people per room: "
          + ", ".join(f"{r.pool.num_samples}/{r.val.num_samples}/{r.test.num_samples}" for r in rooms), flush=True)
    crb = json.loads(Path(args.crb).read_text()) if args.crb else {}
    rows, confusions = [], {}
    for spec in plan(args):
        if spec["n"] > min(r.pool.num_samples for r in rooms) and not (Path(args.data) / "manifest.json").exists():
            rooms = [split_room(s) for s in load_rooms(Path(args.data))]  # still being generated: reload
        if spec["n"] > min(r.pool.num_samples for r in rooms):
            print(f"skip {spec}: the rooms hold fewer pool people", flush=True)
            continue
        res = [run_one(args, rooms, spec, seed) for seed in range(args.seeds)]
        mean = lambda k: float(np.mean([getattr(r, k) for r in res]))
        row = {"protocol": "seen", "capture": spec["capture"], "policy": spec["policy"],
               "people_per_room": spec["n"], "posture_accuracy": round(mean("posture_accuracy"), 2),
               "posture3_accuracy": round(mean("posture3_accuracy"), 2), "error_cm": round(mean("error_cm"), 2),
               "crb_cm": crb.get(spec["policy"], "") if spec["capture"] == "default" else "",
               "seeds": len(res),
               "arch": arch_label(spec["backbone"], args.stem, args.pool_grid) + ("/per-room" if args.per_room else "")
               + ("/aux" if args.aux_weight > 0 else "") + (f"/sel-{args.select}" if args.select != "loss" else ""),
               "mean_answer_cm": round(mean("mean_answer_cm"), 2),
               "steps": int(mean("steps")), "seconds": round(mean("seconds"), 1)}
        rows.append(row)
        confusions[f"{spec['capture']}-{spec['policy']}-{spec['n']}-{spec['backbone']}"] = \
            np.sum([r.confusion for r in res], axis=0).tolist()
        print(" ".join(f"{k}={row[k]}" for k in COLUMNS), flush=True)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with (out / "learning-curve.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, COLUMNS)
        w.writeheader()
        w.writerows(rows)
    (out / "learning-curve-confusion.json").write_text(json.dumps(confusions, indent=1))
    plot(rows, out / "learning-curve.png")
    print(f"wrote {out / 'learning-curve.csv'} and learning-curve.png")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(13, 3.8))
    for capture, style in (("noise-free", "--"), ("default", "-")):
        sel = [r for r in rows
               if r["capture"] == capture and r["policy"] == "oracle" and r["arch"].startswith("resnet10")]
        if not sel:
            continue
        n = [r["people_per_room"] for r in sel]
        for a, key in zip(ax, ("posture_accuracy", "posture3_accuracy", "error_cm")):
            a.plot(n, [r[key] for r in sel], style, marker="o", label=f"oracle spot, {capture}")
    top = max((r["people_per_room"] for r in rows), default=0)
    for r in rows:
        other_net = not r["arch"].startswith("resnet10")
        burst = r["capture"].startswith("burst")
        if r["people_per_room"] == top and (r["policy"] != "oracle" or other_net or burst):
            label = r["policy"] + (f" ({r['arch']})" if other_net else "") + (f", {r['capture']}" if burst else "")
            for a, key in zip(ax, ("posture_accuracy", "posture3_accuracy", "error_cm")):
                a.scatter([top], [r[key]], marker="x")
                a.annotate(label, (top, r[key]), fontsize=7)
    for a, title in zip(ax, ("posture accuracy (6 classes), %", "upright/sitting/crouching, %",
                             "localization error, cm")):
        a.set_xscale("log")
        a.set_xlabel("training people per room")
        a.set_title(title, fontsize=10)
    ax[0].axhline(100 / 6, color="gray", lw=0.5)
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
