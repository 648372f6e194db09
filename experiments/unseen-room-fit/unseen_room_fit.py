"""Rooms no network trained in, each fitted by simulation in its own scan (issue 12).

The networks trained across 200 rooms carry position over to new rooms but not posture. The room's
scan is known at test time (the IEN reads it), so the renderer can make training people in it, as
``nlos fit`` does for a user's room. Hypothesis: a network trained only on simulated people of the
test room reads posture there, and the gap to the ideal observer
(``experiments/physics-bounds/posture_separability.py --split test``) says how much is left.

Per test room of ``--test`` (the first ``--rooms``): ``--people`` synthetic people in that room's
scene (``DatasetConfig.room``; another master seed, so none is a test person), the first
``--transport`` of them with full transport to choose the spot (the oracle on the synthetic people:
nothing of the test people is used), then the seen-rooms recipe (``train.recipe``) on the image
samples, best weights by validation on 100 of them. Scored on the room's real test people (the
static ones; the default one-frame capture and noise draws of ``experiments/unseen-rooms/unseen_rooms.py``)
under the spot chosen from the synthetic people and under the room's oracle spot.

    python experiments/unseen-room-fit/unseen_room_fit.py --test out/unseen/test --rooms 6 --people 1500 --out out/unseen/room-fit

``--variants`` trains one network per variant on the same people: frames a still capture averages
(training and test photographs), ``+albedo`` albedo augmentation, ``+eN`` N epochs, ``+pN`` only
the first N training people (a learning curve on the same render), ``+wdX`` weight decay X, ``+xN``
the training people of N independent renders of ``--people`` (``data``, ``data-2``, ...; other master
seeds), validation and held-out people from the first, ``+sN`` training seed ``--seed`` + N (scored
on the same noise draws), ``+init`` the weights and input of ``--init``, a network trained on other
fitted rooms (``fitted_rooms_transfer.py``; refused if it trained in this room) (e.g. ``1 16
16+albedo 16+e120 16+e120+x2 16+e120+x2+s1 16+e120+init``). Each network is also scored on 100
more simulated people of the fit (the split's test people), a tighter estimate than the room's 30
test people.

The baselines of the paper's Tables 1-2, each given the room's simulation too: ``+adaptive``,
``+flash``, ``+ambient``, ``+center`` train and test under that fixed policy instead of the fitted
spot, and ``+chandran``, ``+tancik``, ``+dlnlos`` train that network instead of the light ResNet
(e.g. ``16+e120+adaptive`` AL + ResNet, ``16+e120+chandran`` the fitted spot + CNN, ``16+e120+adaptive+chandran``
Chandran & Jayasuriya, ``16+e120+flash+tancik``, ``16+e120+ambient+dlnlos``). The summary then
tables every method on the rooms fitted with all of them, with the issue's margins.

A dark or brighter hidden room: ``+luxX`` trains and tests every photograph with the hidden region
at X lux instead of the room's own 0.1-2 (0: the projector's light only; exact, nothing rendered
again: ``train.imaging.relit_hidden_region``), e.g. ``16+e120+lux0``, ``16+e120+adaptive+lux0``,
``16+e120+ambient+lux0.01``; ``--summary-only --hidden-light`` tables them alone
(summary-hidden-light.md).

The spot chosen by the task: ``+rankK`` trains and tests under the fitted room's K-th best spot by
SNR (K = 2..6; the fit's own spot is rank 1), and ``--task-spot V1 V2 ...`` (summary) picks per
room the candidate spot whose network reads posture best on its validation people, e.g.
``--task-spot 16+e120+lux0 16+e120+rank2+lux0 16+e120+rank3+lux0 16+e120+adaptive+lux0``
(summary-task-spot.md). Every
variant is also scored on its validation people (rows 'val:') for that choice.

Writes ``--out``/room-fit-FIRST-LAST.csv (room, variant, spot, people, posture_accuracy, posture3_accuracy, error_cm,
mean_answer_cm, test_people, render_s, train_s) and per room its data, run and predictions.
Resumable: a room's dataset resumes, a trained room keeps ``best.pt``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.data.config import read_dataset_config
from nlos_spotlight.data.static import read_static
from nlos_spotlight.data.store import atomic_csv
from nlos_spotlight.errors import NlosError
from nlos_spotlight.evaluate.room_fits import (ARCHS, LIGHTS, VARIANT_HELP, first_seconds, fitted_spot, light_policy,
                                               parse_variant, read_fit_rows, room_interval, run_dir, static_people,
                                               training_split)

COLUMNS = ["room", "variant", "spot", "people", "posture_accuracy", "posture3_accuracy", "error_cm", "mean_answer_cm",
           "test_people", "render_s", "train_s"]


def room_dataset(test_cfg, room: Path, people: int, transport: int, seed: int, extra_spots=()):
    """One training room built on the test room's scene, with the test set's (``DatasetConfig``)
    render settings (``extra_spots``: candidates its image samples store besides its own choice)."""
    from nlos_spotlight.data.config import DatasetConfig

    keep = ("resolution", "los_vertices", "body_faces", "render", "transport_rank", "stored_spots_top")
    return DatasetConfig(name="room-fit", seed=seed, train_scenes=1, val_scenes=0, test_scenes=0,
                         samples_per_scene=people, transport_samples_per_scene=transport,
                         trajectories_per_test_scene=0, trajectories_per_train_scene=0, room=str(room.resolve()),
                         extra_spots=list(extra_spots), **{k: getattr(test_cfg, k) for k in keep})


def later_render_spots(first: Path, later: Path) -> list[int]:
    """The spots a further render ('+xN') stores besides its own: the first render's (the spot is
    chosen on the first render's full-transport people, so every render must hold it); a render
    begun before this rule keeps what it was begun with."""
    cfg = later / "config.json"
    if cfg.exists():
        return json.loads(cfg.read_text()).get("extra_spots", [])
    from nlos_spotlight.data.tensors import stored_spots

    return stored_spots(next((first / "scenes").iterdir()))


def room_hidden_lux(room: Path) -> float:
    """The illuminance (lux) of a room's hidden region, from its scene file."""
    from nlos_spotlight.scene.io import load_scene
    from nlos_spotlight.world.calibration import illuminance_lux

    amb = load_scene(room).ambient
    lux = illuminance_lux(amb.hidden_radiance) if amb is not None else 0.0
    if lux <= 0:
        raise SystemExit(f"{room.name}: its hidden region has no light of its own to scale ('+lux')")
    return lux


