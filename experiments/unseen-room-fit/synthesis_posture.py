"""Posture by analysis by synthesis: render the six postures in the room's scan, keep the nearest.

The per-room fit (``unseen_room_fit.py``) learns a room's light transport from thousands of people
rendered in its scan; the ideal observer (``experiments/physics-bounds/posture_separability.py``)
says the photograph holds posture. This reads posture with no training at all: for each test
photograph, the person's light (photograph minus empty-room photograph, both noisy) is compared with
the six postures' light rendered in the room's scan under the same spot, and the posture whose
rendering fits best (chi^2 whitened by the photographs' noise, clipped pixels left out) is the
answer.

The clothing albedo is always fitted, exactly: the renderer's person light is affine in the
albedo a per channel, L(a) = a N + (1 - a) Q (the projector's light on the body N, and Q the
ambient light it hides; ``train.imaging.albedo_factors``), so one render gives both and a is a
clipped weighted least-squares fit per channel. What else the renders are told, ``--know``:

* ``body``: the person's own build, pose variant, height, facing and place (only posture and
  albedo unknown): a control. Its chi^2 at the true posture should be about the pixel count
  (the photograph's noise), its accuracy near the ideal observer's "everything known".
* ``build``: the person's own build (gender, weight, muscle, proportions) at pose variant 0, at the
  true place, facing and height: with ``body`` and ``place``, what build and pose each cost.
* ``place``: the true floor position, facing and height; the body is the library's mean build at
  pose variant 0: what a body model that does not know the person costs.
* ``variants``: as ``place``, each posture's best of ``--pose-variants`` pose variants.
* ``position``: the true floor point only; per posture the facing is scanned over ``--facings``
  directions, then facing and height are fitted (``evaluate.synthesis.refine``).
* ``posvar``: as ``position``, each posture scored by the best of ``--pose-variants`` pose variants
  at its fitted facing and height.
* ``none``: nothing but the room: the place too (``evaluate.synthesis.read_photograph``: a coarse
  bank over the floor, then the same per posture with all four fitted). Also scores the place.
* ``fit``: as ``none``, the search started at the per-room fit's floor point for the photograph
  (``--fit-runs``) instead of the bank's cell. With ``--fit-runs`` the summary also fuses the
  fit's posture probabilities with this search's chi^2 (``evaluate.synthesis.fused_log_posterior``,
  the temperature chosen leaving one room out).
* ``fitvar``: as ``fit``, each posture scored by the best of ``--pose-variants`` pose variants at
  its fitted place, facing and height.

The searches render a coarser body (``--search-faces``) and score each posture's fit with the test
people's own body resolution.

Photographs are exactly those the per-room fits were scored on: the room's 30 static test people,
the fit's spot (``--fits``' CSV row of ``--variant``), the 16-frame still capture and the noise
draws of ``evaluate.seen.score_rooms`` (seed 20,000 + ``--seed``). Prints per room and writes
``--out``/synthesis-LEVELS-FIRST-LAST.csv (room, level, people, six-way and three-way accuracy, the fit's
accuracy and error on the same photographs with ``--fit-runs``, median chi^2 per pixel at the true
posture and at the answer, the place error, renders, seconds; resumable per room and level) and
per-person predictions.

    python experiments/unseen-room-fit/synthesis_posture.py --test out/unseen/test --rooms 0-11 --know body place \
        --fit-runs out/unseen/room-fit-3000 --out out/unseen/synthesis
    python experiments/unseen-room-fit/synthesis_posture.py --test out/unseen/test --rooms 0-11 --know position none \
        --people 15 --fit-runs out/unseen/room-fit-3000 --out out/unseen/synthesis
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import time
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.data.static import read_static
from nlos_spotlight.data.store import atomic_csv, atomic_npz
from nlos_spotlight.errors import NlosError
from nlos_spotlight.evaluate.room_fits import read_fit_rows, room_interval, room_range, run_dir, static_people
from nlos_spotlight.evaluate.synthesis import (Bank, Synthesizer, albedo_fit, floor_cells, mean_body,
                                               read_photograph)
from nlos_spotlight.render.sensor import SensorConfig

COLUMNS = ["room", "know", "spot", "people", "accuracy", "accuracy3", "fit_accuracy", "chi2_true", "chi2_best",
           "error_cm", "fit_error_cm", "renders", "seconds"]
KNOW = ("body", "build", "place", "variants", "position", "posvar", "none", "fit", "fitvar")
SEARCHES = {"position": ("truth", False), "posvar": ("truth", True), "none": ("bank", False),
            "fit": ("fit", False), "fitvar": ("fit", True)}
"""The levels that search (the others render at the person's own place, facing and height): where
the search's floor point comes from ('truth': the person's, kept; 'bank': the coarse bank's cell;
'fit': the per-room fit's answer) and whether each posture is scored by its best pose variant."""
BUILD = ("gender", "weight", "muscle", "proportions")
"""The body model's build phenotypes (``world.body.BodyParams``)."""
TEMPERATURES = 10.0 ** np.linspace(-1, 4, 51)
"""The fusion's temperatures tried (``evaluate.synthesis.fused_log_posterior``)."""


def fit_spot(fits: Path, room: str, variant: str) -> tuple[int, float]:
    """The fit's spot (its CSV row ``fit:<face>``) and its six-way accuracy on the test people."""
    for path in sorted(fits.glob("room-fit-*.csv")):
        for row in read_fit_rows(path):
            if row["room"] == room and row["variant"] == variant and row["spot"].startswith("fit:"):
                return int(row["spot"].split(":")[1]), float(row["posture_accuracy"])
    raise SystemExit(f"--fits {fits}: no row for {room} variant {variant} (run unseen_room_fit.py first)")


def fit_predictions(runs: Path | None, room: str, variant: str, people: int) -> tuple[float, float] | None:
    """The per-room fit's six-way accuracy and error (cm) on the same first ``people`` photographs
    (its run's ``predictions-fit.npz``), or None without ``--fit-runs``."""
    if runs is None:
        return None
    z = fit_run_arrays(runs, room, variant)
    ok = z["true_posture"][:people] == z["pred_posture"][:people]
    return 100 * float(ok.mean()), 100 * float(np.linalg.norm(z["pred_xy"] - z["true_xy"], axis=1)[:people].mean())


def fit_run_arrays(runs: Path | None, room: str, variant: str) -> dict:
    """The per-room fit's ``predictions-fit.npz`` on the room's test photographs."""
    if runs is None:
        raise SystemExit("--know fit and the fusion need --fit-runs (the per-room fits' rooms)")
    path = run_dir(runs / room, variant) / "predictions-fit.npz"
    if not path.exists():
        raise SystemExit(f"--fit-runs {runs}: no {path} (run unseen_room_fit.py for {room})")
    return dict(np.load(path))


def fit_places(runs: Path | None, room: str, variant: str, test, specs: list[dict]) -> np.ndarray:
    """(N, 2) the per-room fit's floor point for each test person, world frame; its true points
    must be the specs' (the same people in the same order)."""
    from nlos_spotlight.data.tensors import world_floor

    z = fit_run_arrays(runs, room, variant)
    frame = (test.origin_xy.numpy(), test.forward_xy.numpy())
    if not np.allclose(world_floor(z["true_xy"], *frame), [s["position"] for s in specs], atol=1e-4):
        raise SystemExit(f"{room}: the fit's test people are not the generated specs (positions differ)")
    return world_floor(z["pred_xy"], *frame)


def static_specs(data: Path, room: str) -> tuple[list[dict], object]:
    """The room's static test people's specs (as generated) and its plan entry."""
    from nlos_spotlight.data.config import read_dataset_config
    from nlos_spotlight.data.generate import plan
    from nlos_spotlight.data.scene_builder import SceneBuilder
    from nlos_spotlight.world.rooms import generate_room

    cfg = read_dataset_config(data)
    p = next((q for q in plan(cfg) if q.id == room), None)
    if p is None:
        raise SystemExit(f"{data}: no room {room} in its plan")
    b = SceneBuilder(cfg, p, data)
    scene = generate_room(p.seed, b._room_config()).scene
    return [s for s in b._specs(scene) if s["trajectory"] < 0], cfg


def photographs(test, face: int, frames: int, seed: int):
    """(d, var, keep): the person's light as photographed (photograph minus empty-room photograph,
    (B, H, W, 3)), its noise variance (the sum of both photographs'), and the unclipped pixels
    (B, H, W) -- the same photographs as ``score_rooms``."""
    from nlos_spotlight.train.recipe import seen_config
    from nlos_spotlight.render.sensor import auto_exposure, dn_per_radiance, noise_variance_dn
    from nlos_spotlight.train.imaging import capture, form_images

    net_cfg = seen_config(1).net
    sensor = SensorConfig.at(tuple(test.ambient.shape[:2]), {"burst_frames": frames} if frames > 1 else {})
    y = torch.zeros(len(test.faces))
    y[face] = 1.0
    gen = torch.Generator().manual_seed(20_000 + seed)
    idx = torch.arange(test.num_samples)
    ph = capture(test, idx, y, "spot", sensor, gen, True, net_cfg)
    # the camera knows the exposure it set (metered on the empty room); the noise's level is read
    # from the photographs themselves
    static = form_images(test, idx[:1], y, "spot")[1]
    k = dn_per_radiance(auto_exposure(static.clamp(min=0), sensor), sensor)
    var = sum(noise_variance_dn(im.clamp(min=0) * k, sensor) / k ** 2 for im in (ph.images, ph.background))
    return (ph.images - ph.background).double(), var.double(), ~ph.clipped


def room_synthesizer(room: Path, cfg, face: int, faces: int | None = None) -> Synthesizer:
    """The room's scan (its directory's meshes, as a user's scan) under candidate spot ``face``;
    ``faces``: a coarser body (as many samples on it) for the search, else the test people's own."""
    from nlos_spotlight.scene.io import load_scene
    from nlos_spotlight.world.body import posed_body

    scene = load_scene(room)
    scene.human = None
    # the dataset's sampling without its footprint (the study's recipe)
    settings = cfg.render_settings(person_samples=faces or cfg.render.person_samples, pixel_footprint=0,
                                   footprint_jitter=False)
    return Synthesizer(scene, read_static(room, "aim_points")["aim_points"][face], settings, faces or cfg.body_faces,
                       cfg.render.person_quadrature, pose=lambda params, n: posed_body(params, target_faces=n))


def candidates(spec: dict, know: str, variants: int) -> dict[str, list]:
    """Per posture, the bodies (params) to render at the person's own place for one person at
    ``know`` 'body', 'build' (the person's build, pose variant 0), 'place' (the mean build) or
    'variants' (the mean build, each of ``variants`` pose variants: the best one counts)."""
    from nlos_spotlight.world.body import POSTURES

    p = spec["params"]
    if know == "body":
        return {q: [dataclasses.replace(p, posture=q)] for q in POSTURES}
    mean = {q: mean_body(q, p.facing_deg, p.height_m) for q in POSTURES}
    if know == "build":
        return {q: [dataclasses.replace(b, **{k: getattr(p, k) for k in BUILD})] for q, b in mean.items()}
    if know == "variants":
        return {q: [dataclasses.replace(b, pose_seed=v) for v in range(variants)] for q, b in mean.items()}
    return {q: [b] for q, b in mean.items()}


def check_person(test, k: int, spec: dict) -> None:
    """SystemExit unless stored person ``k`` is spec's (the same posture): the specs and the stored
    samples must be the same people in the same order."""
    from nlos_spotlight.world.body import POSTURES

    if POSTURES[int(test.posture[k])] != spec["params"].posture:
        raise SystemExit(f"{test.scene_dir}: stored person {k} is not the generated spec {k} (posture differs)")


def synthesize_room(args, i: int) -> list[dict]:
    """Every ``--know`` level on room ``i``'s test photographs; one row per level."""
    from nlos_spotlight.evaluate.seen import GROUP_OF
    from nlos_spotlight.world.body import POSTURES

    room = f"test-{i:05d}"
    scene_dir = args.test / "scenes" / room
    face, fit_acc = fit_spot(args.fits, room, args.variant)
    specs, cfg = static_specs(args.test, room)
    test = static_people(scene_dir)
    if test.num_samples != len(specs):
        raise SystemExit(f"{room}: {test.num_samples} stored static people, {len(specs)} specs")
    for k, spec in enumerate(specs):
        check_person(test, k, spec)
    d, var, keep = photographs(test, face, args.frames, args.seed)
    syn = room_synthesizer(scene_dir, cfg, face)
    fast = room_synthesizer(scene_dir, cfg, face, faces=args.search_faces)
    rows = []
    starts = fit_places(args.fit_runs, room, args.variant, test, specs) \
        if any(SEARCHES.get(know, (None, False))[0] == "fit" for know in args.know) else None
    for know in args.know:
        t0, r0, f0 = time.perf_counter(), syn.renders, fast.renders
        origin, variants = SEARCHES.get(know, (None, False))
        bank = Bank(fast, floor_cells(fast.scene, args.spacing), 4) if origin == "bank" else None
        pred, chi_true, chi_best, err, chi_all, xy_all = [], [], [], [], [], []
        for k, spec in enumerate(specs[:args.people or None]):
            w = keep[k].unsqueeze(-1).double() / var[k]
            if origin is not None:
                reading = read_photograph(fast, syn, bank, d[k], w, POSTURES, args.facings, args.iterations,
                                          xy=spec["position"] if origin == "truth" else None,
                                          start=starts[k] if origin == "fit" else None,
                                          variants=args.pose_variants if variants else 1)
                best = reading.chi2
                xy_all.append(reading.xy)
                if origin != "truth":
                    err.append(float(np.linalg.norm(reading.xy - np.asarray(spec["position"]))))
            else:
                best = {q: min(albedo_fit(d[k], w, *syn.light(params, spec["position"]))[0] for params in bodies)
                        for q, bodies in candidates(spec, know, args.pose_variants).items()}
            npix = float(keep[k].sum()) * 3
            chi_all.append([best[q] for q in POSTURES])
            pred.append(POSTURES.index(min(best, key=best.get)))
            chi_true.append(best[spec["params"].posture] / npix)
            chi_best.append(min(best.values()) / npix)
            if args.verbose:
                print(f"  person {k}: {spec['params'].posture} -> {POSTURES[pred[-1]]}"
                      + (f", {100 * err[-1]:.1f} cm" if err else ""), flush=True)
        true = test.posture.numpy()[:len(pred)]
        pred = np.array(pred)
        fit = fit_predictions(args.fit_runs, room, args.variant, len(pred))
        if fit is not None:
            fit_acc = round(fit[0], 2)
        rows.append(dict(room=room, know=know, spot=face, people=len(pred),
                         accuracy=round(100 * float(np.mean(pred == true)), 2),
                         accuracy3=round(100 * float(np.mean(GROUP_OF[pred] == GROUP_OF[true])), 2),
                         fit_accuracy=fit_acc, chi2_true=round(float(np.median(chi_true)), 3),
                         chi2_best=round(float(np.median(chi_best)), 3),
                         error_cm=round(100 * float(np.mean(err)), 2) if err else "",
                         fit_error_cm=round(fit[1], 2) if fit is not None else "",
                         renders=syn.renders - r0 + fast.renders - f0, seconds=round(time.perf_counter() - t0, 1)))
        out = args.out / room
        out.mkdir(parents=True, exist_ok=True)
        atomic_npz(out / f"predictions-{know}.npz", true_posture=true, pred_posture=pred, chi2_true=np.array(chi_true),
                   chi2=np.array(chi_all), pred_xy=np.array(xy_all).reshape(-1, 2))
        print(" ".join(f"{k}={v}" for k, v in rows[-1].items()), flush=True)
    return rows


LEVELS = {"body": "the person's own body, place, facing and height",
          "build": "the person's build (pose variant 0) at the true place, facing, height",
          "place": "mean body at the true place, facing, height",
          "variants": "mean build, best of the pose variants, at the true place, facing, height",
          "position": "mean body at the true place; facing, height fitted",
          "posvar": "mean body at the true place; facing, height fitted; each posture its best pose variant",
          "none": "nothing known: place, facing, height fitted",
          "fit": "nothing known: the search started at the per-room fit's place",
          "fitvar": "nothing known: the search from the fit's place, each posture its best pose variant"}
"""Each ``--know`` level as the summary names it."""


def summary(args) -> list[str]:
    """Markdown lines: per level, six-way and three-way accuracy on the first ``--people`` test
    people of every room scored at that level (mean over rooms, 95% interval over rooms), the
    per-room fit on the same photographs, for 'none' the place error, the median over rooms of
    each room's median chi^2 per pixel at the true posture and at the answer (1: the photograph's
    noise; the CSVs' rows over all the rows' people), and for the searches the
    share of people whose true posture they fit worse than the 'place' level's render at the
    person's own place, facing and height (the search fell short of a point it could have
    reached); written to ``--out``/summary.md."""
    from nlos_spotlight.evaluate.seen import GROUP_OF

    rows = []
    for path in sorted(args.out.glob("synthesis-*.csv")):
        with path.open() as f:
            rows += list(csv.DictReader(f))
    lines = [f"Analysis by synthesis on the per-room fits' test photographs ({args.variant}'s spot, "
             f"{args.frames}-frame still capture), the first {args.people or 30} static test people of each room.", "",
             "| renders told | rooms | people | six-way | interval over rooms | upright/sitting/crouching | "
             "per-room fit, same photographs | place error | fit's error | chi^2/pixel, true posture / answer | "
             "search short |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for know in KNOW:
        rooms = sorted({r["room"] for r in rows if r["know"] == know})
        if not rooms:
            continue
        acc, acc3, fit, short, people = [], [], [], [], 0
        for room in rooms:
            z = np.load(args.out / room / f"predictions-{know}.npz")
            true, pred = (z[k][:args.people or None] for k in ("true_posture", "pred_posture"))
            place = args.out / room / "predictions-place.npz"
            if know in SEARCHES and place.exists():
                # the search's fit of the true posture is worse than the same body at the person's
                # own place, facing and height: the search, not the physics, missed it
                ref = np.load(place)["chi2_true"][:len(true)]
                short += list(z["chi2_true"][:len(true)] > ref + 1e-4)
            acc.append(100 * float(np.mean(true == pred)))
            acc3.append(100 * float(np.mean(GROUP_OF[true] == GROUP_OF[pred])))
            people += len(true)
            if args.fit_runs is not None:
                fit.append(fit_predictions(args.fit_runs, room, args.variant, len(true)))
        err = [float(r["error_cm"]) for r in rows if r["know"] == know and r["error_cm"]]
        fit_text = f"{np.mean([f[0] for f in fit]):.1f}%" if fit else ""
        chi = [(float(r["chi2_true"]), float(r["chi2_best"])) for r in rows if r["know"] == know]
        chi_text = f"{np.median([c[0] for c in chi]):.4f} / {np.median([c[1] for c in chi]):.4f}"
        err_text = f"{np.mean(err):.1f} cm" if err and len(err) == len(rooms) else ""
        fit_err = f"{np.mean([f[1] for f in fit]):.1f} cm" if fit and err_text else ""
        lines.append(f"| {LEVELS[know]} | {len(rooms)} | {people} | **{np.mean(acc):.1f}%** | {room_interval(acc)} | "
                     f"{np.mean(acc3):.1f}% | {fit_text} | {err_text} | {fit_err} | {chi_text} | "
                     f"{f'{100 * np.mean(short):.0f}%' if short else ''} |")
    lines += posture_lines(args)
    lines += lookalike_lines(args)
    lines += fusion_lines(args)
    (args.out / "summary.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return lines


def posture_lines(args) -> list[str]:
    """Markdown lines: each level's six-way accuracy per true posture (people pooled over rooms)."""
    from nlos_spotlight.world.body import POSTURES

    lines = ["", "Per true posture (people pooled over the rooms):", "",
             "| renders told | " + " | ".join(POSTURES) + " |", "|---" * (len(POSTURES) + 1) + "|"]
    for know in KNOW:
        paths = sorted(args.out.glob(f"test-*/predictions-{know}.npz"))
        if not paths:
            continue
        z = [np.load(p) for p in paths]
        true, pred = (np.concatenate([a[k][:args.people or None] for a in z]) for k in ("true_posture", "pred_posture"))
        lines.append(f"| {LEVELS[know]} | " + " | ".join(
            f"{100 * np.mean(pred[true == q] == q):.0f}% ({int((true == q).sum())})" for q in range(len(POSTURES))) + " |")
    return lines


def lookalike_lines(args) -> list[str]:
    """Markdown lines: of each search's wrong answers, how many fit the photograph better than the
    true posture rendered at the person's own place, facing and height (levels 'body', 'variants',
    'place'): look-alikes that no better search would reject with that body, against answers
    the search reached only because it fell short on the truth."""
    lines = ["", "Wrong answers that fit the photograph better than the true posture at the person's own place "
             "(chi^2 of the answer below the truth's):", "",
             "| search | wrong answers | below the person's own body | below the best pose variant | "
             "below the mean body |", "|---|---|---|---|---|"]
    for know in SEARCHES:
        wrong, below = 0, {ref: 0 for ref in ("body", "variants", "place")}
        for path in sorted(args.out.glob(f"test-*/predictions-{know}.npz")):
            z = np.load(path)
            refs = {ref: path.parent / f"predictions-{ref}.npz" for ref in below}
            if "chi2" not in z or len(z["chi2"]) == 0 or not all(r.exists() for r in refs.values()):
                continue
            n = min(len(z["true_posture"]), args.people or len(z["true_posture"]))
            true, chi2 = z["true_posture"][:n], z["chi2"][:n]
            # chi2_true is per pixel: the row's own true-posture chi^2 gives its pixel count
            answer = chi2.min(1) / chi2[np.arange(n), true] * z["chi2_true"][:n]
            miss = chi2.argmin(1) != true
            wrong += int(miss.sum())
            for ref, path_ref in refs.items():
                below[ref] += int((miss & (answer < np.load(path_ref)["chi2_true"][:n])).sum())
        if wrong:
            lines.append(f"| {LEVELS[know]} | {wrong} | " + " | ".join(str(v) for v in below.values()) + " |")
    return lines if len(lines) > 5 else []


def fusion_rooms(args, know: str) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per room scored at level ``know`` whose per-room fit stored its posture probabilities: (true
    posture (n,), synthesis chi^2 (n, 6), the fit's probabilities (n, 6)) on the same people."""
    rooms = {}
    for path in sorted(args.out.glob(f"test-*/predictions-{know}.npz")):
        z, room = np.load(path), path.parent.name
        f = fit_run_arrays(args.fit_runs, room, args.variant)
        if "chi2" not in z or "posture_prob" not in f:
            continue
        n = min(len(z["true_posture"]), args.people or len(z["true_posture"]))
        if not np.array_equal(f["true_posture"][:n], z["true_posture"][:n]):
            raise SystemExit(f"{room}: the fit's and the synthesis' people differ")
        rooms[room] = (z["true_posture"][:n], z["chi2"][:n], f["posture_prob"][:n])
    return rooms


def fused_accuracy(rooms: dict, temperature: float, names=None) -> list[float]:
    """Six-way accuracy (%) of the fused posterior at ``temperature`` in each room of ``names``
    (default all); temperature 0: the synthesis alone, infinity: the network alone."""
    from nlos_spotlight.evaluate.synthesis import fused_log_posterior

    acc = []
    for room in names or rooms:
        true, chi2, prob = rooms[room]
        if temperature == 0:
            pred = chi2.argmin(1)
        elif np.isinf(temperature):
            pred = prob.argmax(1)
        else:
            pred = fused_log_posterior(chi2, prob, temperature).argmax(1)
        acc.append(100 * float(np.mean(pred == true)))
    return acc


def fusion_lines(args) -> list[str]:
    """Markdown lines for each search started at the fit's place ('fit', 'fitvar'): the per-room
    fit's posterior times the synthesis likelihood, its temperature chosen for each room on the
    other rooms (leave one room out), against each alone on the same people; and, in sample, the
    accuracy over temperatures."""
    if args.fit_runs is None:
        return []
    return [line for know, (origin, _) in SEARCHES.items() if origin == "fit" for line in fusion_level(args, know)]


def fusion_level(args, know: str) -> list[str]:
    """:func:`fusion_lines` for one level."""
    rooms = fusion_rooms(args, know)
    if len(rooms) < 2:
        return []
    names = list(rooms)
    held = []
    for room in names:
        others = [r for r in names if r != room]
        scores = np.array([np.mean(fused_accuracy(rooms, t, others)) for t in TEMPERATURES])
        best = np.flatnonzero(scores == scores.max())
        held.append(fused_accuracy(rooms, float(TEMPERATURES[best[len(best) // 2]]), [room])[0])
    people = sum(len(v[0]) for v in rooms.values())
    alone = {name: fused_accuracy(rooms, t) for name, t in (("synthesis", 0.0), ("network", np.inf))}
    lines = ["", f"Fusion on {len(rooms)} rooms, {people} people: the per-room fit's posture probabilities times the "
             f"synthesis likelihood exp(-(chi^2 - min chi^2) / 2T) (level '{know}': {LEVELS[know]}), T chosen "
             "for each room on the others:", "",
             "| posture from | six-way | interval over rooms |", "|---|---|---|",
             f"| the per-room fit alone | {np.mean(alone['network']):.1f}% | {room_interval(alone['network'])} |",
             f"| the synthesis alone | {np.mean(alone['synthesis']):.1f}% | {room_interval(alone['synthesis'])} |",
             f"| both (T left one room out) | **{np.mean(held):.1f}%** | {room_interval(held)} |", "",
             "In sample, over T: " + ", ".join(f"T={t:g}: {np.mean(fused_accuracy(rooms, t)):.1f}%"
                                              for t in (0.0, 1.0, 10.0, 100.0, 1000.0, 10000.0, np.inf))]
    return lines


def _with_know(args, know: list[str]) -> argparse.Namespace:
    """``args`` asking only for the levels ``know``."""
    return argparse.Namespace(**{**vars(args), "know": know})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--test", type=Path, required=True, help="test dataset (unseen-test.yaml)")
    ap.add_argument("--fits", type=Path, default=Path("docs/results/unseen-room-fit-3000"),
                    help="the per-room fits' CSVs (the spot and the accuracy to compare)")
    ap.add_argument("--fit-runs", type=Path, default=None,
                    help="the per-room fits' rooms (out/unseen/room-fit-3000): compare on the same people")
    ap.add_argument("--variant", default="16+e120+x2", help="the fit whose spot and photographs are used")
    ap.add_argument("--rooms", default="0-11", help="test rooms, e.g. 0-11 or 0,3")
    ap.add_argument("--know", nargs="+", default=["body", "place"], choices=KNOW)
    ap.add_argument("--frames", type=int, default=16, help="frames the still capture averages")
    ap.add_argument("--facings", type=int, default=6, help="facings scanned before the refinement (the searches)")
    ap.add_argument("--spacing", type=float, default=0.2, help="the coarse bank's floor grid ('none'), m")
    ap.add_argument("--search-faces", type=int, default=300, help="body faces (and samples) of the search's renders")
    ap.add_argument("--iterations", type=int, default=6, help="least-squares evaluations per posture (the searches)")
    ap.add_argument("--pose-variants", type=int, default=8, help="pose variants tried ('variants', 'posvar', 'fitvar'; the library has 8)")
    ap.add_argument("--people", type=int, default=0, help="first PEOPLE test people of each room (0: all)")
    ap.add_argument("--verbose", action="store_true", help="a line per person")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("out/unseen/synthesis"))
    ap.add_argument("--summary-only", action="store_true", help="only the summary of the rooms scored so far")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.summary_only:
        summary(args)
        return
    rooms = room_range(args.rooms)
    path = args.out / f"synthesis-{'-'.join(args.know)}-{rooms[0]}-{rooms[-1]}.csv"
    rows = []
    if path.exists():  # resume: rooms and levels already scored are kept
        with path.open() as f:
            rows = list(csv.DictReader(f))
    for i in rooms:
        done = {r["know"] for r in rows if r["room"] == f"test-{i:05d}"}
        if set(args.know) <= done:
            continue
        rows += synthesize_room(_with_know(args, [k for k in args.know if k not in done]), i)
        atomic_csv(path, COLUMNS, rows)
    summary(args)


if __name__ == "__main__":
    try:
        main()
    except NlosError as exc:  # a malformed variant or room range: one line
        raise SystemExit(f"error: {exc}") from None
