"""The IEN trained on the task loss across rooms (issue 12, item 3), beside its SNR target.

The network that carries position to new rooms is FloorNet (``backprojection_net.py``, this folder),
so the task is FloorNet's: its own training loss, the position error (m) plus 0.3 x the posture
cross-entropy. With FloorNet frozen, every landed candidate spot t of a training room gets that
loss L_t on the room's full-transport people, whom FloorNet never trained on (it trains on the
image samples), averaged over ``--draws`` noise draws of the default capture ("task tables",
cached per room, resumable, buildable in shards). The IEN (vertex features normals + the Adaptive
Lighting score, the log prior in its logits, as in ``experiments/ien-across-rooms/ien_across_rooms.py``)
is then trained with:

* ``snr``: two-stage training's first stage, the cross-entropy to softmax(SNR / max / snr_tau);
* ``task``: the expected task loss under its spot distribution, sum_t p_t L_t. The network is
  frozen and every candidate is tabled, so this expectation and its gradient are exact (the
  straight-through Gumbel estimator of ``nlos train`` is not needed);
* ``task+snr``: the two summed (``--snr-weight``), the paper's objective;
* ``task-ce``: the cross-entropy to softmax(-(L / min L - 1) / ``--task-tau``), the SNR target's form
  with the task loss in place of the SNR (the expectation's gradient p_t (L_t - E_p L) dies once p
  settles on one candidate; the cross-entropy's does not: ``train.loop.Trainer.spot_loss``).

Each is scored on the test rooms (``--test``, full transport) as its spot's SNR over the best
candidate's and as FloorNet's error and posture accuracy on the rooms' people under that spot,
with the noise draws of ``backprojection_net.py`` (so its rows there are reproduced), beside the
fixed policies. ``--bound``: per test room the spot of lowest FloorNet loss, chosen on half the
people and scored on the other half (both ways), beside the SNR oracle's on the same people and
noise: what any spot chosen for this task could add, chosen on 2 to 15 static people (how many
people a room's task target needs), and the same on the training rooms' 8 people (4 choose, 4 score).
``--score-nets``: the same spots scored with
other FloorNet runs too (other seeds), which the IEN was not trained through.

    python experiments/backprojection-across-rooms/ien_task_across_rooms.py --train out/unseen/train --test out/unseen/test \\
        --floor-net out/backprojection-net/t2-s0 [--rooms 200] [--objectives snr,task,task+snr,task-ce] \\
        [--seeds 2] [--steps 2000] [--draws 4] [--table-people K] [--bound] [--shard I/N] [--out CSV]
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from rich.progress import track

from nlos_spotlight.train.floor_net import predict, room_arrays

from nlos_spotlight.console import QUIET, console

FEATURES = ["normals", "adaptive"]
"""The IEN's vertex features: those of the IEN that met the SNR goal (``experiments/ien-across-rooms/ien_across_rooms.py``)."""
POSTURE_WEIGHT = 0.3
"""FloorNet's posture cross-entropy weight in its training loss (``backprojection_net.train_floor_net``)."""


def load_floor_net(run: Path):
    """A ``backprojection_net.py`` run's FloorNet (eval mode) and the arguments it was trained with."""
    from nlos_spotlight.models.floor_net import FloorNet, FloorNetConfig

    if not (run / "floor_net.pt").exists() or not (run / "run.json").exists():
        raise SystemExit(f"--floor-net: {run} holds no floor_net.pt and run.json (a backprojection_net.py run)")
    args = json.loads((run / "run.json").read_text())["args"]
    net = FloorNet(FloorNetConfig(templates=int(args["templates"])))
    net.load_state_dict(torch.load(run / "floor_net.pt", weights_only=True))
    return net.eval(), args


def person_losses(net, r: dict, k: int, gen: torch.Generator, draws: int) -> tuple[torch.Tensor, torch.Tensor]:
    """(P,) position error (m) and posture cross-entropy of the room's people under its k-th spot,
    each the mean over ``draws`` noise draws."""
    people = torch.arange(len(r["target"]))
    err, ce = torch.zeros(len(people)), torch.zeros(len(people))
    with torch.no_grad():
        for _ in range(draws):
            pos, logits, _ = predict(net, r, k, people, gen)
            err += (pos - r["target"]).norm(dim=1) / draws
            ce += F.cross_entropy(logits, r["posture"], reduction="none") / draws
    return err, ce