def scored_rooms(rows: dict) -> set[str]:
    """The rooms of one (people, variant)'s rows {(room, kind): row} scored on simulated people."""
    return {r for r, kind in rows if kind == "heldout"}


def fit_room(args, i: int, room: Path, test_cfg, rows: list[dict], write) -> None:
    """Render the room's simulated people, then one network per variant; each variant's rows are
    appended to ``rows`` and written (``write``) as soon as it is scored."""
    from nlos_spotlight.data.generate import generate

    out = args.out / room.name
    data = out / "data"
    t0 = time.perf_counter()
    generate(room_dataset(test_cfg, room, args.people, args.transport, 5000 + i), data, progress=False)
    render_s = first_seconds(out / "render_seconds.json", t0)  # a rerun only checks digests
    more = []  # further independent renders of the room's people ('+xN'), their own master seeds
    for r in range(1, max(parse_variant(spec).renders for spec in args.variants)):
        t0 = time.perf_counter()
        spots = later_render_spots(data, out / f"data-{r + 1}")
        generate(room_dataset(test_cfg, room, args.people, args.transport, 5000 + i + 100_000 * r, spots),
                 out / f"data-{r + 1}", progress=False)
        secs = first_seconds(out / f"render_seconds-{r + 1}.json", t0)
        more.append((training_split(out / f"data-{r + 1}").pool, secs))
    test = static_people(room)
    fit_aims = read_static(next((data / "scenes").iterdir()), "aim_points")["aim_points"]
    if not np.allclose(fit_aims, read_static(room, "aim_points")["aim_points"], atol=1e-6):
        raise SystemExit(f"{room.name}: the fitted room's candidate spots differ from the test room's")
    split = training_split(data)
    for spec in args.variants:
        rows += fit_variant(args, out, spec, split, test, render_s, more)
        write(rows)


def refuse_init(args, room: str) -> None:
    """SystemExit where a '+init' variant cannot start ``room`` from ``--init``: none given, or its
    network trained in ``room`` (its run's config.json lists ``train_rooms``): the point is weights
    from other rooms."""
    if args.init is None:
        raise SystemExit("--variants ...+init: give --init BEST_PT (fitted_rooms_transfer.py's run/best.pt)")
    cfg = args.init.parent / "config.json"
    if not cfg.exists():
        raise SystemExit(f"--init {args.init}: no config.json beside it to say which rooms it trained in")
    if room in json.loads(cfg.read_text()).get("train_rooms", []):
        raise SystemExit(f"--init {args.init}: that network trained in {room}; start {room} from one that did not")


def initial_weights(args, room: str) -> dict:
    """``--init``'s checkpoint for a '+init' variant in ``room`` (:func:`refuse_init`)."""
    refuse_init(args, room)
    try:
        return torch.load(args.init, map_location="cpu", weights_only=False)
    except Exception as exc:  # torch raises many types on torn or foreign files
        raise SystemExit(f"--init {args.init}: corrupted or not a checkpoint ({type(exc).__name__})") from None


