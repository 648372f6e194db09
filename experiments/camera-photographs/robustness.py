"""Room models on photographs a real setup would give: each effect alone and all together.

For every room model (``--model ROOM:READING=DIR``; ``READING`` names its recipe: ``before`` for
``nlos fit --capture-preset ideal``, the preset's name otherwise) its held-out people are
photographed under one condition at a time and read by its network, with the same sensor noise
draws for every condition:

* ``fit-photographs`` (magnitude 0): the fit's own photographs (its report's figure: the
  person-free light as the dataset stores it, 2 x 2 samples a pixel);
* ``ideal`` (magnitude 0): the room's light converged (the fit's static layers, 8 x 8 cells a
  pixel, as a camera integrates it; every other condition is photographed in it too), no drift;
* capture effects (``render.variation.EFFECTS``: camera-shift, camera-roll, projector-gain,
  spot-drift, ambient-gain, exposure), each alone at ``--magnitudes`` times the ``tripod`` preset;
* the camera photographs (:func:`camera_photographs`, rendered apart from the fit's sampling):
  ``pixel-integrated``: the person's light integrated over each pixel (8 x 8 footprint
  sub-samples jittered in their cells, :data:`CAMERA_FOOTPRINT`; ``--camera-grid``: 16 x 16 at the
  cells' centres, the photographs before); ``pixel-integrated-2x2``: 2 x 2 sub-samples, each
  seeing the whole body (as the issue measured; ``--pixel-samples``; not converged: 14% from
  8 x 8 in the copy room); ``shadow``: the fit's scattered light plus the spot light the body
  blocks (``nlos_shadow``, 8,192 relay points, in every real with-minus-without photograph);
  ``camera``: the integrated light and the shadow (``--camera-draws``: each the mean of independent
  draws, as a photograph holds no Monte Carlo noise; what is left is in the run's JSON); ``clothing-dark`` / ``clothing-light``: the
  camera photographs of people dressed in albedo 0.05 / 0.9 (exact: the scattered light is linear
  in it, the shadow does not depend on it); a few people are also rendered again at the fit's own
  settings, to check they are the dataset's; diagnostics of the fit's own sampling:
  ``footprint-offsets`` and ``relay-offsets`` (its pixel offsets or shadow relay points drawn
  apart), ``relay-averaged`` (its shadow averaged with that second draw: half the Monte Carlo
  variance) and ``shadow-averaged`` (the camera photographs' shadow averaged with the second draw);
  ``camera-fit-footprint`` (the camera photographs with the person's light at the fit's 8 x 8
  footprint, other offsets) and ``camera-gain-corrected`` (their 16 x 16 light divided by the
  per-pixel gain over the fit's light, cross-fitted on the other half of the people,
  :func:`footprint_gain`): is the camera-photograph gap the fit's fixed footprint pattern?
  ``camera-f32`` (``--fine``): the camera photographs with the person's light at 32 x 32 (is
  16 x 16 converged?); ``bounce`` (``--bounce``): the camera photographs with the person's light
  over one more static bounce as well (``nlos_bounce``, :func:`bounce_light`), magnitude 1, and
  with it scaled to every later bounce (magnitude ``--bounce-tail``, :data:`BOUNCE_TAIL`);
  ``--photograph-bounce`` puts that tail in the ``camera``, clothing and ``all`` photographs too
  (every camera photograph holds it); ``shadow-tail`` (``--shadow-depth 10``): the camera
  photographs with the light the body stops past its first relay as well (:func:`shadow_tail_light`),
  which ``--photograph-bounce`` then puts in every camera photograph; ``--noise-draws`` averages
  every row over sensor-noise draws;
* ``mitsuba`` (``--mitsuba SPP``): with-minus-without photographs by Mitsuba 3's particle tracer
  at 6 bounces (:func:`mitsuba_people`);
* ``capture-all``: every capture effect at 1x ``tripod`` together, on the fit's person light;
* scan versus world (``--world-magnitudes``): ``camera-pose``, ``projector-aim``, ``albedo``,
  ``geometry`` (noise per vertex), ``warp`` (a smooth deformation) (``world.mismatch``), each alone: the people and the room's light rendered in a world
  that differs from the scan the room model believes by one calibration error
  (:func:`world_photographs`; ``--world-draws`` independent worlds, their people pooled in one
  row), beside ``world-scan``, the same rendering in the scan itself; the people are the
  dataset's, drawn in the scan (a world's own draw would place other people);
* ``all``: every capture effect at 1x ``tripod`` on the camera photographs.

The people are rendered again once per room (``--cache``, resumable, atomic) and shared by the
readings. ``python experiments/camera-photographs/robustness.py --table CSV`` prints the summary table and the goals'
verdicts; ``--merge OUT.csv A.csv B.csv ...`` joins per-room runs. Writes ``--out`` (CSV: room, reading, condition, magnitude, posture_accuracy,
posture3_accuracy, error_cm, people), ``*-flags.csv`` (how often ``nlos predict``'s drift flag is
right, :func:`flag_rates`) and a JSON of the run's settings and versions beside it.

    python experiments/camera-photographs/robustness.py --model copyroom:before=out/fits/copyroom-before \\
        --model copyroom:tripod=out/fits/copyroom --out docs/results/robustness.csv
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.errors import NlosError
from nlos_spotlight.render.mitsuba_ref import PHOTOGRAPH_DEPTH
from nlos_spotlight.fit.run import room_builder
from nlos_spotlight.fit.shadow import PHI
from nlos_spotlight.render.bounce import BOUNCE_TAIL
from nlos_spotlight.render.sensor import SensorConfig
from nlos_spotlight.render.variation import WORLD_EFFECTS

COLUMNS = ("room", "reading", "condition", "magnitude", "posture_accuracy", "posture3_accuracy", "error_cm", "people")
CAMERA_CONDITIONS = ("bounce", "shadow-tail", "footprint-offsets", "camera-f32", "camera-fit-footprint", "camera-gain-corrected", "relay-offsets", "relay-averaged", "shadow-averaged", "pixel-integrated", "pixel-integrated-2x2", "shadow", "camera", "clothing-dark", "clothing-light",
                     "all", "capture-all", "camera-mitsuba-people", "mitsuba")
CLOTHING = {"clothing-dark": 0.05, "clothing-light": 0.9}
SHADOW_SAMPLES = 1024
"""Static points relaying the light the body blocks (the renderer's default 4,096 at 2 x 2 sub-samples
a pixel costs about a minute a person: 67 million shadow rays at 4 x 4)."""
CAMERA_FOOTPRINT = 8
"""The camera photographs' person light: integrated over each pixel from 8 x 8 sub-samples jittered
in their cells (``RenderSettings.footprint_jitter``: an unbiased estimate of the pixel's mean light,
drawn apart from any fit's; ``--camera-draws`` averages independent draws)."""
GRID_FOOTPRINT = 16
"""``--camera-grid``: the camera photographs before jittering (16 x 16 sub-samples at their cells'
centres: unbiased for the 16 x 16 render, which is itself about 3.6% from the pixel's mean in the
copy room, the centres' bias falling as 1/n)."""
CAMERA_SHADOW_SAMPLES = 8192
"""Static points relaying the light the body blocks in the camera photographs (twice the fit's)."""
CAMERA_SEED = 7
"""``RenderSettings.footprint_seed`` of the camera photographs (the fit's is the default)."""
RELAY_OFFSET = 0.25
"""``RenderSettings.relay_offset`` of the ``relay-offsets`` condition (a fixed-relay fit's is 0.5)."""
REPRODUCED = 10
"""Held-out people rendered again at the fit's own settings: the check that they are the dataset's."""


@dataclasses.dataclass
class Room:
    """One room model and what its conditions need."""

    name: str
    reading: str
    path: Path
    models: object
    test: object  # SceneTensors of the held-out people, static layers attached
    spot: int
    aim: np.ndarray
    sensor: object
    indices: list[int]  # dataset sample index of each held-out person


def load_room(name: str, reading: str, path: Path, people: int) -> Room:
    from nlos_spotlight.fit.train import fit_train_config, heldout_positions, room_layers
    from nlos_spotlight.train.checkpoint import load_trained

    rep = json.loads((path / "report.json").read_text())
    cfg = fit_config(path)
    if people > cfg.heldout:
        raise NlosError(f"--people: {path} holds {cfg.heldout} held-out people, not {people}")
    from nlos_spotlight.data.tensors import load_split

    s, = load_split(path / "data", "train", ["normals"], samples="images")  # as room_split reads it
    if cfg.shadow.shadow_samples > 0:  # the model's people hold the light their bodies block
        from nlos_spotlight.fit.train import with_shadow

        s = with_shadow(s, path, cfg, int(rep["spot"]["face"]))
    keep = heldout_positions(s, cfg)[:people]
    test = dataclasses.replace(s.subset(keep), layers=room_layers(path, rep["spot"]["aim"]))
    idx = (keep + cfg.transport_people).tolist()  # dataset indices: image samples follow the full-transport ones
    tc = fit_train_config(cfg, path)
    return Room(name, reading, path, load_trained(path), test, int(rep["spot"]["face"]), np.asarray(rep["spot"]["aim"]),
                SensorConfig.at(tuple(test.ambient.shape[:2]), tc.sensor), idx)


def fit_config(model: Path):
    """The ``FitConfig`` a room model was fitted with (``fit.json``)."""
    from nlos_spotlight.fit.config import FitConfig

    return FitConfig.from_record(json.loads((Path(model) / "fit.json").read_text())["settings"])


def cached(path: Path, room: Room) -> dict[str, np.ndarray] | None:
    """The arrays of a cached render of ``room``'s held-out people (``indices`` among them), or None
    where there is none or it holds other people."""
    if not path.exists():
        return None
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files} if list(z["indices"]) == room.indices else None