def task_table(net, fargs: dict, d: Path, draws: int, seed: int) -> dict:
    """Every landed candidate's FloorNet losses on room ``d``'s full-transport people: faces (K,),
    err and ce (K, P)."""
    from nlos_spotlight.data.tensors import load_scene_tensors

    s = load_scene_tensors(d, [], samples="transport")
    faces = [int(f) for f in torch.nonzero(s.landed).flatten()]
    r = room_arrays(d, faces, "transport", fargs["capture"], fargs["mask"])
    gen = torch.Generator().manual_seed(seed)
    parts = [person_losses(net, r, k, gen, draws) for k in range(len(faces))]
    return {"faces": np.asarray(faces), "err": torch.stack([p[0] for p in parts]).numpy(),
            "ce": torch.stack([p[1] for p in parts]).numpy()}


def cached_tables(args, net, fargs, dirs: list[Path], cache: Path, only: range | None = None) -> list[dict | None]:
    """Each room's task table from ``cache`` (built where missing, for rooms ``only`` if given)."""
    from nlos_spotlight.data.store import atomic_npz

    cache.mkdir(parents=True, exist_ok=True)
    out = []
    todo = [i for i, d in enumerate(dirs) if not (cache / f"{d.name}.npz").exists() and (only is None or i in only)]
    for i in track(todo, description="task tables", disable=QUIET or not todo):
        atomic_npz(cache / f"{dirs[i].name}.npz", **task_table(net, fargs, dirs[i], args.draws, 7919 + i))
    for d in dirs:
        p = cache / f"{d.name}.npz"
        if not p.exists():
            out.append(None)
            continue
        try:
            with np.load(p) as z:
                out.append({k: z[k] for k in ("faces", "err", "ce")})
        except Exception as exc:  # a torn or foreign file
            raise SystemExit(f"{p}: corrupted task table ({type(exc).__name__}); delete it to rebuild") from None
    return out


def loss_vector(table: dict, faces: int, people: int = 0) -> torch.Tensor:
    """(T,) the mean task loss of each candidate over the room's first ``people`` (0: all) (0 where
    not landed: the IEN gives those p = 0)."""
    v = torch.zeros(faces)
    err, ce = table["err"][:, : people or None], table["ce"][:, : people or None]
    v[torch.as_tensor(table["faces"])] = torch.as_tensor(err.mean(1) + POSTURE_WEIGHT * ce.mean(1), dtype=torch.float32)
    return v


OBJECTIVES = ("snr", "task", "task+snr", "task-ce")


def task_term(objective: str, logits: torch.Tensor, landed: torch.Tensor, loss: torch.Tensor, tau: float):
    """The task part of ``objective`` for one room: its IEN logits and candidates' task losses (T,)."""
    log_p = torch.log_softmax(logits.masked_fill(~landed, float("-inf")), 0)
    if objective in ("task", "task+snr"):  # the expected task loss, exact: sum_t p_t L_t
        return (log_p.exp() * loss).sum()
    if objective == "task-ce":
        rel = loss / loss[landed].min() - 1.0
        q = torch.softmax((-rel / tau).masked_fill(~landed, float("-inf")), 0)
        return -(q * log_p.masked_fill(~landed, 0.0)).sum()
    return torch.zeros(())