def fit_variant(args, out: Path, spec: str, split, test, render_s: float, more: list) -> list[dict]:
    """One network for the room's simulated people with the capture and augmentation of ``spec``,
    scored on the room's test people under the fitted spot and the test people's oracle spot."""
    from nlos_spotlight.data.store import atomic_npz
    from nlos_spotlight.train.recipe import resume_validated, seen_config, train_validated
    from nlos_spotlight.evaluate.seen import score_rooms
    from nlos_spotlight.evaluate.unseen import room_lights
    from nlos_spotlight.train.imaging import relit_hidden_region
    from nlos_spotlight.train.loop import Trainer

    v = parse_variant(spec)
    # 'fit': the oracle over the fitted room's full-transport simulated people (none of the test people)
    cfg = seen_config(1, args.seed + v.train_seed, noise=True, policy=light_policy(v.light), arch=v.arch)
    cfg = dataclasses.replace(cfg, sensor={"burst_frames": v.frames} if v.frames > 1 else {}, albedo_augment=v.albedo)
    if v.weight_decay is not None:
        cfg = dataclasses.replace(cfg, weight_decay=v.weight_decay)
    init = initial_weights(args, Path(test.scene_dir).name) if v.init else None
    if init is not None:  # the other rooms' network's input (geometry-aware or not) comes with its weights
        cfg = dataclasses.replace(cfg, net=dataclasses.replace(cfg.net, **init["config"]["net"]))
    if v.people is not None:
        if v.people > split.pool.num_samples:
            raise SystemExit(f"--variants {spec}: the room has only {split.pool.num_samples} training people")
        split = dataclasses.replace(split, pool=split.pool.subset(torch.arange(v.people)))
    for pool, secs in more[:v.renders - 1]:  # the further renders' training people ('+xN')
        split = dataclasses.replace(split, pool=split.pool.concat(pool))
        render_s += secs
    if v.hidden_lux is not None:  # every photograph of the room, training and test, in that light
        scale = v.hidden_lux / room_hidden_lux(Path(test.scene_dir))
        split = dataclasses.replace(split, **{k: relit_hidden_region(getattr(split, k), scale)
                                              for k in ("pool", "val", "test")})
        test = relit_hidden_region(test, scale)
    run = run_dir(out, spec)
    per_epoch = max(1, split.pool.num_samples // cfg.batch_size)
    steps = max(args.min_steps, round((v.epochs or args.epochs) * per_epoch))
    every = max(per_epoch, steps // 25)
    cfg = dataclasses.replace(cfg, steps=steps, eval_every=every, ckpt_every=every, log_every=every,
                              select=args.select)
    t1 = time.perf_counter()
    run.mkdir(parents=True, exist_ok=True)
    (run / "config.json").write_text(json.dumps({"train": cfg.to_dict(), "variant": spec,
                                                 "init": str(args.init) if v.init else None}, indent=1))
    tr = Trainer(cfg, [split.pool], run, val_scenes=[split.val])
    resume_validated(tr, run)  # also a run killed before its first checkpoint: its validation rows dropped
    if tr.step == 0 and init is not None:
        tr.net.load_state_dict(init["net"])
    train_validated(tr, run)
    train_s = first_seconds(run / "train_seconds.json", t1)  # a rescored run reports its training
    (y, mode, _), = tr.illuminations([tr.scenes[0]], train=False)
    # the room's test people under the network's illumination and, for the fitted spot, under the
    # test people's oracle spot; "heldout": 100 more simulated people of the fit (a tighter estimate
    # of the same network in the same room than 30 test people give); "val": the simulated people
    # that chose its weights (what a task-chosen spot may be chosen by: ``--task-spot``)
    lights = {"fit": (test, (y, mode)), "heldout": (split.test, (y, mode)), "val": (split.val, (y, mode))}
    if v.light == "fit":
        lights["oracle"] = (test, (room_lights([test], "oracle", 0)[0].spot_vector(len(test.faces)), "spot"))
    elif not fitted_spot(v.light):  # a fixed policy reads the scan only: the test room's choice must be the training room's
        ill = room_lights([test], v.light, args.seed)[0]
        if ill.mode != mode or (y is not None and ill.face != int(y.argmax())):
            raise SystemExit(f"{Path(test.scene_dir).name}: {v.light} chose differently in the fitted room")
    mean = split.pool.target.mean(0)
    rows = []
    for name, (people, light) in lights.items():
        res = score_rooms(tr.net, cfg.net, tr.sensor, [people], [light], True, args.seed)
        p = res["per_person"]
        where = int(light[0].argmax()) if light[1] == "spot" else light[1]
        rows.append(dict(room=Path(test.scene_dir).name, variant=spec, spot=f"{name}:{where}",
                         people=split.pool.num_samples, posture_accuracy=round(res["posture_accuracy"], 2),
                         posture3_accuracy=round(res["posture3_accuracy"], 2), error_cm=round(res["error_cm"], 2),
                         mean_answer_cm=round(100 * float((people.target - mean).norm(dim=1).mean()), 2),
                         test_people=people.num_samples, render_s=round(render_s), train_s=round(train_s)))
        atomic_npz(run / f"predictions-{name}.npz", **{k: np.asarray(v) for k, v in p.items()})
        print(" ".join(f"{k}={v}" for k, v in rows[-1].items()), flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--test", type=Path, required=True, help="test dataset (unseen-test.yaml)")
    ap.add_argument("--rooms", type=int, default=None,
                    help="ROOMS test rooms from --first (by index, each finished; default 6); with --summary-only, "
                         "only these rooms (default: every fitted room)")
    ap.add_argument("--first", type=int, default=0, help="start at this test room")
    ap.add_argument("--variants", nargs="+", default=["1"], metavar="VARIANT",
                    help="one network per variant on the same people: frames a still capture averages "
                         "(train and test), '+albedo' for albedo augmentation, '+eN' N epochs, '+pN' the first N "
                         f"training people, '+wdX' weight decay X, '+xN' people of N renders, '+sN' training seed "
                         f"+N, '+init' start from --init's weights: {VARIANT_HELP}")
    ap.add_argument("--init", type=Path, default=None, metavar="BEST_PT",
                    help="'+init' variants start from this checkpoint (a network of other rooms)")
    ap.add_argument("--also", nargs="*", type=Path, default=[], metavar="CSV",
                    help="earlier fits' room-fit CSVs to summarize beside these (e.g. the committed 1,200-people fits)")
    ap.add_argument("--people", type=int, default=1500, help="synthetic people per room")
    ap.add_argument("--transport", type=int, default=8, help="of which with full transport (the spot's choice)")
    ap.add_argument("--epochs", type=float, default=60.0)
    ap.add_argument("--min-steps", type=int, default=800)
    ap.add_argument("--select", default="metrics", help="best weights by validation 'loss' or 'metrics'")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("out/unseen/room-fit"))
    ap.add_argument("--compare", nargs="*", default=[], metavar="NAME=NPZ",
                    help="predictions of networks trained across rooms on the same test set, for the summary")
    ap.add_argument("--ceiling", type=Path, default=Path("docs/results/posture-ceiling-unseen.txt"),
                    help="experiments/physics-bounds/posture_separability.py --split test's output: "
                         "the ideal observer per person")
    ap.add_argument("--summary-only", action="store_true", help="only the summary of the rooms fitted so far")
    ap.add_argument("--hidden-light", action="store_true",
                    help="summary: only the '+lux' variants (every method in that light, and each beside itself and "
                         "ours in the rooms' own light), to summary-hidden-light.md")
    ap.add_argument("--pair", nargs=2, action="append", default=[], metavar=("BASE", "OTHER"),
                    help="summary: OTHER - BASE paired by room on the rooms fitted with both variants (repeatable); "
                         "variants joined by commas count as their mean per room (e.g. training seeds)")
    ap.add_argument("--pair-out", type=Path, default=None, metavar="PATH",
                    help="summary: also write the --pair tables alone to PATH")
    ap.add_argument("--ensemble", nargs="+", action="append", default=[], metavar="VARIANT",
                    help="summary: the networks of these variants (e.g. two training seeds, or a spot's and the "
                         "projector-off photograph's) averaged, on the rooms where all were scored: posture "
                         "probabilities and positions averaged (repeatable)")
    ap.add_argument("--task-spot", nargs="+", action="append", default=[], metavar="VARIANT",
                    help="summary: the spot chosen by the task among these variants' spots (ours first, e.g. "
                         "16+e120+lux0 16+e120+rank2+lux0 16+e120+adaptive+lux0): per room the one whose network "
                         "reads posture best on its validation people (repeatable), to summary-task-spot.md")
    args = ap.parse_args()
    if args.summary_only:
        return summary(args)
    torch.set_num_threads(args.threads)
    from nlos_spotlight.data.store import scene_id

    for spec in args.variants:
        parse_variant(spec)
    test_cfg = read_dataset_config(args.test)
    rooms = [args.test / "scenes" / scene_id("test", i) for i in range(args.first, args.first + (args.rooms or 6))]
    for room in rooms:  # by index, so that workers on disjoint rooms can start before all are generated
        if not (room / "done.json").exists():
            raise SystemExit(f"{room}: not generated (nlos generate CONFIG --out {args.test} --shard I/N, "
                             "I its scene index)")
        if any(parse_variant(spec).init for spec in args.variants):
            refuse_init(args, room.name)  # before any rendering
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / f"room-fit-{args.first}-{args.first + len(rooms)}.csv"

    write = lambda rows: atomic_csv(path, COLUMNS, rows)
    rows = []  # an earlier run's rows of other variants in the same CSV are kept
    if path.exists():
        rows = [r for r in read_fit_rows(path) if r["variant"] not in args.variants]
    for i, room in enumerate(rooms, args.first):
        try:
            fit_room(args, i, room, test_cfg, rows, write)
        except NlosError as exc:  # bad or inconsistent data: one line, the finished rooms' rows kept
            raise SystemExit(f"{room.name}: {exc}") from None
    summary(args)


def summary(args) -> None:
    """Every fitted room so far (all ``room-fit-*.csv`` and ``--also``), one line per (training
    people, variant) over the rooms it has, beside the networks trained across rooms
    (``--compare``) and the ideal observer (``--ceiling``) on the same rooms' static people."""
    fits, own = {}, set()
    for path in sorted(args.out.glob("room-fit-*.csv")) + list(args.also):
        for r in read_fit_rows(path):
            if args.rooms is not None and not args.first <= int(r["room"].split("-")[-1]) < args.first + args.rooms:
                continue
            if path.parent == args.out:
                own.add(r["room"])
            elif own and r["room"] not in own:
                continue  # --also: only the rooms fitted here, so that every line has the same rooms
            fits.setdefault((int(r["people"]), r["variant"]), {})[r["room"], r["spot"].split(":")[0]] = r
    if args.hidden_light:
        return hidden_light_summary(args, fits)
    if args.task_spot:
        return task_spot_summary(args, fits)
    rooms = sorted({room for rows in fits.values() for room, _ in rows})
    index = [int(r.split("-")[-1]) for r in rooms]
    lines = [f"{len(rooms)} test rooms ({', '.join(rooms)}), static people; one frame unless stated; last column: "
             "the same networks on 100 more simulated people a room (where scored)",
             "| method | rooms | six-way | six-way, 95% interval over rooms | upright/sitting/crouching | error | "
             "mean answer | six-way, simulated |",
             "|---|---|---|---|---|---|---|---|"]
    for (people, variant), rows in sorted(fits.items()):
        done = sorted({room for room, kind in rows if kind == "fit"})
        fit = [rows[r, "fit"] for r in done]
        mean = lambda k: np.mean([float(r[k]) for r in fit])
        held = [float(rows[r, "heldout"]["posture_accuracy"]) for r in done if (r, "heldout") in rows]
        held = f"{np.mean(held):.1f}% ({len(held)} rooms)" if held else ""
        lines.append(f"| fitted in the room: {people} training people, {parse_variant(variant).describe()} | "
                     f"{len(done)} | {mean('posture_accuracy'):.1f}% | "
                     f"{room_interval([float(r['posture_accuracy']) for r in fit])} | {mean('posture3_accuracy'):.1f}% | "
                     f"{mean('error_cm'):.1f} cm | {mean('mean_answer_cm'):.1f} cm | {held} |")
    for spec in args.compare:
        name, path = spec.split("=", 1)
        with np.load(path) as z:
            keep = np.isin(z["room"], index) & (z["trajectory"][:, 0] < 0)
            t, q = z["true_posture"][keep], z["pred_posture"][keep]
            from nlos_spotlight.evaluate.seen import GROUP_OF

            err = 100 * np.linalg.norm(z["pred_xy"][keep] - z["true_xy"][keep], axis=1).mean()
            lines.append(f"| {name} | {len(rooms)} | {100 * np.mean(t == q):.1f}% | | "
                         f"{100 * np.mean(GROUP_OF[t] == GROUP_OF[q]):.1f}% | {err:.1f} cm | | |")
    if args.ceiling and args.ceiling.exists():
        import re

        text = args.ceiling.read_text()
        for frames in (1, 16):
            acc = [float(m.group(2)) for m in re.finditer(
                rf"room (test-\d+) person \d+:.*? {frames} frame\(s\) \d+% / (\d+)%", text) if m.group(1) in rooms]
            lines.append(f"| ideal observer, nuisances fitted, {frames} frame(s) ({len(acc)} people) | {len(rooms)} | "
                         f"{np.mean(acc):.1f}% | | | | | |")
    for (people, variant), rows in sorted(fits.items()):
        done = sorted({room for room, kind in rows if kind == "fit" and (room, "oracle") in rows})
        if not done:  # a baseline's light: scored under its own illumination only
            continue
        same = sum(rows[r, "fit"]["spot"].split(":")[1] == rows[r, "oracle"]["spot"].split(":")[1] for r in done)
        lines.append(f"{people} people, variant {variant}: the spot chosen from the simulated people is the test "
                     f"people's oracle in {same} of {len(done)} rooms.")
    pairs = variant_pairs(fits, args.pair)
    if args.pair_out:  # the pairs alone, for a results page
        args.pair_out.write_text("\n".join(pairs).lstrip("\n") + "\n")
    lines += people_curve(fits) + pairs + methods_table(fits, args.out)
    lines += hidden_light_table(fits, args.test)
    for variants in args.ensemble:
        lines += ensembles(args.out, rooms, variants)
    text = "\n".join(lines)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "summary.md").write_text(text + "\n")


def hidden_light_summary(args, fits: dict) -> None:
    """``--hidden-light``: the methods table of each '+lux' light (the variants that share it) and
    :func:`hidden_light_table`, written to summary-hidden-light.md."""
    dark = {k: rows for k, rows in fits.items() if parse_variant(k[1]).hidden_lux is not None}
    lines = methods_table(dark, args.out) + hidden_light_table(fits, args.test)
    if not lines:
        raise SystemExit(f"--hidden-light: no '+lux' variant fitted under {args.out}")
    text = "\n".join(lines).lstrip("\n")
    print(text)
    (args.out / "summary-hidden-light.md").write_text(text + "\n")


METHOD_NAMES = {("fit", "resnet18"): "Ours (fitted spot + ResNet)", ("adaptive", "resnet18"): "AL + ResNet",
                ("fit", "chandran"): "fitted spot + CNN (the paper's IEN + CNN)",
                ("adaptive", "chandran"): "Chandran & Jayasuriya (AL + CNN)",
                ("flash", "tancik"): "Tancik et al. (flash + CNN)", ("ambient", "dlnlos"): "DL-NLOS (ambient + CNN)"}
"""(light, network) -> the name of the paper's Tables 1-2 row it reproduces, fitted in the room."""


def methods_table(fits: dict, out: Path) -> list[str]:
    """Every method fitted in the same rooms with the same people, capture and epochs (variants that
    differ only in '+LIGHT' / '+ARCH'): the paper's Tables 1-2 with every method given the room's
    simulation, each method on the rooms it was fitted in beside ours on the same rooms (paired),
    the issue's margins, and six-way per posture from the runs' predictions under ``out``."""
    groups = {}
    for (people, variant), rows in fits.items():
        groups.setdefault((people, method_base(variant)), {})[variant] = rows
    lines = []
    for (people, base), variants in sorted(groups.items()):
        if len(variants) < 2 or base not in variants:
            continue
        ours = variants[base]
        rooms = {v: sorted(scored_rooms(rows) & scored_rooms(ours)) for v, rows in variants.items()}
        rooms[base] = sorted(set().union(*(r for v, r in rooms.items() if v != base)))
        if not rooms[base]:
            continue
        lines += ["", f"Every method fitted in the same rooms on the same {people} simulated people a room, "
                      f"{parse_variant(base).describe()}: six-way and error on the rooms' 30 test people and 100 "
                      "more simulated people, each method on the rooms it was fitted in; paired: the method minus "
                      "ours on those rooms, test / simulated people (mean +- standard error over the rooms):",
                  "| method | rooms | six-way (test) | six-way (simulated) | error (test) | error (simulated) | "
                  "paired six-way | paired error |", "|---|---|---|---|---|---|---|---|"]
        for variant in sorted(variants, key=method_order):
            rows, rs = variants[variant], rooms[variant]
            if not rs:
                continue
            pair = lambda k, unit="": "" if variant == base else " / ".join(
                paired_change(ours, rows, rs, kind, k) + unit for kind in ("fit", "heldout"))
            cells = [f"{room_mean(rows, rs, kind, k):.1f}{unit}" for k, unit in (("posture_accuracy", "%"),
                     ("error_cm", " cm")) for kind in ("fit", "heldout")]  # six-way, then error; test, simulated
            lines.append(f"| {method_name(variant)} | {len(rs)} | " + " | ".join(cells)
                         + f" | {pair('posture_accuracy')} | {pair('error_cm', ' cm')} |")
        lines += method_goals(variants, base, rooms)
        lines += posture_table(out, rooms, sorted(variants, key=method_order))
    return lines


def hidden_light_table(fits: dict, test: Path) -> list[str]:
    """Each method ('+lux' variants) with the hidden region's own light changed, beside the same
    method and ours in the rooms' own light (0.1-2 lux), on the rooms fitted with both: is the
    projector needed where the hidden room is dark?"""
    unlit = lambda v: "+".join(e for e in v.split("+") if not e.startswith("lux"))
    ours_of = lambda v: method_base(unlit(v))
    dark = [(p, v) for p, v in fits if parse_variant(v).hidden_lux is not None
            and (p, unlit(v)) in fits and (p, ours_of(v)) in fits]
    if not dark:
        return []
    own_lux = {r: room_hidden_lux(test / "scenes" / r) for r in set().union(*(scored_rooms(fits[k]) for k in dark))}
    lines = ["", "The hidden region's own light changed ('+lux', exact: the person's light under it scales with it, "
                 "nothing else does), each method beside itself and ours in the rooms' own light on the same rooms; "
                 "paired: mean +- standard error over the rooms, test / simulated people:",
             "| method | hidden region | rooms | six-way (test) | six-way (simulated) | error (test) | error (simulated) "
             "| six-way minus the same method in the rooms' light | six-way minus ours in the rooms' light |",
             "|---|---|---|---|---|---|---|---|---|"]
    shown = set()  # a method's row in the rooms' light once, above all its '+lux' rows on the same rooms
    for people, variant in sorted(dark, key=lambda pv: (method_order(pv[1]), -parse_variant(pv[1]).hidden_lux)):
        same, ours = fits[people, unlit(variant)], fits[people, ours_of(variant)]
        rows = fits[people, variant]
        rooms = sorted(scored_rooms(rows) & scored_rooms(same) & scored_rooms(ours))
        if not rooms:
            continue
        own = np.mean([own_lux[r] for r in rooms])
        pair = lambda a, b: " / ".join(paired_change(a, b, rooms, kind, "posture_accuracy") for kind in ("fit", "heldout"))
        cells = lambda rs: " | ".join(f"{room_mean(rs, rooms, kind, k):.1f}{unit}" for k, unit in
                                      (("posture_accuracy", "%"), ("error_cm", " cm")) for kind in ("fit", "heldout"))
        if (people, unlit(variant), tuple(rooms)) not in shown:
            shown.add((people, unlit(variant), tuple(rooms)))
            lines.append(f"| {method_name(unlit(variant))} | rooms' own ({own:.2f} lux on average) | {len(rooms)} | "
                         f"{cells(same)} | | {pair(ours, same) if same is not ours else ''} |")
        lines += [f"| {method_name(unlit(variant))} | {parse_variant(variant).hidden_lux:g} lux | {len(rooms)} | "
                  f"{cells(rows)} | {pair(same, rows)} | {pair(ours, rows)} |"]
    return lines


def method_base(variant: str) -> str:
    """A variant without its '+LIGHT' and '+ARCH': ours with the same capture, people and training."""
    return "+".join(e for e in variant.split("+") if e not in LIGHTS and e not in ARCHS)


def method_key(variant: str) -> tuple[str, str]:
    """A variant's (light, network): the key of :data:`METHOD_NAMES`."""
    v = parse_variant(variant)
    return v.light, v.arch


def method_order(variant: str) -> tuple:
    """Sort key: the rows of :data:`METHOD_NAMES` in its order, then any other light and network."""
    key, order = method_key(variant), list(METHOD_NAMES)
    return (order.index(key) if key in order else len(order), *key)


def method_name(variant: str) -> str:
    """The paper's name for a variant's (light, network), else 'light + network'."""
    light, arch = method_key(variant)
    return METHOD_NAMES.get((light, arch), f"{LIGHTS.get(light, 'fitted spot')} + {ARCHS.get(arch, 'ResNet')}")


def room_mean(rows: dict, rooms: list[str], kind: str, key: str) -> float:
    """Mean of ``key`` over ``rooms`` of one variant's rows {(room, kind): row}."""
    return float(np.mean([float(rows[r, kind][key]) for r in rooms]))


def method_goals(variants: dict, base: str, rooms: dict) -> list[str]:
    """The issue's margins on fitted rooms, each on the rooms fitted with both: ours' error over
    AL + ResNet's (goal at most 0.57x) and ours' six-way minus the fitted spot + CNN's (goal at
    least 5 points), on test and simulated people."""
    find = lambda *key: next((v for v in variants if method_key(v) == key), None)
    ours, al, cnn = variants[base], find("adaptive", "resnet18"), find("fit", "chandran")
    lines = []
    for kind, who in (("fit", "test"), ("heldout", "simulated")):
        parts = []
        if al is not None and rooms[al]:
            ratio = room_mean(ours, rooms[al], kind, "error_cm") / room_mean(variants[al], rooms[al], kind, "error_cm")
            parts.append(f"error {ratio:.2f}x AL + ResNet's ({len(rooms[al])} rooms; goal at most 0.57x)")
        if cnn is not None and rooms[cnn]:
            gain = (room_mean(ours, rooms[cnn], kind, "posture_accuracy")
                    - room_mean(variants[cnn], rooms[cnn], kind, "posture_accuracy"))
            parts.append(f"six-way {gain:+.1f} points over the fitted spot + CNN ({len(rooms[cnn])} rooms; goal at "
                         "least +5)")
        if parts:
            lines.append(f"Ours on the {who} people: " + "; ".join(parts) + ".")
    return lines


def ensembles(out: Path, rooms: list[str], variants: list[str]) -> list[str]:
    """``--ensemble``: per room and kind of people, each network alone and the networks' average
    (posture probabilities and positions averaged), from the runs' predictions-*.npz; then the
    ensemble minus each network, paired over the rooms."""
    if len(variants) < 2:
        return []
    runs = lambda r: [run_dir(out / r, v) for v in variants]
    done = [r for r in rooms if all((d / "predictions-heldout.npz").exists() for d in runs(r))]
    lines = ["", f"Ensemble of {' and '.join(variants)} on {len(done)} rooms: six-way / error of each network and of "
                 "their average", "| room | people | " + " | ".join(variants) + " | ensemble |",
             "|---" * (len(variants) + 3) + "|"]
    gains = {"fit": [], "heldout": []}  # per room: ensemble minus each network, six-way
    for r in done:
        for kind, who in (("fit", "test"), ("heldout", "simulated")):
            z = [np.load(d / f"predictions-{kind}.npz") for d in runs(r)]
            t, xy = z[0]["true_posture"], z[0]["true_xy"]
            if any("posture_prob" not in q or not np.array_equal(q["true_posture"], t) for q in z):
                raise SystemExit(f"--ensemble: {r}'s {kind} predictions differ in people or lack probabilities "
                                 "(rescore the runs)")
            acc = lambda pred: 100 * float(np.mean(pred == t))
            err = lambda pred: 100 * float(np.linalg.norm(pred - xy, axis=1).mean())
            alone = [(acc(q["pred_posture"]), err(q["pred_xy"])) for q in z]
            average = lambda k: np.mean([q[k] for q in z], 0)
            both = (acc(average("posture_prob").argmax(1)), err(average("pred_xy")))
            gains[kind].append([both[0] - a for a, _ in alone])
            lines.append(f"| {r} | {who} ({len(t)}) | " + " | ".join(f"{a:.1f}% / {e:.1f} cm" for a, e in alone)
                         + f" | {both[0]:.1f}% / {both[1]:.1f} cm |")
    for kind, who in (("fit", "test"), ("heldout", "simulated")):
        g = np.array(gains[kind])
        if len(g) > 1:
            se = g.std(0, ddof=1) / np.sqrt(len(g))
            lines.append(f"Ensemble minus each network, six-way on the {who} people (mean +- standard error over "
                         f"{len(g)} rooms): " + ", ".join(f"{g[:, k].mean():+.1f} +- {se[k]:.1f} ({v})"
                                                      for k, v in enumerate(variants)) + ".")
    return lines


def posture_table(out: Path, rooms: dict, variants: list[str]) -> list[str]:
    """Six-way per true posture of each variant (the paper's Table 1 columns) on its rooms
    (``rooms[variant]``), their test and simulated people pooled, from each run's
    predictions-fit.npz and predictions-heldout.npz."""
    from nlos_spotlight.world.body import POSTURES

    lines = ["", "Six-way per posture (%), each method on its rooms, their test and simulated people pooled:",
             "| method | rooms | " + " | ".join(POSTURES) + " | all |", "|---" * (len(POSTURES) + 3) + "|"]
    for variant in variants:
        files = [run_dir(out / r, variant) / f"predictions-{k}.npz" for r in rooms[variant] for k in ("fit", "heldout")]
        if not files or not all(f.exists() for f in files):
            continue
        t, q = (np.concatenate([np.load(f)[k] for f in files]) for k in ("true_posture", "pred_posture"))
        cells = [f"{100 * np.mean(q[t == c] == c):.1f}" if np.any(t == c) else "" for c in range(len(POSTURES))]
        lines.append(f"| {method_name(variant)} | {len(rooms[variant])} | " + " | ".join(cells)
                     + f" | {100 * np.mean(t == q):.1f} |")
    return lines


def people_curve(fits: dict) -> list[str]:
    """Training people against accuracy on the rooms fitted at every size: variants that differ only
    in '+pN' / '+xN' (the same renders, fewer or more of them), so that rooms do not confound people."""
    base = lambda v: "+".join(e for e in v.split("+") if e[:1] not in ("p", "x"))  # FRAMES is digits
    curves = {}
    for (people, variant), rows in fits.items():
        curves.setdefault(base(variant), {})[people] = rows
    lines = []
    for b, sizes in sorted(curves.items()):
        common = sorted(set.intersection(*(scored_rooms(rows) for rows in sizes.values())))
        if len(sizes) < 2 or not common:
            continue
        lines += ["", f"Training people, variant {b} (+pN: the first N people of the render, +xN: N renders), "
                      f"on the {len(common)} rooms fitted at every size ({', '.join(common)}):",
                  "| training people | six-way (test) | six-way (simulated) | error (simulated) |", "|---|---|---|---|"]
        for people, rows in sorted(sizes.items()):
            mean = lambda kind, k: room_mean(rows, common, kind, k)
            lines.append(f"| {people} | {mean('fit', 'posture_accuracy'):.1f}% | "
                         f"{mean('heldout', 'posture_accuracy'):.1f}% | {mean('heldout', 'error_cm'):.1f} cm |")
        lines += people_steps(b, sizes) + people_rooms(b, sizes)
    return lines


def people_rooms(base: str, sizes: dict) -> list[str]:
    """Per room, six-way on its test people / on its 100 simulated ones at each training-people size."""
    rooms = sorted(set.union(*(scored_rooms(rows) for rows in sizes.values())))
    cell = lambda rows, r: (f"{float(rows[r, 'fit']['posture_accuracy']):.1f}% / "
                            f"{float(rows[r, 'heldout']['posture_accuracy']):.0f}%") if r in scored_rooms(rows) else ""
    lines = ["", f"Per room, variant {base}: six-way on the 30 test people / on the 100 simulated ones",
             "| room | " + " | ".join(f"{p} people" for p in sorted(sizes)) + " |", "|---" * (len(sizes) + 1) + "|"]
    return lines + [f"| {r} | " + " | ".join(cell(sizes[p], r) for p in sorted(sizes)) + " |" for r in rooms]


def people_steps(base: str, sizes: dict) -> list[str]:
    """Each step of the people curve on every room fitted at both sizes (more rooms than the rooms
    fitted at every size): the paired change, so that rooms do not confound people."""
    lines = ["", f"Each step, variant {base}, on the rooms fitted at both sizes (paired change, mean +- "
             "standard error over the rooms):",
             "| training people | rooms | six-way (test) | six-way (simulated) | error (simulated) |",
             "|---|---|---|---|---|"]
    steps = sorted(sizes)
    for a, b in zip(steps, steps[1:]):
        common = sorted(scored_rooms(sizes[a]) & scored_rooms(sizes[b]))
        if not common:
            continue
        delta = lambda kind, k, unit="": paired_change(sizes[a], sizes[b], common, kind, k) + unit
        lines.append(f"| {a} -> {b} | {len(common)} | {delta('fit', 'posture_accuracy')} | "
                     f"{delta('heldout', 'posture_accuracy')} | {delta('heldout', 'error_cm', ' cm')} |")
    return lines if len(lines) > 4 else []


def variant_pairs(fits: dict, pairs: list) -> list[str]:
    """``--pair BASE OTHER``: OTHER - BASE on the rooms scored with both (a variant named by several
    people counts, e.g. '1' of the 1,200- and 3,000-people fits: the one sharing the most rooms).
    BASE or OTHER may join variants with commas (e.g. a method's training seeds): their mean per
    room, on the rooms scored with all of them, so the standard error is over rooms only."""
    lines = []
    for base, other in pairs:
        group = base.split(",") + other.split(",")
        keys = lambda v: [k for k in fits if k[1] == v]
        common = lambda ks: set.intersection(*(scored_rooms(fits[k]) for k in ks))
        choices = [[]]
        for v in group:  # every way of picking one (people, variant) per name; keep the widest
            choices = [c + [k] for c in choices for k in keys(v)]
        best = max(choices, key=lambda ks: len(common(ks)), default=None)  # None: a name never fitted
        if best is None or not common(best):
            raise SystemExit(f"--pair {base} {other}: no room scored with every variant")
        rooms = sorted(common(best))
        n = len(base.split(","))
        before, after = seed_mean([fits[k] for k in best[:n]], rooms), seed_mean([fits[k] for k in best[n:]], rooms)
        delta = lambda kind, k, unit="": paired_change(before, after, rooms, kind, k) + unit
        name = lambda spec: spec if "," not in spec else f"mean of ({spec.replace(',', ', ')})"
        lines += ["", f"{name(other)} - {name(base)} on the {len(rooms)} rooms scored with both ({', '.join(rooms)}; "
                      "paired change, mean +- standard error over the rooms):",
                  "| six-way (test) | six-way (simulated) | error (test) | error (simulated) |", "|---|---|---|---|",
                  f"| {delta('fit', 'posture_accuracy')} | {delta('heldout', 'posture_accuracy')} | "
                  f"{delta('fit', 'error_cm', ' cm')} | {delta('heldout', 'error_cm', ' cm')} |"]
    return lines


def seed_mean(runs: list[dict], rooms: list[str]) -> dict:
    """Rows {(room, kind): {key: value}} averaging ``runs`` (one variant's rows each) on ``rooms``,
    for the test and held-out simulated people's six-way and error."""
    keys = ("posture_accuracy", "error_cm")
    return {(r, kind): {k: np.mean([float(rows[r, kind][k]) for rows in runs]) for k in keys}
            for r in rooms for kind in ("fit", "heldout")}


def task_spot_summary(args, fits: dict) -> None:
    """``--task-spot``: :func:`task_spot_tables`, written to summary-task-spot.md."""
    text = "\n".join(task_spot_tables(fits, args.task_spot, args.out)).lstrip("\n")
    print(text)
    (args.out / "summary-task-spot.md").write_text(text + "\n")


def task_spot_tables(fits: dict, groups: list, out: Path) -> list[str]:
    """``--task-spot V1 V2 ...``: the spot chosen by the task. In each room, of the candidates'
    networks (the same people and training under different spots, V1 ours), the one whose six-way on
    its 100 validation people is highest (ties: lower validation error); scored on the test and the
    held-out simulated people, which took no part in the choice. Beside it each candidate, and the
    candidate a choice by the held-out people would make (hindsight: what a perfect choice reaches).
    Where the runs' validation predictions are under ``out``, also the choice by the validation
    people's posture log-loss, a score less grainy than the count of right answers."""
    lines = []
    for candidates in groups:
        people, runs, rooms = task_spot_runs(fits, candidates)
        acc = lambda v, r, kind: float(runs[v][r, kind]["posture_accuracy"])
        pick = lambda r, kind: max(candidates, key=lambda v: (acc(v, r, kind), -float(runs[v][r, kind]["error_cm"])))
        chosen = {r: pick(r, "val") for r in rooms}
        hindsight = {r: pick(r, "heldout") for r in rooms}
        loss = {(v, r): validation_log_loss(run_dir(out / r, v)) for v in candidates for r in rooms}
        by_loss = ({r: min(candidates, key=lambda v: loss[v, r]) for r in rooms}
                   if None not in loss.values() else None)
        lines += ["", f"The spot chosen by the task ({people} simulated people a room, "
                      f"{parse_variant(candidates[0]).describe()}): in each room the candidate whose network reads "
                      "posture best on its 100 validation people; six-way validation / held-out simulated / test "
                      "per room and candidate (spot = candidate face):",
                  "| room | " + " | ".join(method_name(v) for v in candidates) + " | chosen | hindsight |",
                  "|---|" + "---|" * (len(candidates) + 2)]
        for r in rooms:
            cells = [f"{acc(v, r, 'val'):.0f} / {acc(v, r, 'heldout'):.0f} / {acc(v, r, 'fit'):.0f} "
                     f"({runs[v][r, 'fit']['spot'].split(':')[1]})" for v in candidates]
            lines.append(f"| {r} | " + " | ".join(cells) + f" | {method_name(chosen[r])} | {method_name(hindsight[r])} |")
        as_rows = lambda choice: {(r, k): runs[choice[r]][r, k] for r in rooms for k in ("fit", "heldout")}
        chosen_rows = as_rows(chosen)
        named = [(method_name(v), runs[v]) for v in candidates] + [("task-chosen spot (by validation)", chosen_rows)]
        if by_loss is not None:
            named.append(("task-chosen spot (by validation log-loss)", as_rows(by_loss)))
        named.append(("hindsight (by the held-out simulated people)", as_rows(hindsight)))
        lines += task_spot_means(named, rooms)
        same = sum(chosen[r] == hindsight[r] for r in rooms)
        lines.append(f"The validation people chose the hindsight candidate in {same} of {len(rooms)} rooms; the "
                     "task-chosen spot minus each candidate, six-way test / simulated: " + "; ".join(
                         f"{name} " + " / ".join(paired_change(rows, chosen_rows, rooms, kind, "posture_accuracy")
                                                 for kind in ("fit", "heldout")) for name, rows in named[1:len(candidates)]) + ".")
        if by_loss is not None:
            lines.append("Chosen by the validation log-loss: " + ", ".join(
                f"{r} {method_name(by_loss[r])} ({' / '.join(f'{loss[v, r]:.2f}' for v in candidates)})" for r in rooms)
                + f"; the held-out candidate in {sum(by_loss[r] == hindsight[r] for r in rooms)} of {len(rooms)} rooms.")
    return lines


def validation_log_loss(run: Path) -> float | None:
    """Mean -log p(true posture) of a run's validation people (``predictions-val.npz``), or None."""
    path = run / "predictions-val.npz"
    if not path.exists():
        return None
    with np.load(path) as z:
        p = z["posture_prob"][np.arange(len(z["true_posture"])), z["true_posture"]]
    return float(-np.log(np.clip(p, 1e-12, None)).mean())


def task_spot_runs(fits: dict, candidates: list[str]) -> tuple[int, dict, list[str]]:
    """(people, {variant: rows}, rooms) of a ``--task-spot`` group: the largest fit holding every
    candidate, and the rooms where each was scored on its validation and held-out people."""
    people = [p for p in {p for p, _ in fits} if all((p, v) in fits for v in candidates)]
    if not people:
        raise SystemExit(f"--task-spot: no fit holds every one of {' '.join(candidates)}")
    runs = {v: fits[max(people), v] for v in candidates}
    rooms = sorted(set.intersection(*({r for r, k in rows if k == "val"} & scored_rooms(rows)
                                      for rows in runs.values())))
    if not rooms:
        raise SystemExit(f"--task-spot: no room has validation rows for all of {' '.join(candidates)} "
                         "(fitted before validation was scored: fit them again)")
    return max(people), runs, rooms


def task_spot_means(named: list[tuple[str, dict]], rooms: list[str]) -> list[str]:
    """Each (name, rows) averaged over ``rooms``, paired with the first (ours)."""
    ours = named[0][1]
    lines = [f"Mean over the {len(rooms)} rooms; paired: minus ours (mean +- standard error over the rooms), "
             "test / simulated people:",
             "| method | six-way (test) | six-way (simulated) | error (test) | error (simulated) | paired six-way |"
             " paired error |", "|---|---|---|---|---|---|---|"]
    for name, rows in named:
        cells = [f"{room_mean(rows, rooms, kind, k):.1f}{unit}" for k, unit in (("posture_accuracy", "%"),
                 ("error_cm", " cm")) for kind in ("fit", "heldout")]
        pair = lambda k, unit="": "" if rows is ours else " / ".join(
            paired_change(ours, rows, rooms, kind, k) + unit for kind in ("fit", "heldout"))
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {pair('posture_accuracy')} | {pair('error_cm', ' cm')} |")
    return lines


def paired_change(before: dict, after: dict, rooms: list[str], kind: str, key: str) -> str:
    """after - before of ``key`` on ``rooms``: mean +- standard error over the rooms."""
    d = np.array([float(after[r, kind][key]) - float(before[r, kind][key]) for r in rooms])
    se = f" +- {d.std(ddof=1) / np.sqrt(len(d)):.1f}" if len(d) > 1 else ""
    return f"{d.mean():+.1f}{se}"


if __name__ == "__main__":
    try:
        main()
    except NlosError as exc:  # a malformed variant or room range: one line
        raise SystemExit(f"error: {exc}") from None
