"""Does a network on the backprojection carry over to rooms it never saw? (issue 12)

Trains ``models/floor_net.FloorNet`` on the matched-filter maps (``data/backprojection.py``) of the
training rooms' image samples under each room's stored spots, with the default capture's noise
drawn afresh every step (Gaussian in luminance with the sensor's variance per pixel, empty-room
frame included), keeps the weights with the lowest error on the validation rooms, and scores the
test rooms' people under each policy's spot, beside the matched filter's own best cell on the
same noisy photographs.

    python experiments/backprojection-across-rooms/backprojection_net.py --train out/unseen/train --test out/unseen/test \\
        [--rooms 200] [--steps 3000] [--templates 1|2] [--capture photo|spot] [--mask placement|free] \\
        [--seed 0] [--ien IEN_PT] [--out DIR]

Writes ``DIR/backprojection-net.csv`` (policy, method, error_cm, posture_accuracy, posture3_accuracy
(upright / sitting / crouching), people) and
``DIR/run.json`` (arguments, versions, seconds, the validation curve), and every test person's
prediction under each policy in ``DIR/predictions-POLICY.npz`` (room, true_xy, pred_xy, true_posture,
pred_posture, trajectory: the arrays of ``evaluate.seen.score_rooms``' ``per_person``).
"""

from __future__ import annotations

import argparse
import csv
import json
import platform
import time
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.console import console


from nlos_spotlight.train.floor_net import CAPTURES, FloorNetTraining, predict, room_arrays, train_floor_net