def camera_people(room: Room, cache: Path, pixel_samples: int) -> dict[str, np.ndarray]:
    """The held-out people rendered again (cached): the fit's settings (a reproduction check),
    ``pixel_samples``^2 sub-samples a pixel, and the shadow term."""
    from nlos_spotlight.data.store import atomic_npz

    path = cache / room.name / f"people-{len(room.indices)}-p{pixel_samples}.npz"
    if (got := cached(path, room)) is not None:
        return got
    builder, dcfg = room_builder(room.path, fit_config(room.path))
    base = dcfg.render_settings()
    t0 = time.perf_counter()
    fine = builder.rerender(room.indices, dataclasses.replace(base, transport_pixel_samples=pixel_samples,
                                                              pixel_footprint=0, shadow_samples=SHADOW_SAMPLES),
                            room.aim, ("nlos", "nlos_ambient", "nlos_shadow"))
    out = {"indices": np.asarray(room.indices), **{f"fine_{k}": v for k, v in fine.items()},
           "seconds": np.float64(time.perf_counter() - t0)}
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_npz(path, **out)
    return out


def fit_reproduction(room: Room, cache: Path) -> dict[str, np.ndarray]:
    """The first :data:`REPRODUCED` held-out people rendered again at the fit's own settings
    (``fit_nlos``: the check that they are the dataset's) and, for a fit with footprint sampling,
    all of them at its footprint with other pixel offsets (``offset_nlos``, :data:`CAMERA_SEED`)."""
    from nlos_spotlight.data.store import atomic_npz

    cfg = fit_config(room.path)
    jit = "j" if cfg.render.footprint_jitter else ""
    path = cache / room.name / f"fit-{len(room.indices)}-f{cfg.render.pixel_footprint}{jit}-s{cfg.shadow.shadow_samples}.npz"
    if (got := cached(path, room)) is not None:
        return {k: v for k, v in got.items() if k != "indices"}
    builder, dcfg = room_builder(room.path, cfg)
    base = dcfg.render_settings()
    out = {"fit_nlos": builder.rerender(room.indices[:REPRODUCED], base, room.aim, ("nlos",))["nlos"]}
    if cfg.shadow.shadow_samples > 0:  # the fit's own shadow, only its relay points drawn apart
        out["relay_shadow"] = builder.rerender(room.indices, dataclasses.replace(
            base, shadow_samples=cfg.shadow.shadow_samples, relay_offset=RELAY_OFFSET), room.aim, ("nlos_shadow",),
            one_footprint=True)["nlos_shadow"]
    if cfg.render.pixel_footprint > 0:
        out["offset_nlos"] = builder.rerender(room.indices, dataclasses.replace(base, footprint_seed=CAMERA_SEED),
                                              room.aim, ("nlos",))["nlos"]
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_npz(path, indices=np.asarray(room.indices), **out)
    return out


WORLD_SEED = 11
"""Seed of the first world's draw (the same worlds for every reading of a room); draw i's is
``WORLD_SEED + 1000 i``."""
WORLD_FOOTPRINT = 8
"""Footprint of the world photographs' person light: 8 x 8 sub-samples jittered in their cells (an
unbiased pixel mean, as the camera photographs), drawn apart from any fit's, other relay points."""


def world_photographs(room: Room, cache: Path, effect: str, magnitude: float, draw: int = 0) -> dict[str, np.ndarray]:
    """The held-out people photographed in a world that differs from the scan by ``effect`` at
    ``magnitude`` x ``tripod`` (cached): their light (``nlos``, ``nlos_ambient``, ``nlos_shadow``)
    at :data:`WORLD_FOOTPRINT`, and the world's static layers (what the capture records of the
    room). Magnitude 0 is the scan itself: the reference of these conditions. ``draw``: which of
    the independent worlds of that effect and magnitude (:data:`WORLD_SEED`)."""
    from nlos_spotlight.data.store import atomic_npz
    from nlos_spotlight.render.layers import static_layers
    from nlos_spotlight.render.settings import RenderSettings
    from nlos_spotlight.render.variation import layers_arrays, preset
    from nlos_spotlight.world.mismatch import mismatched_world

    name = "scan" if magnitude == 0 else f"{effect}-{magnitude:g}" + (f"-d{draw}" if draw else "")
    path = cache / room.name / f"world-{name}-{len(room.indices)}-f{WORLD_FOOTPRINT}j.npz"
    if (got := cached(path, room)) is not None:
        return got
    cfg = fit_config(room.path)
    builder, dcfg = room_builder(room.path, cfg)
    v = preset("tripod").only(effect).scaled(magnitude)
    world, aim, drawn = mismatched_world(builder.room_scene(), room.aim, v, WORLD_SEED + 1000 * draw)
    rs = RenderSettings(pixel_samples=dcfg.render.pixel_samples, pixel_footprint=WORLD_FOOTPRINT, footprint_jitter=True,
                        spot_samples=dcfg.render.spot_samples,
                        person_samples=dcfg.render.person_samples, shadow_samples=4096, footprint_seed=CAMERA_SEED,
                        relay_offset=RELAY_OFFSET, device="cpu")
    t0 = time.perf_counter()
    got = builder.rerender(room.indices, rs, aim, ("nlos", "nlos_ambient", "nlos_shadow"), world=world,
                           one_footprint=True)
    L = static_layers(world, aim)
    out = {"indices": np.asarray(room.indices), **got, **layers_arrays(L, "layer_"), "aim": aim,
           "drawn": np.array(json.dumps(drawn)), "seconds": np.float64(time.perf_counter() - t0)}
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_npz(path, **out)
    print(f"{room.name}: world {name}: {len(room.indices)} people in {out['seconds']:.0f} s ({drawn})", flush=True)
    return out


def world_test(room: Room, w: dict):
    """``room``'s held-out people as photographed in world ``w`` (:func:`world_photographs`)."""
    from nlos_spotlight.render.variation import layers_from

    t = with_person_light(room.test, room.spot, w["nlos"] + w["nlos_shadow"], w["nlos_ambient"])
    return dataclasses.replace(t, layers=layers_from(w, "layer_"))