def train_ien(rooms, losses, objective: str, snr_weight: float, steps: int, seed: int, out: Path,
              tau: float = 0.05):
    """The IEN trained on ``objective`` over ``rooms`` (``losses``: each room's (T,) task losses)."""
    from nlos_spotlight.models.ien import IENConfig
    from nlos_spotlight.train.config import TrainConfig
    from nlos_spotlight.train.loop import Trainer

    cfg = TrainConfig(name="ien-task-across-rooms", seed=seed, policy="ien", spot_steps=steps, steps=1, snr_weight=1.0,
                      scenes_per_step=min(len(rooms), 8), batch_size=8, device="cpu", ien=IENConfig(prior_weight=1.0))
    tr = Trainer(cfg, rooms, out)
    w_snr = {"snr": 1.0, "task": 0.0, "task+snr": snr_weight, "task-ce": 0.0}[objective]
    t0 = time.perf_counter()
    for _ in range(steps):
        tr.ien.train()
        picks = [int(torch.randint(len(rooms), (1,), generator=tr.gen)) for _ in range(cfg.scenes_per_step)]
        scenes = [tr.scenes[i] for i in picks]
        terms = []
        for i, s, lg in zip(picks, scenes, tr.ien_logits(scenes)):
            terms.append(w_snr * tr.spot_loss(s, lg) + task_term(objective, lg, s.landed, losses[i], tau))
        loss = torch.stack(terms).mean()
        tr.opt.zero_grad()
        loss.backward()
        tr.opt.step()
    return tr.ien.eval(), time.perf_counter() - t0


def task_loss_at(losses: list[torch.Tensor], lights) -> float:
    """Mean over rooms of the tabled task loss at each room's spot (``lights``: one Illumination a room)."""
    return round(float(np.mean([float(v[ill.face]) for v, ill in zip(losses, lights)])), 4)


def score_test(net, fargs: dict, dirs: list[Path], faces: dict[str, list[int]]) -> dict[str, tuple[float, float]]:
    """FloorNet's error (cm) and six-way accuracy (%) over the test rooms' people, each policy's spot
    per room, with ``backprojection_net.py``'s noise draws (the same for every policy)."""
    seed = int(fargs["seed"])
    acc = {p: ([], []) for p in faces}
    for i, d in enumerate(track(dirs, description="test rooms", disable=QUIET)):
        r = room_arrays(d, [faces[p][i] for p in faces], "transport", fargs["capture"], fargs["mask"])
        for k, p in enumerate(faces):
            g = torch.Generator().manual_seed(1000 * seed + i)
            with torch.no_grad():
                pos, logits, _ = predict(net, r, k, torch.arange(len(r["target"])), g)
            acc[p][0].append((pos - r["target"]).norm(dim=1))
            acc[p][1].append(logits.argmax(1) == r["posture"])
    return {p: (float(torch.cat(e).mean()) * 100, float(torch.cat(c).float().mean()) * 100)
            for p, (e, c) in acc.items()}


def bound_rows(tables: list[dict], oracle_faces: list[int], static: list[np.ndarray], choose: int = 0) -> dict:
    """Hindsight: each room's spot of lowest task loss chosen on half its static people (the first
    ``choose`` of them; 0: all) and scored on the other half, both ways, beside the SNR oracle's
    spot on the same people and draws. ``static``: each room's static people (a walk's frames are
    one person, so they would sit in both halves)."""
    err_task, err_oracle, ce_task, ce_oracle, same = [], [], [], [], 0
    for t, of, people in zip(tables, oracle_faces, static):
        loss = t["err"] + POSTURE_WEIGHT * t["ce"]  # (K, P)
        halves = [people[h::2] for h in (0, 1)]
        k_or = int(np.nonzero(t["faces"] == of)[0][0])
        for pick, score in (halves, halves[::-1]):
            k = int(loss[:, pick[:choose or None]].mean(1).argmin())
            same += k == k_or
            err_task.append(t["err"][k, score])
            err_oracle.append(t["err"][k_or, score])
            ce_task.append(t["ce"][k, score])
            ce_oracle.append(t["ce"][k_or, score])
    cat = lambda x: float(np.concatenate(x).mean())
    return {"chosen_on": choose or len(halves[0]), "task_best_error_cm": 100 * cat(err_task),
            "oracle_error_cm": 100 * cat(err_oracle), "task_best_ce": cat(ce_task), "oracle_ce": cat(ce_oracle),
            "same_face_share": same / (2 * len(tables))}