def train(args, t0: float):
    """FloorNet trained on the training rooms (``train.floor_net.train_floor_net``), the weights of
    its best validation error kept; returns it, the training rooms' mean position, the validation
    curve and its best error."""
    from nlos_spotlight.data.tensors import finished_scene_dirs

    arrays = lambda split: [room_arrays(d, None, "images", args.capture, args.mask)
                            for d in finished_scene_dirs(args.train, split)]
    train_rooms, val = arrays("train")[: args.rooms], arrays("val")
    console.print(f"{len(train_rooms)} training and {len(val)} validation rooms ready ({time.perf_counter() - t0:.0f} s)")
    cfg = FloorNetTraining(rooms=args.rooms, steps=args.steps, rooms_per_step=args.rooms_per_step,
                           people_per_room=args.people_per_room, lr=args.lr, templates=args.templates,
                           capture=args.capture, mask=args.mask, seed=args.seed)
    run = train_floor_net(cfg, train_rooms, val, lambda m: console.print(f"{m} ({time.perf_counter() - t0:.0f} s)"))
    return run.net, run.mean_xy, run.curve, run.best_cm


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", required=True)
    ap.add_argument("--test", required=True)
    ap.add_argument("--rooms", type=int, default=200, help="training rooms")
    ap.add_argument("--test-rooms", type=int, default=40)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--rooms-per-step", type=int, default=4)
    ap.add_argument("--people-per-room", type=int, default=16)
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--policies", default="oracle,adaptive,center,random")
    ap.add_argument("--templates", type=int, default=1, choices=(1, 2),
                    help="2: also the filter of a person lit evenly (the person's ambient light)")
    ap.add_argument("--ien", type=Path, default=None,
                    help="ien.pt of experiments/unseen-rooms/unseen_rooms.py --ien (features normals,adaptive, "
                         "prior weight 1): score its spot too")
    ap.add_argument("--capture", choices=CAPTURES, default="photo",
                    help="spot: projector-off frames too, the person's ambient light removed (CAPTURES)")
    ap.add_argument("--mask", choices=("placement", "free"), default="placement",
                    help="cells a person may stand in (data.backprojection.FloorGrid.mask)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("out/backprojection-net"))
    args = ap.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(args.seed)
    from nlos_spotlight.data.store import atomic_npz
    from nlos_spotlight.data.tensors import finished_scene_dirs, load_scene_tensors
    from nlos_spotlight.evaluate.seen import GROUP_OF
    from nlos_spotlight.lighting import policy_rng
    from nlos_spotlight.lighting.learned import policy_named
    from nlos_spotlight.models.floor_net import FloorNet, FloorNetConfig

    t0 = time.perf_counter()
    args.out.mkdir(parents=True, exist_ok=True)
    weights = args.out / "floor_net.pt"
    if weights.exists():  # trained before: score only (e.g. with --ien added)
        console.print(f"{weights}: trained weights found, scoring only")
        mean_xy = torch.cat([load_scene_tensors(d, [], samples="images").target
                             for d in finished_scene_dirs(args.train, "train")[: args.rooms]]).mean(0)
        net = FloorNet(FloorNetConfig(templates=args.templates))
        net.load_state_dict(torch.load(weights, weights_only=True))
        before = json.loads((args.out / "run.json").read_text())
        curve, best = before["validation_cm"], before["best_validation_cm"]
        train_seconds = before.get("train_seconds")  # runs scored again before this field: unknown
    else:
        net, mean_xy, curve, best = train(args, t0)
        train_seconds = time.perf_counter() - t0
        torch.save(net.state_dict(), weights)
    net.eval()
    rows = []
    test_dirs = finished_scene_dirs(args.test, "test")[: args.test_rooms]
    policies, ien, feats = args.policies.split(","), None, []
    if args.ien:
        from nlos_spotlight.models.ien import IEN, IENConfig

        feats = ["normals", "adaptive"]
        ien = IEN(IENConfig(in_features=7, prior_weight=1.0))
        ien.load_state_dict(torch.load(args.ien, weights_only=True))
        ien.eval()
        policies.append("ien")
    acc = {(p, m): [[], [], []] for p in policies for m in ("floor-net", "matched-filter", "mean answer")}
    group = torch.as_tensor(GROUP_OF)
    per = {p: {k: [] for k in ("room", "true_xy", "pred_xy", "true_posture", "pred_posture", "trajectory")}
           for p in policies}
    for i, d in enumerate(test_dirs):  # rooms outside: one backprojector a room
        s = load_scene_tensors(d, feats, samples="transport")
        # the i-th test room's key, as experiments/unseen-rooms/unseen_rooms.py draws it (evaluate.unseen.room_lights)
        faces = [policy_named(policy, ien)(s, Path(d), policy_rng(args.seed, i, new_room=True)).face
                 for policy in policies]
        r = room_arrays(d, faces, "transport", args.capture, args.mask)
        for k, policy in enumerate(policies):
            g = torch.Generator().manual_seed(1000 * args.seed + i)
            with torch.no_grad():
                pos, logits, cell = predict(net, r, k, torch.arange(len(r["target"])), g)
            for m, p in (("floor-net", pos), ("matched-filter", cell), ("mean answer", mean_xy.expand_as(pos))):
                acc[policy, m][0].append((p - r["target"]).norm(dim=1))
            guess = logits.argmax(1)
            for key, v in (("room", torch.full((len(pos),), i)), ("true_xy", r["target"]), ("pred_xy", pos),
                           ("true_posture", r["posture"]), ("pred_posture", guess), ("trajectory", s.trajectory)):
                per[policy][key].append(v.numpy())
            acc[policy, "floor-net"][1].append(guess == r["posture"])
            acc[policy, "floor-net"][2].append(group[guess] == group[r["posture"]])
    pct = lambda c: round(float(torch.cat(c).float().mean()) * 100, 1) if c else ""
    for (policy, m), (e, c, c3) in acc.items():
        rows.append(dict(policy=policy, method=m, error_cm=round(float(torch.cat(e).mean()) * 100, 2),
                         posture_accuracy=pct(c), posture3_accuracy=pct(c3), people=int(sum(len(x) for x in e))))
        console.print(f"{policy:9s} {m:15s} {rows[-1]['error_cm']:6.1f} cm  posture {rows[-1]['posture_accuracy']} "
                      f"/ {rows[-1]['posture3_accuracy']}")
    for policy, cols in per.items():
        atomic_npz(args.out / f"predictions-{policy}.npz", **{k: np.concatenate(v) for k, v in cols.items()})
    with open(args.out / "backprojection-net.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    (args.out / "run.json").write_text(json.dumps(dict(
        args={k: str(v) for k, v in vars(args).items()}, validation_cm=curve, best_validation_cm=best,
        mean_xy=mean_xy.tolist(),
        train_seconds=train_seconds, seconds=time.perf_counter() - t0, torch=torch.__version__, python=platform.python_version()), indent=1))


if __name__ == "__main__":
    main()