def world_conditions(room: Room, cache: Path, magnitudes: list[float], draws: int = 1,
                     effects: tuple[str, ...] = WORLD_EFFECTS) -> list:
    """(condition, magnitude, test people, variation) of the scan-versus-world rows: ``world-scan``
    (magnitude 0: the same rendering in the scan itself) and each of ``effects`` (of :data:`WORLD_EFFECTS`)."""
    from nlos_spotlight.render.variation import preset

    ideal = preset("ideal")
    rows = [("world-scan", 0.0, world_test(room, world_photographs(room, cache, "camera-pose", 0.0)), ideal)]
    for effect in effects:
        for m in magnitudes:
            rows.append((effect, m, [world_test(room, world_photographs(room, cache, effect, m, d)) for d in range(draws)],
                         ideal))
    return rows


def camera_photographs(room: Room, cache: Path, draws: int = 1, grid: bool = False) -> dict[str, np.ndarray]:
    """The held-out people as a camera records them (cached): their light integrated over each pixel
    (:data:`CAMERA_FOOTPRINT`) and the light their bodies block (:data:`CAMERA_SHADOW_SAMPLES`),
    rendered apart from the fit's own sampling (:data:`CAMERA_SEED`): ``cam_nlos``,
    ``cam_nlos_ambient``, ``cam_nlos_shadow``. A real photograph holds no Monte Carlo noise: with
    ``draws`` > 1 each is the mean of that many independent draws (pixel offsets and relay points
    apart), and ``cam_noise_nlos`` / ``cam_noise_shadow`` (N,) the relative L2 standard error of
    the mean left in each person's light and shadow (from the draws' spread). ``grid``: the recipe
    before (:data:`GRID_FOOTPRINT`)."""
    parts = [_camera_draw(room, cache, d, grid) for d in range(draws)]
    out = {k: np.mean([p[k] for p in parts], 0) for k in ("cam_nlos", "cam_nlos_ambient", "cam_nlos_shadow")}
    out["seconds"] = np.float64(sum(float(p["seconds"]) for p in parts))
    if draws > 1:
        for k in ("nlos", "nlos_shadow"):
            a = np.stack([p[f"cam_{k}"] for p in parts])  # (draws, N, H, W, 3)
            spread = np.sqrt(((a - a.mean(0)) ** 2).sum((0, 2, 3, 4)) / (draws - 1) / draws)
            out[f"cam_noise_{k.replace('nlos_', '')}"] = spread / np.linalg.norm(a.mean(0).reshape(a.shape[1], -1), axis=1)
    return out


def _camera_draw(room: Room, cache: Path, draw: int, grid: bool = False) -> dict[str, np.ndarray]:
    """Draw ``draw`` of :func:`camera_photographs` (cached; draw 0 is the benchmark's first)."""
    from nlos_spotlight.data.store import atomic_npz
    from nlos_spotlight.render.settings import RenderSettings

    tail = f"-d{draw}" if draw else ""
    n = GRID_FOOTPRINT if grid else CAMERA_FOOTPRINT
    path = cache / room.name / f"camera-{len(room.indices)}-f{n}{'' if grid else 'j'}-s{CAMERA_SHADOW_SAMPLES}{tail}.npz"
    if (got := cached(path, room)) is not None:
        return got
    builder, dcfg = room_builder(room.path, fit_config(room.path))
    rs = RenderSettings(pixel_samples=dcfg.render.pixel_samples, pixel_footprint=n, footprint_jitter=not grid,
                        spot_samples=dcfg.render.spot_samples, person_samples=dcfg.render.person_samples,
                        shadow_samples=CAMERA_SHADOW_SAMPLES, footprint_seed=CAMERA_SEED + 100 * draw,
                        relay_offset=(0.5 + draw * PHI) % 1.0, device="cpu")
    t0 = time.perf_counter()
    got = builder.rerender(room.indices, rs, room.aim, ("nlos", "nlos_ambient", "nlos_shadow"), one_footprint=True)
    out = {"indices": np.asarray(room.indices), **{f"cam_{k}": v for k, v in got.items()},
           "seconds": np.float64(time.perf_counter() - t0)}
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_npz(path, **out)
    print(f"{room.name}: camera photographs, draw {draw}: {len(room.indices)} people in {out['seconds']:.0f} s", flush=True)
    return out


FINE_FOOTPRINT = 32
"""Footprint of the ``camera-f32`` photographs' person light (the convergence check of
``CAMERA_FOOTPRINT``: brute force converges about as 1/n, so 32 x 32 is about twice as close)."""


BOUNCE_RELAY = 4096
"""Relay points of the ``bounce`` photographs' fifth bounce (``nlos_bounce``, ``render/bounce.py``)."""


def bounce_light(room: Room, cache: Path) -> dict[str, np.ndarray]:
    """The held-out people's light over one more static bounce (``nlos_bounce``: the room relaying
    the spot onto the body and the body's light to the camera), at the camera photographs' footprint
    and seed (cached): ``bounce_nlos``."""
    from nlos_spotlight.data.store import atomic_npz
    from nlos_spotlight.render.settings import RenderSettings

    from nlos_spotlight.render.bounce import NEAR_FIELD

    near = f"-near{NEAR_FIELD:g}" if NEAR_FIELD else ""  # rendered before the distance floor: no suffix
    path = cache / room.name / f"bounce-{len(room.indices)}-f{CAMERA_FOOTPRINT}j-s{BOUNCE_RELAY}{near}.npz"
    if (got := cached(path, room)) is not None:
        return {k: v for k, v in got.items() if k != "indices"}
    builder, dcfg = room_builder(room.path, fit_config(room.path))
    rs = RenderSettings(pixel_samples=dcfg.render.pixel_samples, pixel_footprint=CAMERA_FOOTPRINT, footprint_jitter=True,
                        spot_samples=dcfg.render.spot_samples, person_samples=dcfg.render.person_samples,
                        shadow_samples=BOUNCE_RELAY, footprint_seed=CAMERA_SEED, relay_offset=0.5, device="cpu")
    t0 = time.perf_counter()
    got = builder.rerender(room.indices, rs, room.aim, ("nlos_bounce",), one_footprint=True)
    out = {"bounce_nlos": got["nlos_bounce"], "bounce_seconds": np.float64(time.perf_counter() - t0)}
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_npz(path, indices=np.asarray(room.indices), **out)
    print(f"{room.name}: the fifth bounce of {len(room.indices)} people in {out['bounce_seconds']:.0f} s", flush=True)
    return out


def shadow_tail_light(room: Room, cache: Path, depth: int) -> dict[str, np.ndarray]:
    """The held-out people's shadow past its first relay (``nlos_shadow`` at ``shadow_depth`` ``depth``
    minus at 4, the same relay points: the room's later relays the body stops, ``render/tail.py``),
    at the camera photographs' footprint and seed (cached): ``shadow_tail``."""
    from nlos_spotlight.data.store import atomic_npz
    from nlos_spotlight.render.settings import RenderSettings

    path = cache / room.name / f"shadow-tail-{len(room.indices)}-f{CAMERA_FOOTPRINT}j-s{BOUNCE_RELAY}-d{depth}.npz"
    if (got := cached(path, room)) is not None:
        return {k: v for k, v in got.items() if k != "indices"}
    builder, dcfg = room_builder(room.path, fit_config(room.path))
    t0 = time.perf_counter()
    got = [builder.rerender(room.indices, RenderSettings(
        pixel_samples=dcfg.render.pixel_samples, pixel_footprint=CAMERA_FOOTPRINT, footprint_jitter=True,
        spot_samples=dcfg.render.spot_samples, person_samples=dcfg.render.person_samples, shadow_samples=BOUNCE_RELAY,
        shadow_depth=d, footprint_seed=CAMERA_SEED, relay_offset=0.5, device="cpu"), room.aim, ("nlos_shadow",),
        one_footprint=True)["nlos_shadow"] for d in (4, depth)]
    out = {"shadow_tail": got[1] - got[0], "shadow_tail_seconds": np.float64(time.perf_counter() - t0)}
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_npz(path, indices=np.asarray(room.indices), **out)
    print(f"{room.name}: the shadow past its first relay of {len(room.indices)} people in "
          f"{out['shadow_tail_seconds']:.0f} s", flush=True)
    return out


