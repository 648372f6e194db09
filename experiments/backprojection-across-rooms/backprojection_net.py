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
from nlos_spotlight.data.backprojection import matched_filter
from nlos_spotlight.render.sensor import SensorConfig


CAPTURES = ("photo", "spot")
"""What the filter reads. 'photo': the photograph minus the empty-room one (the networks' input: the
person's light from the spot and from the room's ambient light). 'spot': also a projector-off
photograph with the person and one without, so that (on - off with) - (on - off without) leaves the
person's light from the spot alone, at the noise of four frames."""


def room_arrays(d: Path, faces: list[int] | None, samples: str, capture: str = "photo",
                mask: str = "placement") -> dict:
    """What training and scoring need of one room: its templates' parts, and its people's photographs
    (luminance, background-subtracted, noise-free; ``capture`` of :data:`CAPTURES`) and noise variance
    under each spot of ``faces`` (None: the room's stored spots)."""
    from nlos_spotlight.data.backprojection import FloorGrid, candidate_spot_factor, room_backprojector
    from nlos_spotlight.data.tensors import load_scene_tensors
    from nlos_spotlight.train.imaging import form_images, radiance_variance

    s = load_scene_tensors(d, [], samples=samples)
    grid = FloorGrid(mask=mask)
    bp, _ = room_backprojector(str(d), grid)
    sensor = SensorConfig.at(tuple(s.ambient.shape[:2]))
    faces = faces if faces is not None else [int(f) for f in torch.nonzero(s.stored).flatten()]
    hit = torch.as_tensor(bp.hit.ravel())
    imgs, var, spots = [], [], []
    idx = torch.arange(s.num_samples)
    for f in faces:
        y = torch.zeros(len(s.faces))
        y[f] = 1.0
        with torch.no_grad():
            img, pf = form_images(s, idx, y, "spot")
        v = 2 * radiance_variance(pf, pf, sensor)  # photograph and empty-room frame
        person = img - pf
        if capture == "spot":  # the two projector-off frames, at the same exposure
            v = v + 2 * radiance_variance(s.ambient, pf, sensor)
            person = person - s.nlos_ambient
        imgs.append(person.mean(-1).reshape(len(idx), -1)[:, hit])
        var.append((v.sum(-1) / 9).reshape(-1)[hit])
        spots.append(candidate_spot_factor(str(d), f, grid))
    return dict(kernel=torch.as_tensor(bp.kernel, dtype=torch.float32), valid=torch.as_tensor(bp.valid),
                cells=torch.as_tensor(bp.cells, dtype=torch.float32), heights=bp.heights,
                spots=torch.as_tensor(np.stack(spots), dtype=torch.float32), images=torch.stack(imgs, 1).float(),
                var=torch.stack(var).float(), target=s.target, posture=s.posture, faces=faces)


def heat(room: dict, k: int, people: torch.Tensor, gen: torch.Generator | None, templates: int = 1):
    """(B, M Z, G, G) noise-weighted matched filters of ``people`` under the room's k-th spot (fresh
    noise from ``gen``; None: noise-free): the spot's templates, and with ``templates`` 2 the kernel
    alone (a person lit evenly); the spot templates' norms (G, G)."""
    w = 1.0 / room["var"][k]
    x = room["images"][people, k]
    if gen is not None:
        x = x + torch.randn(x.shape, generator=gen) * room["var"][k].sqrt()
    n = int(round(len(room["cells"]) ** 0.5))
    hs, strength = [], None
    for t in [room["spots"][k][:, None] * room["kernel"], room["kernel"]][:templates]:  # (P, C)
        hs.append(matched_filter(x, t, w).reshape(len(people), -1, n, n))
        if strength is None:
            strength = ((t * t) @ w).sqrt().reshape(room["heights"], n, n).amax(0)
    return torch.cat(hs, 1), strength


def argmax_cell(room: dict, h: torch.Tensor) -> torch.Tensor:
    """(B, 2) the valid cell where the spot's filter (the first Z channels of ``h``) peaks."""
    m = h[:, : room["heights"]].amax(1).reshape(len(h), -1).masked_fill(~room["valid"][None], -torch.inf)
    return room["cells"][m.argmax(1)]


def predict(net, room: dict, k: int, people: torch.Tensor, gen) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    h, strength = heat(room, k, people, gen, net.cfg.templates)
    n = h.shape[-1]
    valid = room["valid"].reshape(n, n)
    pos, logits, _ = net(h, valid.expand(len(h), -1, -1), strength.expand(len(h), -1, -1), room["cells"])
    return pos, logits, argmax_cell(room, h)


def train_floor_net(args, t0: float):
    """FloorNet trained on the training rooms, the weights of its best validation error kept;
    returns it, the training rooms' mean position, the validation curve and its best error."""
    from nlos_spotlight.data.tensors import finished_scene_dirs
    from nlos_spotlight.models.floor_net import FloorNet, FloorNetConfig

    arrays = lambda split: [room_arrays(d, None, "images", args.capture, args.mask)
                            for d in finished_scene_dirs(args.train, split)]
    train, val = arrays("train")[: args.rooms], arrays("val")
    console.print(f"{len(train)} training and {len(val)} validation rooms ready ({time.perf_counter() - t0:.0f} s)")
    mean_xy = torch.cat([r["target"] for r in train]).mean(0)
    net = FloorNet(FloorNetConfig(heights=train[0]["heights"], templates=args.templates))
    opt = torch.optim.AdamW(net.parameters(), lr=args.lr, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, args.lr, total_steps=args.steps)
    gen = torch.Generator().manual_seed(args.seed)
    rng = np.random.default_rng(args.seed)
    curve, best, best_state = [], float("inf"), None

    def val_error() -> float:
        g = torch.Generator().manual_seed(12345)
        net.eval()
        errs = []
        with torch.no_grad():
            for r in val:
                for k in range(len(r["faces"])):
                    pos, _, _ = predict(net, r, k, torch.arange(len(r["target"])), g)
                    errs.append((pos - r["target"]).norm(dim=1))
        net.train()
        return float(torch.cat(errs).mean()) * 100

    for step in range(1, args.steps + 1):
        loss = 0.0
        for i in rng.choice(len(train), min(args.rooms_per_step, len(train)), replace=False):
            r = train[i]
            k = int(rng.integers(len(r["faces"])))
            people = torch.as_tensor(rng.choice(len(r["target"]), min(args.people_per_room, len(r["target"])),
                                                replace=False))
            pos, logits, _ = predict(net, r, k, people, gen)
            loss = loss + (pos - r["target"][people]).norm(dim=1).mean() \
                + 0.3 * torch.nn.functional.cross_entropy(logits, r["posture"][people])
        opt.zero_grad()
        (loss / args.rooms_per_step).backward()
        opt.step()
        sched.step()
        if step % 250 == 0 or step == args.steps:
            e = val_error()
            curve.append((step, e))
            if e < best:
                best, best_state = e, {k: v.clone() for k, v in net.state_dict().items()}
            console.print(f"step {step}: validation {e:.1f} cm (best {best:.1f}) ({time.perf_counter() - t0:.0f} s)")
    net.load_state_dict(best_state)
    return net, mean_xy, curve, best


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
        net, mean_xy, curve, best = train_floor_net(args, t0)
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
