"""FloorNet in the learning curve's rooms: physics first against 3,000 people of the room (issues 10, 12).

The learning curve (``experiments/seen-rooms-learning-curve/learning_curve.py``,
``docs/results/learning-curve.csv``) trains an image network on up to 3,000 people of each of its 3
rooms and scores the 100 held-out people of each (``train.recipe.split_masks``). Here the FloorNet
of ``backprojection_net.py`` (this folder), trained on the 200 rooms of the unseen-room datasets and on no person of these rooms, reads the
same held-out people's photographs (default capture, noise drawn with a fixed seed per room) under
each policy's spot, through the matched filter of each room's own scan. The answer for the mean is
the room's training pool's mean position, as in the learning curve.

With ``--finetune STEPS`` the FloorNet then trains on these rooms as the learning curve's network
does: on each room's training pool (up to ``--people`` a room) under its stored spots, fresh noise
every step, the weights of the lowest error on the rooms' validation people kept (the seen-rooms
protocol), starting from the 200-room weights.

    python experiments/backprojection-across-rooms/backprojection_seen.py --data out/lc/data \\
        --run out/backprojection-net/t2-s0 [--policies oracle,adaptive,center,random] [--finetune STEPS] [--people 3000] [--seed 0] \\
        [--out docs/results/backprojection-seen.csv]
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.train.floor_net import predict, room_arrays
from nlos_spotlight.console import console


def finetune(net, rooms: list[tuple[dict, torch.Tensor, torch.Tensor]], steps: int, lr: float, seed: int):
    """Train ``net`` on the rooms' (arrays, pool, validation) people under their stored spots, as
    ``backprojection_net.train_floor_net`` does; the weights of the best validation error kept.
    Returns the validation curve [(step, cm)]."""
    opt = torch.optim.AdamW(net.parameters(), lr=lr, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, lr, total_steps=steps)
    gen, rng = torch.Generator().manual_seed(seed), np.random.default_rng(seed)

    def val_error() -> float:
        g, errs = torch.Generator().manual_seed(12345), []
        net.eval()
        with torch.no_grad():
            for r, _, val in rooms:
                for k in range(len(r["faces"])):
                    errs.append((predict(net, r, k, val, g)[0] - r["target"][val]).norm(dim=1))
        net.train()
        return float(torch.cat(errs).mean()) * 100

    curve = [(0, val_error())]
    best, best_state = curve[0][1], {k: v.clone() for k, v in net.state_dict().items()}
    net.train()
    for step in range(1, steps + 1):
        loss = 0.0
        for r, pool, _ in rooms:
            k = int(rng.integers(len(r["faces"])))
            people = pool[torch.as_tensor(rng.choice(len(pool), min(16, len(pool)), replace=False))]
            pos, logits, _ = predict(net, r, k, people, gen)
            loss = loss + (pos - r["target"][people]).norm(dim=1).mean() \
                + 0.3 * torch.nn.functional.cross_entropy(logits, r["posture"][people])
        opt.zero_grad()
        (loss / len(rooms)).backward()
        opt.step()
        sched.step()
        if step % 250 == 0 or step == steps:
            curve.append((step, val_error()))
            if curve[-1][1] < best:
                best, best_state = curve[-1][1], {k: v.clone() for k, v in net.state_dict().items()}
            console.print(f"step {step}: validation {curve[-1][1]:.1f} cm (best {best:.1f})")
    net.load_state_dict(best_state)
    net.eval()
    return curve


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, required=True, help="the learning curve's dataset")
    ap.add_argument("--run", type=Path, required=True, help="a backprojection_net.py output directory")
    ap.add_argument("--policies", default="oracle,adaptive,center,random")
    ap.add_argument("--finetune", type=int, default=0, help="steps of training on these rooms' pools (0: none)")
    ap.add_argument("--people", type=int, default=3000, help="training people a room for --finetune")
    ap.add_argument("--lr", type=float, default=5e-4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("docs/results/backprojection-seen.csv"))
    args = ap.parse_args()
    torch.set_num_threads(1)
    from nlos_spotlight.data.tensors import finished_scene_dirs, load_scene_tensors
    from nlos_spotlight.train.recipe import split_masks
    from nlos_spotlight.evaluate.seen import GROUP_OF
    from nlos_spotlight.lighting import POLICIES, policy_rng
    from nlos_spotlight.models.floor_net import FloorNet, FloorNetConfig

    run = json.loads((args.run / "run.json").read_text())["args"]
    net = FloorNet(FloorNetConfig(templates=int(run["templates"])))
    net.load_state_dict(torch.load(args.run / "floor_net.pt", weights_only=True))
    net.eval()
    policies = args.policies.split(",")
    group = torch.as_tensor(GROUP_OF)
    acc = {(p, m): [[], [], []] for p in policies for m in ("floor-net", "matched-filter", "mean answer")}
    rooms = []
    for i, d in enumerate(finished_scene_dirs(args.data, "train")):
        s = load_scene_tensors(d, [], samples="images")
        pool, val, test = (torch.nonzero(m).flatten() for m in split_masks(s))
        st = load_scene_tensors(d, [], samples="transport")  # the oracle's SNR estimate reads these
        faces = [POLICIES[p](st, Path(d), policy_rng(args.seed, i)).face for p in policies]
        stored = [int(f) for f in torch.nonzero(s.stored).flatten()]
        r = room_arrays(d, list(dict.fromkeys(faces + stored)), "images", run.get("capture", "photo"),
                        run.get("mask", "placement"))
        rooms.append((r, pool[: args.people], val, test, s.target[pool[: args.people]].mean(0), faces))
        console.print(f"room {i} ({Path(d).name}): spots {dict(zip(policies, faces))}, {len(pool)} pool, "
                      f"{len(test)} test people")
    curve = finetune(net, [(r, pool, val) for r, pool, val, *_ in rooms], args.finetune, args.lr, args.seed) \
        if args.finetune else []
    for i, (r, _, _, people, mean_xy, faces) in enumerate(rooms):
        for policy, face in zip(policies, faces):
            k = r["faces"].index(face)
            g = torch.Generator().manual_seed(1000 * args.seed + i)
            with torch.no_grad():
                pos, logits, cell = predict(net, r, k, people, g)
            truth = r["target"][people]
            for m, p in (("floor-net", pos), ("matched-filter", cell), ("mean answer", mean_xy.expand_as(pos))):
                acc[policy, m][0].append((p - truth).norm(dim=1))
            guess, true_posture = logits.argmax(1), r["posture"][people]
            acc[policy, "floor-net"][1].append(guess == true_posture)
            acc[policy, "floor-net"][2].append(group[guess] == group[true_posture])
    pct = lambda c: round(float(torch.cat(c).float().mean()) * 100, 1) if c else ""
    rows = []
    for (policy, m), (e, c, c3) in acc.items():
        rows.append(dict(protocol="seen", capture="default", policy=policy, method=m,
                         error_cm=round(float(torch.cat(e).mean()) * 100, 2), posture_accuracy=pct(c),
                         posture3_accuracy=pct(c3), people=int(sum(len(x) for x in e)), floor_net=str(args.run),
                         finetune_steps=args.finetune, people_per_room=args.people if args.finetune else 0))
        console.print(f"{policy:9s} {m:15s} {rows[-1]['error_cm']:6.1f} cm  posture {rows[-1]['posture_accuracy']} "
                      f"/ {rows[-1]['posture3_accuracy']}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    args.out.with_suffix(".json").write_text(json.dumps(dict(
        args={k: str(v) for k, v in vars(args).items()}, validation_cm=curve, torch=torch.__version__), indent=1))


if __name__ == "__main__":
    main()