def fine_light(room: Room, cache: Path) -> dict[str, np.ndarray]:
    """The held-out people's scattered light (``nlos``, ``nlos_ambient``) at :data:`FINE_FOOTPRINT`
    (cached): ``f32_nlos``, ``f32_nlos_ambient``."""
    from nlos_spotlight.data.store import atomic_npz

    path = cache / room.name / f"fine-{len(room.indices)}-f{FINE_FOOTPRINT}.npz"
    if (got := cached(path, room)) is not None:
        return {k: v for k, v in got.items() if k != "indices"}
    builder, dcfg = room_builder(room.path, fit_config(room.path))
    rs = dcfg.render_settings(pixel_footprint=FINE_FOOTPRINT, footprint_seed=CAMERA_SEED + 50)
    got = builder.rerender(room.indices, rs, room.aim, ("nlos", "nlos_ambient"))
    out = {f"f32_{k}": v for k, v in got.items()}
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_npz(path, indices=np.asarray(room.indices), **out)
    return out


MITSUBA_DEPTH = PHOTOGRAPH_DEPTH
"""Bounces of the Mitsuba photographs (``render.mitsuba_ref.PHOTOGRAPH_DEPTH``)."""


def mitsuba_people(room: Room, cache: Path, spp: int, count: int, progress: bool = True) -> dict[str, np.ndarray]:
    """The first ``count`` held-out people photographed by Mitsuba 3's particle tracer
    (``render.mitsuba_ref``, ``max_depth`` :data:`MITSUBA_DEPTH`): the room with the person minus
    the room without, at the same seeds (paths that never meet the person cancel), so it holds every
    bounce up to the depth: the light the body scatters, the light it blocks, and their
    interreflections. Two halves of ``spp`` at other seeds give the Monte Carlo noise. One cached
    file a person (resumable): ``mitsuba_presence`` (N, H, W, 3) and ``mitsuba_noise`` (N,), the
    relative L2 standard error of each image."""
    from nlos_spotlight.data.store import atomic_npz
    from nlos_spotlight.render.mitsuba_ref import mitsuba_photograph
    from nlos_spotlight.scene.format import Human

    d = cache / room.name / f"mitsuba-d{MITSUBA_DEPTH}-spp{spp}"
    d.mkdir(parents=True, exist_ok=True)
    cfg = fit_config(room.path)
    builder, dcfg = room_builder(room.path, cfg)
    scene, _ = builder._room()
    specs, out, noise, t0 = builder._specs(scene), [], [], time.perf_counter()
    for n, k in enumerate(room.indices[:count]):
        path = d / f"{k:05d}.npz"
        try:
            with np.load(path, allow_pickle=False) as z:
                out.append(z["presence"])
                noise.append(float(z["noise"]))
            continue
        except (OSError, ValueError, KeyError):
            pass
        body, person, t = builder._person(specs[k], scene.hidden_region.floor_z)
        sc = dataclasses.replace(scene, human=Human("human.ply", np.asarray(specs[k]["params"].albedo, np.float64),
                                                   person.translated_mesh(t)))
        img, e = mitsuba_photograph(sc, room.aim, spp, seed=1000 * k, max_depth=MITSUBA_DEPTH)
        out.append(img)
        noise.append(e)
        atomic_npz(path, presence=img, noise=np.float64(noise[-1]))
        if progress:
            print(f"{room.name}: mitsuba {n + 1}/{count} people, {time.perf_counter() - t0:.0f} s, "
                  f"Monte Carlo noise {100 * noise[-1]:.0f}%", flush=True)
    return {"mitsuba_presence": np.stack(out), "mitsuba_noise": np.asarray(noise)}