def snr_task_agreement(rooms, losses) -> tuple[float, float]:
    """Over rooms: the mean Spearman correlation of candidates' SNR with their task loss, and the
    mean task loss at the best-SNR candidate minus the lowest tabled one."""
    from scipy.stats import spearmanr

    from nlos_spotlight.lighting.snr import candidate_snr

    rho, gap = [], []
    for s, v in zip(rooms, losses):
        snr = np.asarray(candidate_snr(s.scene_dir))  # the default capture
        ok = s.landed.numpy()
        rho.append(spearmanr(snr[ok], v.numpy()[ok]).statistic)
        gap.append(float(v[int(np.argmax(np.where(ok, snr, -np.inf)))]) - float(v.numpy()[ok].min()))
    return float(np.nanmean(rho)), float(np.mean(gap))


def shard(spec: str, n: int) -> range:
    """Rooms ``I mod N`` of ``n`` for ``--shard I/N``."""
    try:
        i, k = (int(x) for x in spec.split("/"))
    except ValueError:
        raise SystemExit(f"--shard: expected I/N, got {spec!r}") from None
    if not 0 <= i < k:
        raise SystemExit(f"--shard: need 0 <= I < N, got {spec!r}")
    return range(i, n, k)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", type=Path, required=True, help="training dataset (its full-transport people)")
    ap.add_argument("--test", type=Path, required=True, help="test dataset of other rooms (full transport)")
    ap.add_argument("--floor-net", type=Path, required=True, help="a backprojection_net.py run directory")
    ap.add_argument("--rooms", type=int, default=200, help="training rooms (the first R)")
    ap.add_argument("--test-rooms", type=int, default=40)
    ap.add_argument("--objectives", default=",".join(OBJECTIVES))
    ap.add_argument("--snr-weight", type=float, default=1.0, help="the SNR term's weight in task+snr")
    ap.add_argument("--task-tau", type=float, default=0.05, help="task-ce: the target's temperature")
    ap.add_argument("--policies", default="oracle,adaptive,center,random", help="fixed policies scored beside")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--score-nets", type=Path, nargs="*", default=[],
                    help="more backprojection_net.py runs to score every spot with (not trained through)")
    ap.add_argument("--table-people", type=int, default=0,
                    help="train on the task loss of each training room's first K people only (0: all)")
    ap.add_argument("--draws", type=int, default=4, help="noise draws per person in the task tables")
    ap.add_argument("--bound", action="store_true", help="also the test rooms' hindsight best spot by task loss")
    ap.add_argument("--shard", default="", help="I/N: only build the task tables of rooms I mod N, then stop")
    ap.add_argument("--cache", type=Path, default=None, help="task tables (default: FLOOR_NET/task-tables-dD)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("docs/results/ien-task-across-rooms.csv"))
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    objectives = [o for o in args.objectives.split(",") if o]
    if bad := [o for o in objectives if o not in OBJECTIVES]:
        raise SystemExit(f"--objectives: unknown objective {bad[0]!r} ({', '.join(OBJECTIVES)})")
    if args.table_people < 0:
        raise SystemExit(f"--table-people: expected 0 (all) or a positive count, got {args.table_people}")
    if args.bound and "oracle" not in args.policies.split(","):
        raise SystemExit("--bound compares with the oracle spot: keep 'oracle' in --policies")
    from nlos_spotlight.data.generate import versions
    from nlos_spotlight.data.tensors import finished_scene_dirs, load_scene_tensors
    from nlos_spotlight.evaluate.unseen import room_lights, snr_fraction

    t0 = time.perf_counter()
    net, fargs = load_floor_net(args.floor_net)
    dirs = finished_scene_dirs(args.train, "train")[: args.rooms]
    test_dirs = finished_scene_dirs(args.test, "test")[: args.test_rooms]
    if len(dirs) < args.rooms or not test_dirs:
        raise SystemExit(f"{len(dirs)} finished training rooms (--rooms {args.rooms}), {len(test_dirs)} test rooms")
    cache = args.cache or args.floor_net / f"task-tables-d{args.draws}"
    if args.shard:
        cached_tables(args, net, fargs, dirs, cache / "train", shard(args.shard, len(dirs)))
        if args.bound:
            cached_tables(args, net, fargs, test_dirs, cache / "test", shard(args.shard, len(test_dirs)))
        return
    tables = cached_tables(args, net, fargs, dirs, cache / "train")
    rooms = [load_scene_tensors(d, FEATURES, "transport") for d in dirs]
    losses = [loss_vector(t, len(s.faces)) for t, s in zip(tables, rooms)]  # what every row reports
    trained_on = [loss_vector(t, len(s.faces), args.table_people) for t, s in zip(tables, rooms)] \
        if args.table_people else losses
    test = [load_scene_tensors(d, FEATURES, "transport") for d in test_dirs]
    rho, gap = snr_task_agreement(rooms, losses)
    console.print(f"{len(rooms)} training rooms: SNR vs task loss Spearman {rho:.3f}; task loss at the best-SNR "
                  f"spot minus the lowest {gap:.4f} ({time.perf_counter() - t0:.0f} s)")
    fseed = int(fargs["seed"])
    lights = {p: room_lights(test, p, fseed) for p in args.policies.split(",") if p}
    train_lights = {p: room_lights(rooms, p, fseed) for p in lights}
    meta = {p: {"objective": p, "seed": "", "seconds": "", "train_task_loss": task_loss_at(losses, ls)}
            for p, ls in train_lights.items()}
    for obj in objectives:
        for seed in range(args.seeds):
            ien, sec = train_ien(rooms, trained_on, obj, args.snr_weight, args.steps, seed, cache, args.task_tau)
            name = f"ien-{obj}-s{seed}"
            lights[name] = room_lights(test, "ien", 0, ien)
            meta[name] = {"objective": obj, "seed": seed, "seconds": round(sec),
                          "train_task_loss": task_loss_at(losses, room_lights(rooms, "ien", 0, ien))}
            console.print(f"{name}: {sec:.0f} s, training rooms' task loss at its spot {meta[name]['train_task_loss']}")
    faces = {p: [ill.face for ill in ls] for p, ls in lights.items()}
    rows = []
    for run in [args.floor_net, *args.score_nets]:  # the tables' network, then independent ones
        n, fa = (net, fargs) if run == args.floor_net else load_floor_net(run)
        scores = score_test(n, fa, test_dirs, faces)
        for p, ls in lights.items():
            frac = snr_fraction(test, ls)
            rows.append({"floor_net": run.name, "policy": p, **meta[p], "train_rooms": len(rooms),
                         "test_rooms": len(test), "snr_fraction_mean": round(float(frac.mean()), 3),
                         "snr_fraction_median": round(float(np.median(frac)), 3),
                         "error_cm": round(scores[p][0], 2), "posture_accuracy": round(scores[p][1], 2)})
            console.print(" ".join(f"{k}={v}" for k, v in rows[-1].items()))
    record = {"args": {k: str(v) for k, v in vars(args).items()}, "floor_net_args": fargs,
              "snr_task_spearman": rho, "task_gap_at_best_snr": gap, "versions": versions()}
    if args.bound:
        tt = cached_tables(args, net, fargs, test_dirs, cache / "test")
        oracle = [ill.face for ill in lights["oracle"]]
        static = lambda rs: [np.nonzero(s.trajectory[:, 0].numpy() < 0)[0] for s in rs]
        record["bound"] = [bound_rows(tt, oracle, static(test), k) for k in (2, 4, 8, 0)]
        record["bound_train_rooms"] = bound_rows(tables, [ill.face for ill in train_lights["oracle"]], static(rooms))
        for b in record["bound"] + [record["bound_train_rooms"]]:
            console.print(f"hindsight best spot by task loss, chosen on {b['chosen_on']} people: "
                          f"{b['task_best_error_cm']:.1f} cm against the oracle's {b['oracle_error_cm']:.1f} cm")
    record["seconds"] = round(time.perf_counter() - t0)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    args.out.with_suffix(".json").write_text(json.dumps(record, indent=1))
    console.print(f"wrote {args.out} and {args.out.with_suffix('.json')}")


if __name__ == "__main__":
    main()