def footprint_gain(fit_light: np.ndarray, camera_light: np.ndarray) -> np.ndarray:
    """(N, H, W, 3) per-pixel gain of the camera photographs' person light over the fit's, each
    person's from the other half of the people (cross-fitted: no person corrects itself): a fixed
    pattern of the fit's footprint that a network can learn (``camera-gain-corrected``)."""
    n = len(fit_light)
    halves = [np.arange(n) < n // 2, np.arange(n) >= n // 2]
    out = np.ones_like(camera_light)
    for mine, other in (halves, halves[::-1]):
        f, c = fit_light[other].sum(0), camera_light[other].sum(0)
        ok = np.abs(f) > 1e-6 * np.abs(f).max()
        out[mine] = np.clip(np.where(ok, c / np.where(ok, f, 1.0), 1.0), 0.5, 2.0)
    return out


def footprint_pattern(fit_light: np.ndarray, camera_light: np.ndarray, offset_light: np.ndarray) -> dict:
    """How far the people-mean person light of the camera photographs (16 x 16) and of the fit's
    footprint at other offsets is from the fit's own (relative L2), and how alike the per-pixel gain
    maps of two halves of the people are (correlation): a fixed pattern, not noise."""
    rel = lambda a, b: float(np.linalg.norm(a - b) / np.linalg.norm(b))
    n = len(fit_light)
    gain = lambda sl: np.clip(camera_light[sl].sum(0) / np.where(np.abs(fit_light[sl].sum(0)) > 0,
                                                                  fit_light[sl].sum(0), 1.0), 0.0, 3.0)
    a, b = gain(slice(0, n // 2)), gain(slice(n // 2, n))
    return {"mean_light_camera_vs_fit": rel(camera_light.mean(0), fit_light.mean(0)),
            "mean_light_fit_offsets_vs_fit": rel(offset_light.mean(0), fit_light.mean(0)),
            "gain_map_halves_correlation": float(np.corrcoef(a.ravel(), b.ravel())[0, 1])}


def with_person_light(test, spot: int, nlos: np.ndarray, nlos_ambient: np.ndarray):
    """``test`` whose people's light under ``spot`` is ``nlos`` (N, H, W, 3) (one stored column, its
    shadow term and later bounces included or not as given: the stored ones are dropped)."""
    n, t = test.num_samples, test.u.shape[1]
    u = torch.zeros(n, t, 1, dtype=test.u.dtype)
    u[:, spot, 0] = 1
    v = torch.as_tensor(nlos, dtype=test.v.dtype)[:, None]
    return dataclasses.replace(test, u=u, v=v, nlos_ambient=torch.as_tensor(nlos_ambient, dtype=test.nlos_ambient.dtype),
                               shadow=None, bounce=None)


def spot_vector(room: Room, test) -> torch.Tensor:
    y = torch.zeros(test.u.shape[1])
    y[room.spot] = 1
    return y


def score(room: Room, test, variation=None, seed: int = 0, draws: int = 1) -> dict:
    """Six-way and 3-class posture accuracy (%) and mean error (cm) of ``test`` (or of a list of
    tests pooled: one row over several worlds, each its own photographs); ``correct`` and
    ``error_m`` hold each person's outcome (:func:`paired`), averaged over ``draws`` independent
    sensor noise and drift draws (seeds ``seed + 1000 k``): what a row says about the people, less
    the luck of one noise draw."""
    from nlos_spotlight.evaluate.seen import score_rooms

    if isinstance(test, list):
        parts = [(t.num_samples, score(room, t, variation, seed + i, draws)) for i, t in enumerate(test)]
        n = sum(k for k, _ in parts)
        out = {key: sum(k * r[key] for k, r in parts) / n for key in SCORES}
        return {**out, **{k: np.concatenate([r[k] for _, r in parts]) for k in ("correct", "error_m")}}
    y = spot_vector(room, test)
    runs = [score_rooms(room.models.net, room.models.config.net, room.sensor, [test], [(y, "spot")], True,
                        seed + 1000 * k, variation=variation) for k in range(draws)]
    pp = [r["per_person"] for r in runs]
    return {**{k: float(np.mean([r[k] for r in runs])) for k in SCORES},
            "correct": np.mean([p["true_posture"] == p["pred_posture"] for p in pp], 0),
            "error_m": np.mean([np.linalg.norm(p["pred_xy"] - p["true_xy"], axis=1) for p in pp], 0)}


SCORES = ("posture_accuracy", "posture3_accuracy", "error_cm")
PAIRED_COLUMNS = ("room", "reading", "condition", "magnitude", "reference", "people", "posture_drop",
                  "posture_drop_se", "error_ratio", "error_ratio_lo", "error_ratio_hi")
BOOTSTRAP = 2000
"""Resamples of the people for the error ratio's 95% interval."""


MITSUBA_REFERENCES = ("camera-mitsuba-people", "camera-mitsuba-noise")
"""Mitsuba's photographs are paired with ours of the same people too: as rendered, and with
Mitsuba's own Monte Carlo noise added (what its noise alone costs)."""


def _pairs(outcomes: dict):
    """((condition, magnitude), outcome, reference name) of every pairing :func:`paired` reports."""
    for (cond, mag), r in outcomes.items():
        if cond in ("ideal", "world-scan", "fit-photographs"):
            continue
        yield (cond, mag), r, "world-scan" if cond in WORLD_EFFECTS else "ideal"
        if cond == "mitsuba":
            for ref in MITSUBA_REFERENCES:
                yield (cond, mag), r, ref


def paired(name: str, reading: str, outcomes: dict) -> list[dict]:
    """Each row against its reference on the same people (``ideal``; ``world-scan`` for the world
    effects, repeated over the worlds pooled in a row): the drop in six-way posture (points) with
    its paired standard error, and the mean error's ratio with a bootstrap 95% interval. With 100
    people a drop's standard error is 3-5 points: a goal of 3 points is at the edge of what the
    benchmark resolves, and this says by how much."""
    rng = np.random.default_rng(0)
    out = []
    for (cond, mag), r, ref_name in _pairs(outcomes):
        ref = outcomes.get((ref_name, 0.0 if ref_name in ("ideal", "world-scan") else mag))
        if ref is None or len(r["correct"]) < len(ref["correct"]):
            continue
        k = len(r["correct"]) // len(ref["correct"])
        c0, e0 = np.tile(ref["correct"], k), np.tile(ref["error_m"], k)
        d = 100.0 * (c0.astype(float) - r["correct"].astype(float))
        boot = rng.integers(0, len(d), (BOOTSTRAP, len(d)))
        ratios = r["error_m"][boot].mean(1) / e0[boot].mean(1)
        out.append({"room": name, "reading": reading, "condition": cond, "magnitude": mag, "reference": ref_name,
                    "people": len(d), "posture_drop": float(d.mean()), "posture_drop_se": float(d.std(ddof=1) / np.sqrt(len(d))),
                    "error_ratio": float(r["error_m"].mean() / e0.mean()),
                    "error_ratio_lo": float(np.percentile(ratios, 2.5)), "error_ratio_hi": float(np.percentile(ratios, 97.5))})
    return out


def conditions(room: Room, people: dict | None, magnitudes: list[float], bounce_tail: float = 1.0,
               photograph_bounce: bool = False):
    """(condition, magnitude, test people, variation) for every row of one room model;
    ``photograph_bounce``: the camera photographs (``camera``, the clothing rows, ``all``) hold the
    person's light over every later bounce too (``bounce_nlos`` x ``bounce_tail``), as a camera's do."""
    from nlos_spotlight.render.variation import CAPTURE_EFFECTS, preset
    from nlos_spotlight.train.imaging import form_parts

    tripod, ideal = preset("tripod"), preset("ideal")
    yield "fit-photographs", 0.0, room.test, None
    yield "ideal", 0.0, room.test, ideal
    for effect in CAPTURE_EFFECTS:
        for m in magnitudes:
            yield effect, m, room.test, tripod.only(effect).scaled(m)
    yield "capture-all", 1.0, room.test, tripod.capture_effects
    if people is None:
        return
    t = room.test
    albedo = t.albedo.numpy()[:, None, None, :]
    c = people  # the camera photographs' parts (``camera_photographs``) and the 2 x 2 renders (``camera_people``)
    later = bounce_tail * c["bounce_nlos"] if photograph_bounce else 0.0  # scales with the clothing, as nlos does
    stopped = c["cam_nlos_shadow"] + (c["shadow_tail"] if photograph_bounce and "shadow_tail" in c else 0.0)
    cam = lambda a: with_person_light(t, room.spot, (c["cam_nlos"] + later) * (a / albedo) + stopped,
                                      c["cam_nlos_ambient"] * ((1 - a) / (1 - albedo)))
    yield "pixel-integrated", 1.0, with_person_light(t, room.spot, c["cam_nlos"], c["cam_nlos_ambient"]), ideal
    yield "pixel-integrated-2x2", 1.0, with_person_light(t, room.spot, c["fine_nlos"], c["fine_nlos_ambient"]), ideal
    scattered = dataclasses.replace(t, shadow=None, bounce=None)  # the fit's own light of the body alone
    lit, amb, _ = form_parts(scattered, torch.arange(t.num_samples), spot_vector(room, t), "spot")
    own_bounce = t.bounce.double().numpy() if t.bounce is not None else 0.0  # a bounce model's own, in its rows
    body = lit.double().numpy()  # the body's scattered light alone (the footprint gain's reference)
    lit = lit.double() + torch.as_tensor(own_bounce, dtype=torch.float64)
    if "offset_nlos" in c:  # the fit's own footprint and shadow, only the pixels' slot offsets drawn apart
        stored_shadow = t.shadow.double().numpy() if t.shadow is not None else 0.0
        yield "footprint-offsets", 1.0, with_person_light(t, room.spot, c["offset_nlos"] + stored_shadow + own_bounce,
                                                          amb.double().numpy()), ideal
    if "relay_shadow" in c:  # the fit's own light, the shadow's relay points drawn apart
        yield "relay-offsets", 1.0, with_person_light(t, room.spot, lit.double().numpy() + c["relay_shadow"],
                                                      amb.double().numpy()), ideal
        if t.shadow is not None:  # two draws of the shadow averaged: what its Monte Carlo noise costs
            half = 0.5 * (t.shadow.double().numpy() + c["relay_shadow"])
            yield "relay-averaged", 1.0, with_person_light(t, room.spot, lit.double().numpy() + half,
                                                           amb.double().numpy()), ideal
            half = 0.5 * (c["cam_nlos_shadow"] + c["relay_shadow"])
            yield "shadow-averaged", 1.0, with_person_light(t, room.spot, lit.double().numpy() + half,
                                                            amb.double().numpy()), ideal
    yield "shadow", 1.0, with_person_light(t, room.spot, lit.double().numpy() + c["cam_nlos_shadow"],
                                           amb.double().numpy()), ideal
    yield "camera", 1.0, cam(albedo), ideal
    if "f32_nlos" in c:  # the camera photographs with the person's light twice as converged
        yield "camera-f32", 1.0, with_person_light(t, room.spot, c["f32_nlos"] + c["cam_nlos_shadow"],
                                                   c["f32_nlos_ambient"]), ideal
    if "offset_nlos" in c:  # is the gap the fit's footprint pattern? the same photographs at the fit's footprint
        yield "camera-fit-footprint", 1.0, with_person_light(t, room.spot, c["offset_nlos"] + c["cam_nlos_shadow"],
                                                             c["cam_nlos_ambient"]), ideal
        g = footprint_gain(body, c["cam_nlos"])
        yield "camera-gain-corrected", 1.0, with_person_light(t, room.spot, c["cam_nlos"] / g + c["cam_nlos_shadow"],
                                                              c["cam_nlos_ambient"]), ideal
    for name, a in CLOTHING.items():
        yield name, 1.0, cam(np.full_like(albedo, a)), ideal
    if "bounce_nlos" in c:  # the camera photographs with the person's light over one more bounce, and
        for k in sorted({1.0, bounce_tail}):  # scaled to every later bounce as Mitsuba measures them
            yield "bounce", k, with_person_light(t, room.spot, c["cam_nlos"] + k * c["bounce_nlos"] + c["cam_nlos_shadow"],
                                                 c["cam_nlos_ambient"]), ideal
    if "shadow_tail" in c:  # the camera photographs (with the bounce's tail under --photograph-bounce) with the
        # light the body stops past its first relay: beside ``bounce`` x tail, what the shadow's tail costs
        yield "shadow-tail", 1.0, with_person_light(t, room.spot, c["cam_nlos"] + later + c["cam_nlos_shadow"]
                                                    + c["shadow_tail"], c["cam_nlos_ambient"]), ideal
    yield "all", 1.0, cam(albedo), tripod.capture_effects
    if "mitsuba_presence" in c:  # the first people only: ours beside Mitsuba's on the same people
        n = len(c["mitsuba_presence"])
        few, pick = t.subset(torch.arange(n)), lambda a: a[:n]
        ours = pick(c["cam_nlos"] + later + stopped)  # every bounce we render, as the camera rows
        yield "camera-mitsuba-people", 1.0, with_person_light(few, room.spot, ours, pick(c["cam_nlos_ambient"])), ideal
        noisy = ours + mc_noise_like(ours, c["mitsuba_noise"], np.random.default_rng(MITSUBA_NOISE_SEED))
        yield "camera-mitsuba-noise", 1.0, with_person_light(few, room.spot, noisy, pick(c["cam_nlos_ambient"])), ideal
        yield "mitsuba", 1.0, with_person_light(few, room.spot, c["mitsuba_presence"], pick(c["cam_nlos_ambient"])), ideal


MITSUBA_NOISE_SEED = 35


def mc_noise_like(images: np.ndarray, relative: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(N, H, W, 3) zero-mean noise whose relative L2 to each of ``images`` is ``relative`` (N,), its
    variance in each pixel proportional to the pixel's magnitude: a particle tracer's noise, whose
    paths land where the light is (a proxy: the two halves' difference is not stored)."""
    z = rng.standard_normal(images.shape) * np.sqrt(np.abs(images))
    scale = np.asarray(relative) * np.linalg.norm(images.reshape(len(images), -1), axis=1) / np.maximum(
        np.linalg.norm(z.reshape(len(z), -1), axis=1), 1e-300)
    return z * scale[:, None, None, None]


def drifted_captures(room: Room, multiple: float, per: int, gen: torch.Generator):
    """``per`` held-out people photographed under every capture effect at ``multiple`` x ``tripod``,
    in batches: (photographs, the drift truly drawn between each capture and its empty-room burst
    (B, 7) in ``models.nuisance.DIRECTIONS`` order)."""
    from nlos_spotlight.render.variation import draw_captures, preset
    from nlos_spotlight.train.imaging import drifted_images, photographs

    L, t = room.test.layers, room.test
    burst, y = room.sensor.burst_frames, spot_vector(room, t)
    v = preset("tripod").capture_effects.scaled(multiple)
    for a in range(0, per, t.num_samples):
        idx = torch.arange(min(t.num_samples, per - a))
        d = lambda: draw_captures(v, len(idx), burst, L.f_px, L.depth_m, gen)
        p, e = d(), d()
        images, empty, free = drifted_images(t, idx, y, None, v, burst, gen, draws=(p, e))
        ph = photographs(images, empty, room.sensor, gen, True, True, metered=free)
        yield ph, torch.stack([p.projector * p.exposure / (e.projector * e.exposure) - 1,
                               p.ambient * p.exposure / (e.ambient * e.exposure) - 1,
                               p.shift[:, 0] - e.shift[:, 0], p.shift[:, 1] - e.shift[:, 1], p.roll - e.roll,
                               p.aim[:, 0] - e.aim[:, 0], p.aim[:, 1] - e.aim[:, 1]], 1).double().numpy()


def flag_rates(room: Room, multiples: list[float], per: int, seed: int = 0) -> list[dict]:
    """How often ``nlos predict``'s drift flag (``apps.drift``) is right: held-out people photographed
    under every capture effect at each multiple of ``tripod`` (:func:`drifted_captures`); a capture
    is truly beyond tolerance when the drawn difference of its two captures exceeds the flag's
    threshold along some direction. Per multiple: captures truly beyond and within, the share of
    each that is flagged."""
    from nlos_spotlight.apps.drift import Drift, tolerance
    from nlos_spotlight.models.nuisance import DIRECTIONS

    net = room.models.net
    if getattr(net, "nuisance", None) is None or per < 1:  # no projection, or no check asked for
        return []
    L = room.test.layers
    tol = tolerance(room.models.config.variation, room.sensor.burst_frames, L.f_px, L.depth_m)
    gen = torch.Generator().manual_seed(30_000 + seed)
    rows = []
    for m in multiples:
        truth, est, se = [], [], []
        for ph, drawn in drifted_captures(room, m, per, gen):
            with torch.no_grad():
                c, e_ = net.nuisance.drift(ph.images - ph.background, ph.background, ph.clipped)
            est.append(c.double().numpy())
            se.append(e_.double().numpy())
            truth.append(drawn)
        beyond = Drift(np.concatenate(truth), tol).flagged
        judged = Drift(np.concatenate(est), tol, np.concatenate(se))
        flagged = judged.flagged
        rows.append({"room": room.name, "reading": room.reading, "magnitude": m, "captures": len(beyond),
                     "beyond": int(beyond.sum()), "flagged_beyond": float(flagged[beyond].mean()) if beyond.any() else "",
                     "flagged_within": float(flagged[~beyond].mean()) if (~beyond).any() else "",
                     **{f"measurable_{d}": float(judged.measurable[:, k].mean()) for k, d in enumerate(DIRECTIONS)}})
        print(f"{room.name:10s} {room.reading:8s} flags at x{m:g} tripod: {int(beyond.sum())} of {len(beyond)} beyond, "
              f"flagged {rows[-1]['flagged_beyond']} of those, {rows[-1]['flagged_within']} of the rest", flush=True)
    return rows


def person_light_removed(room: Room) -> dict:
    """Share of the held-out people's light (weighted as the projection weighs it, noise-free) that
    projecting out each direction alone, and all seven, removes: what the reading gives up."""
    from nlos_spotlight.models.nuisance import DIRECTIONS, noise_weights, nuisance_basis, project_out, room_prior
    from nlos_spotlight.train.imaging import form_parts

    t, L = room.test, room.test.layers
    lit, amb, _ = form_parts(t, torch.arange(t.num_samples), spot_vector(room, t), "spot")
    person = (lit + amb).double()
    b = sum(L.nominal()).double()[None].expand_as(person)
    frac, rel = room_prior(L)
    m, w = nuisance_basis(b, frac.double(), rel.double()), noise_weights(b, None)
    energy = lambda x: float((w * x ** 2).sum())
    out = {d: 1 - energy(project_out(person, m[:, k:k + 1], w)[0]) / energy(person) for k, d in enumerate(DIRECTIONS)}
    out["all"] = 1 - energy(project_out(person, m, w)[0]) / energy(person)
    out["person_over_room"] = float(person.abs().mean() / b.abs().mean())
    return out


def sensor_noise(room: Room, seed: int = 0) -> list[float]:
    """Per held-out person: the sensor's noise in the photograph minus the empty-room photograph
    (half the difference of two noise draws, times sqrt 2) over the noise-free difference, relative L2."""
    from nlos_spotlight.render.variation import preset
    from nlos_spotlight.train.imaging import capture

    t, y = room.test, spot_vector(room, room.test)
    idx = torch.arange(t.num_samples)
    diff = lambda s, noisy: (lambda ph: (ph.images - ph.background).double())(capture(
        t, idx, y, "spot", room.sensor, torch.Generator().manual_seed(s), noisy, room.models.config.net,
        variation=preset("ideal")))
    a, b, clean = diff(seed + 1, True), diff(seed + 2, True), diff(seed + 3, False)
    return [float((a[i] - b[i]).norm() / np.sqrt(2) / clean[i].norm()) for i in range(len(idx))]


def reproduction_gap(room: Room, people: dict) -> float:
    """Relative L2 of the stored people's light against the same settings rendered again (the
    re-rendered people are the dataset's)."""
    from nlos_spotlight.train.imaging import form_parts

    n = len(people["fit_nlos"])
    t = dataclasses.replace(room.test, shadow=None, bounce=None)
    lit, _, _ = form_parts(t, torch.arange(n), spot_vector(room, t), "spot")
    a = lit.double().numpy()
    return float(np.linalg.norm(a - people["fit_nlos"]) / np.linalg.norm(people["fit_nlos"]))


def table(csv_path: Path) -> str:
    """Markdown: per room and reading, six-way posture / error of every condition at 1x (and the
    capture effects at 2x), then the goals' verdicts (issue 35) per reading."""
    rows = list(csv.DictReader(Path(csv_path).open()))
    key = lambda r: (r["room"], r["reading"])
    ideal = {key(r): r for r in rows if r["condition"] == "ideal"}  # the converged room, no drift
    conds = []
    for r in rows:
        c = (r["condition"], float(r["magnitude"]))
        if c not in conds and c[1] in (1.0, 2.0):
            conds.append(c)
    models = list(ideal)
    lines = ["| condition | " + " | ".join(f"{room} {reading}" for room, reading in models) + " |",
             "|---|" + "---|" * len(models)]
    cell = lambda r: f"{float(r['posture_accuracy']):.0f}% / {float(r['error_cm']):.1f}"
    got = {(key(r), r["condition"], float(r["magnitude"])): r for r in rows}
    for c, m in [("fit-photographs", 0.0), ("ideal", 0.0), ("world-scan", 0.0)] + conds:
        lines.append(f"| {c}{'' if m == 0 else f' x{m:g}'} | "
                     + " | ".join(cell(got[(k, c, m)]) if (k, c, m) in got else "" for k in models) + " |")
    lines += ["", "Six-way posture / error (cm) on the held-out people; the goals (points and error ratio "
              "against the same model's ideal):", ""]
    goals = [("every capture effect together at 1x tripod: within 5 points, 1.3x", lambda c, m: c == "capture-all",
              5, 1.3),
             ("all, camera photographs included, at 1x tripod: within 5 points, 1.3x", lambda c, m: c == "all", 5, 1.3),
             ("each capture effect at 2x: within 10 points, 1.5x",
              lambda c, m: c not in CAMERA_CONDITIONS + WORLD_EFFECTS and m == 2.0, 10, 1.5),
             ("camera photographs (the light integrated over each pixel, with the body's shadow): within 3 "
              "points, 1.1x", lambda c, m: c == "camera", 3, 1.1),
             ("clothing 0.05 / 0.9: within 10 points", lambda c, m: c.startswith("clothing"), 10, float("inf"))]
    world = {key(r): r for r in rows if r["condition"] == "world-scan"}
    goals = [(n, p, pts, ratio, ideal) for n, p, pts, ratio in goals] + [
        ("each scan-versus-world effect at 2x: within 10 points, 1.5x of world-scan",
         lambda c, m: c in WORLD_EFFECTS and m == 2.0, 10, 1.5, world),
        ("each scan-versus-world effect at 1x: within 5 points, 1.3x of world-scan",
         lambda c, m: c in WORLD_EFFECTS and m == 1.0, 5, 1.3, world)]
    pf = Path(csv_path).with_name(Path(csv_path).stem + "-paired.csv")
    pair = {(r["room"], r["reading"], r["condition"], float(r["magnitude"])): r
            for r in (csv.DictReader(pf.open()) if pf.exists() else [])}
    for name, pick, pts, ratio, bases in goals:
        for k, base in bases.items():
            sel = [r for r in rows if key(r) == k and pick(r["condition"], float(r["magnitude"]))]
            if not sel:
                continue
            drop = max(float(base["posture_accuracy"]) - float(r["posture_accuracy"]) for r in sel)
            worst = max(float(r["error_cm"]) / float(base["error_cm"]) for r in sel)
            ok = drop <= pts and worst <= ratio
            line = f"- {name}: {k[0]} {k[1]}: worst {drop:+.1f} points, {worst:.2f}x: {'met' if ok else 'not met'}"
            worst_row = max(sel, key=lambda r: float(base["posture_accuracy"]) - float(r["posture_accuracy"]))
            p = pair.get((*k, worst_row["condition"], float(worst_row["magnitude"])))
            if p is not None:  # what 100 people resolve: the paired drop's standard error
                d, se = float(p["posture_drop"]), float(p["posture_drop_se"])
                unresolved = abs(d - pts) < 2 * se or float(p["error_ratio_lo"]) <= ratio <= float(p["error_ratio_hi"])
                line += (f" ({worst_row['condition']} x{float(worst_row['magnitude']):g} paired: {d:+.1f} ± {se:.1f} "
                         f"points, error ratio 95% {float(p['error_ratio_lo']):.2f}-"
                         f"{float(p['error_ratio_hi']):.2f}{'; within the noise of the goal' if unresolved else ''})")
            lines.append(line)
    return "\n".join(lines)


def merge(out: Path, parts: list[Path]) -> None:
    """One CSV (and flags CSV) from the per-room runs, in their order."""
    for suffix in ("", "-flags", "-paired"):
        rows, header = [], None
        for p in parts:
            f = p.with_name(p.stem + suffix + ".csv")
            if f.exists():
                r = list(csv.DictReader(f.open()))
                header = header or list(r[0])
                rows += r
        if header:
            with out.with_name(out.stem + suffix + ".csv").open("w", newline="") as f:
                w = csv.DictWriter(f, header)
                w.writeheader()
                w.writerows(rows)


def main(argv=None) -> int:
    if argv is None and len(sys.argv) == 3 and sys.argv[1] == "--table":
        print(table(Path(sys.argv[2])))
        return 0
    if argv is None and len(sys.argv) > 3 and sys.argv[1] == "--merge":
        merge(Path(sys.argv[2]), [Path(p) for p in sys.argv[3:]])
        return 0
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", action="append", required=True, help="ROOM:READING=ROOM_MODEL_DIR (repeat)")
    ap.add_argument("--people", type=int, default=100, help="held-out people per room (default 100)")
    ap.add_argument("--magnitudes", default="0.5,1,2", help="multiples of the tripod preset (default 0.5,1,2)")
    ap.add_argument("--pixel-samples", type=int, default=2, help="sub-samples a pixel side for pixel-integrated "
                                                                  "(2: as the issue measured, 2 x 2 and 4 x 4 read alike)")
    ap.add_argument("--mitsuba", type=int, default=0, help="samples a pixel of the Mitsuba photographs (0: none; "
                                                             "two halves give their noise)")
    ap.add_argument("--mitsuba-people", type=int, default=100, help="held-out people Mitsuba photographs")
    ap.add_argument("--world-magnitudes", default="", help="multiples of tripod for the scan-versus-world effects "
                                                            "(WORLD_EFFECTS; empty: none; each renders the people again)")
    ap.add_argument("--camera-draws", type=int, default=1, help="independent draws averaged in each camera "
                                                                 "photograph (its Monte Carlo noise over sqrt(draws))")
    ap.add_argument("--bounce", action="store_true", help="also the camera photographs with the person's light over "
                    "one more static bounce (nlos_bounce; about 5 s a person)")
    ap.add_argument("--bounce-tail", type=float, default=BOUNCE_TAIL,
                    help="also the bounce photographs with nlos_bounce times this (every later bounce); 1: not")
    ap.add_argument("--photograph-bounce", action="store_true", help="with --bounce, the camera photographs "
                    "(camera, clothing-*, all) hold the bounce at --bounce-tail, as a camera's do")
    ap.add_argument("--shadow-depth", type=int, default=4, help="above 4, also the camera photographs with the light "
                    "the body stops past its first relay, to this max_depth (shadow-tail; with --photograph-bounce in "
                    "every camera photograph; about 3 s a person)")
    ap.add_argument("--camera-grid", action="store_true", help="the camera photographs as before jittering: "
                    "16 x 16 sub-samples at their cells' centres (biased about 3.6%% in the copy room)")
    ap.add_argument("--fine", action="store_true", help="also the camera photographs with the person's light at "
                                                         "32 x 32 (camera-f32: is 16 x 16 converged?)")
    ap.add_argument("--world-draws", type=int, default=1, help="independent worlds per effect and magnitude, "
                                                                "their people pooled in one row (default 1)")
    ap.add_argument("--world-effects", default=",".join(WORLD_EFFECTS), help="which scan-versus-world effects "
                                                                              "(default all: %(default)s)")
    ap.add_argument("--no-render", action="store_true", help="capture effects only (no people rendered again)")
    ap.add_argument("--world-only", action="store_true", help="of the people rendered again, only the world "
                                                               "rows' (capture effects and world rows)")
    ap.add_argument("--cache", default="out/robustness", help="the people rendered again, per room")
    ap.add_argument("--seed", type=int, default=0, help="sensor noise and drift draws")
    ap.add_argument("--noise-draws", type=int, default=1, help="sensor noise and drift draws per person and row, "
                                                                "averaged (the paired standard errors shrink)")
    ap.add_argument("--flag-multiples", default="1,2,3,4,6", help="tripod multiples of the drift-flag check")
    ap.add_argument("--flag-captures", type=int, default=400, help="captures per multiple in the drift-flag check")
    ap.add_argument("--out", required=True, help="CSV to write (a JSON of the run beside it)")
    args = ap.parse_args(argv)
    mags = [float(m) for m in args.magnitudes.split(",")]
    if args.photograph_bounce and not args.bounce:
        raise NlosError("--photograph-bounce: the camera photographs' bounce is rendered with --bounce")
    effects = tuple(e.strip() for e in args.world_effects.split(",") if e.strip())
    if set(effects) - set(WORLD_EFFECTS):
        raise NlosError(f"--world-effects: unknown {', '.join(sorted(set(effects) - set(WORLD_EFFECTS)))} "
                        f"(known: {', '.join(WORLD_EFFECTS)})")
    torch.set_num_threads(max(1, os.cpu_count() or 1))
    rows, notes, flags, pairs = [], {}, [], []
    for spec in args.model:
        try:
            head, path = spec.split("=", 1)
            name, reading = head.split(":", 1)
        except ValueError:
            raise NlosError(f"--model: expected ROOM:READING=DIR, got {spec!r}") from None
        from nlos_spotlight.fit.run import finished_model

        finished_model(path)  # one line when not a finished room model that aims a spot
        room = load_room(name, reading, Path(path), args.people)
        people = None
        if not (args.no_render or args.world_only):
            fine = fine_light(room, Path(args.cache)) if args.fine else {}
            if args.bounce:
                fine.update(bounce_light(room, Path(args.cache)))
            if args.shadow_depth > 4:
                fine.update(shadow_tail_light(room, Path(args.cache), args.shadow_depth))
            people = {**fine, **camera_people(room, Path(args.cache), args.pixel_samples),
                      **camera_photographs(room, Path(args.cache), args.camera_draws, args.camera_grid),
                      **fit_reproduction(room, Path(args.cache))}
            if args.mitsuba > 0:
                people.update(mitsuba_people(room, Path(args.cache), args.mitsuba, args.mitsuba_people))
                notes.setdefault(f"{name}:{reading}", {})["mitsuba_noise_median"] = float(
                    np.median(people["mitsuba_noise"]))
        if people is not None:
            from nlos_spotlight.train.imaging import form_parts

            rel = lambda a, b: float(np.linalg.norm(a - b) / np.linalg.norm(b))
            t = dataclasses.replace(room.test, shadow=None, bounce=None)
            stored = form_parts(t, torch.arange(t.num_samples), spot_vector(room, t))[0].double().numpy()
            notes[f"{name}:{reading}"] = {**notes.get(f"{name}:{reading}", {}),
                "reproduction_gap": reproduction_gap(room, people), "render_s": float(people["seconds"]),
                "pixel_integration_gap": rel(stored, people["cam_nlos"]),
                "pixel_integration_gap_2x2": rel(people["fine_nlos"], people["cam_nlos"]),
                "shadow_over_nlos": rel(people["cam_nlos"] + people["cam_nlos_shadow"], people["cam_nlos"]),
                "camera_draws": args.camera_draws}
            if "bounce_nlos" in people:  # the fifth bounce against the light of the first four
                notes[f"{name}:{reading}"]["bounce_over_nlos"] = rel(people["cam_nlos"] + people["bounce_nlos"],
                                                                     people["cam_nlos"])
                notes[f"{name}:{reading}"]["bounce_sum_over_nlos"] = float(people["bounce_nlos"].sum()
                                                                           / people["cam_nlos"].sum())
            for k in ("cam_noise_nlos", "cam_noise_shadow"):  # Monte Carlo noise left in the camera photographs
                if k in people:
                    notes[f"{name}:{reading}"][f"{k}_median"] = float(np.median(people[k]))
            if room.test.shadow is not None:
                sh = room.test.shadow.double().numpy()
                notes[f"{name}:{reading}"]["stored_shadow_gap"] = rel(sh, people["cam_nlos_shadow"])
            if "offset_nlos" in people:
                notes[f"{name}:{reading}"]["footprint_pattern"] = footprint_pattern(stored, people["cam_nlos"],
                                                                                     people["offset_nlos"])
            if "f32_nlos" in people:  # 16 x 16 against 32 x 32: how converged the camera photographs are
                notes[f"{name}:{reading}"]["camera_vs_f32_mean_light"] = rel(people["cam_nlos"].mean(0),
                                                                             people["f32_nlos"].mean(0))
                notes[f"{name}:{reading}"]["fit_vs_f32_mean_light"] = rel(stored.mean(0), people["f32_nlos"].mean(0))
        notes.setdefault(f"{name}:{reading}", {})["person_light_removed"] = person_light_removed(room)
        notes[f"{name}:{reading}"]["sensor_noise_median"] = float(np.median(sensor_noise(room, args.seed)))
        flags += flag_rates(room, [float(m) for m in args.flag_multiples.split(",")], args.flag_captures, args.seed)
        world_mags = [float(m) for m in args.world_magnitudes.split(",") if m.strip()]
        worlds = world_conditions(room, Path(args.cache), world_mags, args.world_draws, effects) \
            if world_mags and not args.no_render else []
        outcomes = {}
        for cond, mag, test, var in [*conditions(room, people, mags, args.bounce_tail, args.photograph_bounce), *worlds]:
            r = score(room, test, var, args.seed, args.noise_draws)
            outcomes[(cond, mag)] = r
            rows.append({"room": name, "reading": reading, "condition": cond, "magnitude": mag,
                         **{k: r[k] for k in SCORES}, "people": len(r["correct"])})
            print(f"{name:10s} {reading:8s} {cond:17s} x{mag:<4g} six-way {r['posture_accuracy']:5.1f}%  "
                  f"3-way {r['posture3_accuracy']:5.1f}%  error {r['error_cm']:6.1f} cm", flush=True)
        pairs += paired(name, reading, outcomes)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp")
    with tmp.open("w", newline="") as f:
        w = csv.DictWriter(f, COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{r[k]:.2f}" if isinstance(r[k], float) else r[k]) for k in COLUMNS})
    os.replace(tmp, out)
    with out.with_name(out.stem + "-paired.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, PAIRED_COLUMNS)
        w.writeheader()
        w.writerows({k: (f"{v:.3f}" if isinstance(v, float) else v) for k, v in r.items()} for r in pairs)
    if flags:
        flag_csv = out.with_name(out.stem + "-flags.csv")
        with flag_csv.open("w", newline="") as f:
            w = csv.DictWriter(f, list(flags[0]))
            w.writeheader()
            w.writerows({k: (f"{v:.3f}" if isinstance(v, float) else v) for k, v in r.items()} for r in flags)
    from nlos_spotlight.data.generate import versions

    out.with_suffix(".json").write_text(json.dumps({"argv": sys.argv[1:], "people": args.people, "magnitudes": mags,
                                                    "pixel_samples": args.pixel_samples, "seed": args.seed, "noise_draws": args.noise_draws,
                                                    "rooms": notes, "versions": versions()}, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except NlosError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
