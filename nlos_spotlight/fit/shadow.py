"""A step of ``nlos fit``: the spot light each person's body blocks, under the chosen spot.

A photograph with the person minus one without holds, besides the light the body scatters
(``nlos``), the light it stops on the way to and from the static surfaces that relay the spot
(``nlos_shadow``, ``render/shadow.py``): in the copy room a median 38% of the scattered light, in
the living room more than all of it (experiments/camera-photographs/robustness.py). It depends on the spot, so it is
rendered once the spot is chosen, for the image samples only, by ``workers`` processes in blocks
of :data:`BLOCK` people (``ROOM_MODEL/shadow/block-NNNNN.npz``, written atomically: a rerun renders
only the missing blocks), with the same pixel footprint as the people's light. Training adds it to
every person's light (``SceneTensors.shadow``); it scales with the projector, not with clothing.

With ``world_variation`` other than 'ideal' the same step renders each image sample's whole light
under the chosen spot (``nlos``, ``nlos_ambient``, ``nlos_shadow``) in a world that differs from
the scan by a drawn calibration error (``world.mismatch``: camera pose, projector aim, albedo,
scan geometry), one world per relay set of a block (:data:`RELAY_SETS` worlds a block, each built
once), and training reads these instead of the dataset's light: the room model learns what
survives the calibration error, not the scan's exact pixels (experiments/camera-photographs/robustness.py, world rows).
"""

from __future__ import annotations

import json
import multiprocessing as mp
from pathlib import Path

import numpy as np

from ..data.config import SET_BLOCK as BLOCK, SETS_PER_BLOCK as RELAY_SETS
from ..errors import NlosError
from .config import BEFORE, FitConfig, auto_workers

# BLOCK: people per shadow file (a worker's unit of work: one renderer precompute per block).
# RELAY_SETS: sets of relay points a block draws (``shadow_relay='per-person'``): each set's static
# visibility is cast once and shared by the block's people that use it (about 1/8 of them); a
# jittered footprint draws its sub-samples per the same sets (``data.config.sampling_set``).
PHI = 0.6180339887498949
"""Golden-ratio step between blocks' offsets: every block's sets differ from every other's."""


def relay_offsets(indices: list[int], cfg: FitConfig) -> list[float] | None:
    """The strata offset of each sample's relay points (None: the renderer's one fixed set).
    Sample k uses set k mod :data:`RELAY_SETS` of its block, shifted by the block's golden-ratio step."""
    if cfg.shadow_relay == "fixed":
        return None
    return [float((k // BLOCK * PHI + (k % RELAY_SETS) / RELAY_SETS) % 1.0) for k in indices]


def shadow_dir(out: Path) -> Path:
    return Path(out) / "shadow"


def _blocks(first: int, last: int) -> list[tuple[int, list[int]]]:
    """(block number, dataset sample indices) covering image samples ``first`` .. ``last - 1``."""
    starts = range(first, last, BLOCK)
    return [(b, list(range(a, min(a + BLOCK, last)))) for b, a in enumerate(starts)]


def _path(out: Path, block: int) -> Path:
    return shadow_dir(out) / f"block-{block:05d}.npz"


def _readable(path: Path, indices: list[int], comps: tuple[str, ...] = ("nlos_shadow",)) -> bool:
    return _block_depth(path, indices, comps, 0) is not None


def _block_depth(path: Path, indices: list[int], comps: tuple[str, ...], unkeyed: int) -> int | None:
    """The ``shadow_depth`` a block holding ``comps`` of ``indices`` was rendered at (``unkeyed``:
    that of blocks written before blocks recorded it); None if it is missing, torn or another's."""
    try:
        with np.load(path, allow_pickle=False) as z:
            if z["indices"].tolist() != indices or any(z[c].shape[0] != len(indices) for c in comps):
                return None
            return int(z["shadow_depth"]) if "shadow_depth" in z.files else unkeyed
    except Exception:  # a torn block is rendered again
        return None


DEPTH_COMPONENTS = ("nlos_shadow",)
"""What ``shadow_depth`` changes: another depth renders these again and keeps a block's others (the
bounce, a drawn world's light), a quarter of the step's time."""


def _one_thread() -> None:
    """A shadow worker: one torch thread, and it ends with the fit (a killed fit left its pool's
    workers rendering, ownerless, before)."""
    import torch

    from .run import die_with_parent

    die_with_parent()

    torch.set_num_threads(1)


WORLD_COMPONENTS = ("nlos", "nlos_ambient", "nlos_shadow")
"""What a block stores under a world variation: the people's whole light in their drawn worlds."""


def components(cfg: FitConfig) -> tuple[str, ...]:
    """What each block of this fit stores (``nlos_bounce`` too with ``cfg.bounce``)."""
    own = ("nlos_shadow",) if cfg.world_variation == "ideal" else WORLD_COMPONENTS
    return own + (("nlos_bounce",) if cfg.bounce else ())


def _in_worlds(builder, settings, aim: np.ndarray, indices: list[int], offsets: list[float] | None,
               cfg: FitConfig, block: int, comps: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The block's people's ``comps`` in :data:`RELAY_SETS` drawn worlds: those of relay set j (k mod
    :data:`RELAY_SETS`) in world [seed, block, j], so each world's renderer serves its set."""
    from ..render.variation import preset
    from ..world.mismatch import mismatched_world

    v = preset(cfg.world_variation).world_effects
    scan = builder.room_scene()
    out = {c: [None] * len(indices) for c in comps}
    for j in range(RELAY_SETS):
        pos = [i for i, k in enumerate(indices) if k % RELAY_SETS == j]
        if not pos:
            continue
        world, world_aim, _ = mismatched_world(scan, aim, v, [cfg.seed, WORLD_STREAM, block, j])
        got = builder.rerender([indices[i] for i in pos], settings, world_aim, comps,
                               None if offsets is None else [offsets[i] for i in pos], world=world)
        for c in comps:
            for n, i in enumerate(pos):
                out[c][i] = got[c][n]
    return {c: np.stack(imgs) for c, imgs in out.items()}


WORLD_STREAM = 7919
"""Seed stream of the drawn worlds (apart from the people's and the training's)."""


def _render_block(out: str, cfg: dict, aim: list, block: int, indices: list[int], keep: bool = False) -> int:
    """One block: the people rendered again as the dataset drew them (``SceneBuilder.rerender``),
    their ``nlos_shadow`` under the spot aimed at ``aim`` (their whole light in drawn worlds under a
    world variation, :func:`_in_worlds`). ``keep``: the block is whole at another ``shadow_depth``;
    only :data:`DEPTH_COMPONENTS` are rendered again, its other arrays kept as they are."""
    from ..data.store import atomic_npz, f16_encode
    from ..render.settings import RenderSettings, resolve_device
    from .run import room_builder

    out_p, fc = Path(out), FitConfig(**cfg)
    builder, dcfg = room_builder(out_p, fc)
    settings = RenderSettings.of(dcfg.render, fc.shadow, device=resolve_device(fc.render_device))
    aim = np.asarray(aim, np.float64)
    comps = DEPTH_COMPONENTS if keep else components(fc)
    if fc.world_variation == "ideal":
        got = builder.rerender(indices, settings, aim, comps, relay_offsets(indices, fc))
    else:
        got = _in_worlds(builder, settings, aim, indices, relay_offsets(indices, fc), fc, block, comps)
    arrays = {}
    if keep:
        with np.load(_path(out_p, block), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files if k not in ("indices", "shadow_depth")}
    for c, img in got.items():
        arrays[c], arrays[f"{c}_scale"] = f16_encode(img, True)
    atomic_npz(_path(out_p, block), indices=np.asarray(indices, np.int64),
               shadow_depth=np.asarray(fc.shadow.shadow_depth, np.int64), **arrays)
    return len(indices)


def _pool_block(*args) -> tuple[int, float]:
    """:func:`_render_block` in a rendering process of the pool, with that process's own peak memory
    so far (``fit.run.own_peak_mb``)."""
    from .run import own_peak_mb

    return _render_block(*args), own_peak_mb()


BOUNCE_ADDED = {"bounce_near_field": 0.0, "bounce_body_samples": BEFORE["bounce_body_samples"]}
"""The bounce's render settings added since it was first stored, at the value blocks from before
them were rendered with."""


def render_shadows(out: Path, cfg: FitConfig, spot: dict, progress: bool = True) -> None:
    """Render (or finish) every image sample's ``nlos_shadow`` under ``spot`` (``spot.json``'s record)."""
    from concurrent.futures import ProcessPoolExecutor, as_completed

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from ..console import QUIET, console
    from ..data.store import atomic_json, remove_stale_temporaries
    from ..render.bounce import NEAR_FIELD
    from .run import WORKER_PEAKS_MB

    out, d = Path(out), shadow_dir(out)
    sh = cfg.shadow
    meta = {"face": int(spot["face"]), "aim": [float(a) for a in spot["aim"]], "shadow_samples": sh.shadow_samples,
            "pixel_footprint": cfg.render.pixel_footprint, "footprint_jitter": cfg.render.footprint_jitter,
            "bounce": cfg.bounce, "shadow_relay": cfg.shadow_relay, "shadow_depth": sh.shadow_depth,
            "world_variation": cfg.world_variation,
            **({"bounce_near_field": NEAR_FIELD, "bounce_body_samples": sh.bounce_body_samples} if cfg.bounce else {})}
    stored = {"shadow_relay": "fixed", "shadow_depth": 4, "world_variation": "ideal", "footprint_jitter": False, "bounce": False,
              **json.loads((d / "meta.json").read_text())} \
        if (d / "meta.json").exists() else dict(meta)
    for key, before in BOUNCE_ADDED.items():
        if stored.get("bounce") and key not in stored:  # rendered before this setting of the bounce existed
            stored[key] = before
            if (out / "train" / "result.json").exists():  # a trained model keeps the light it was trained on
                meta[key] = before
    # blocks that do not record their depth were rendered at the depth of the meta that came with them
    meta["unkeyed_shadow_depth"] = unkeyed = int(stored.pop("unkeyed_shadow_depth", stored["shadow_depth"]))
    apart = lambda m: {k: v for k, v in m.items() if k not in ("shadow_depth", "unkeyed_shadow_depth")}
    if apart(stored) != apart(meta):
        for p in d.glob("block-*.npz"):  # another spot or setting: nothing to keep (another depth: the rest kept)
            p.unlink()
        meta["unkeyed_shadow_depth"] = unkeyed = sh.shadow_depth
    d.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(d)
    atomic_json(d / "meta.json", meta)
    todo = []  # (block, its samples, whether it keeps its arrays other than DEPTH_COMPONENTS)
    for b, idx in _blocks(cfg.transport_people, cfg.samples):
        depth = _block_depth(_path(out, b), idx, components(cfg), unkeyed)
        if depth != sh.shadow_depth:
            todo.append((b, idx, depth is not None))
    total = cfg.samples - cfg.transport_people
    columns = (TextColumn("shadow"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn())
    with Progress(*columns, console=console, disable=QUIET or not progress) as bar:
        task = bar.add_task("shadow", total=total, completed=total - sum(len(i) for _, i, _ in todo))
        if not todo:
            return
        args = (str(out), cfg.to_dict(), meta["aim"])
        workers = auto_workers(cfg.workers, cfg.render_device)
        if workers == 1:  # in this process
            for b, idx, keep in todo:
                bar.advance(task, _render_block(*args, b, idx, keep))
            return
        with ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                                 initializer=_one_thread) as pool:
            jobs = [pool.submit(_pool_block, *args, b, idx, keep) for b, idx, keep in todo]
            for job in as_completed(jobs):
                try:
                    n, peak = job.result()
                    WORKER_PEAKS_MB.append(peak)
                    bar.advance(task, n)
                except Exception as exc:
                    for j in jobs:
                        j.cancel()
                    raise NlosError(f"{d}: rendering the shadow failed ({type(exc).__name__}: "
                                    f"{str(exc).splitlines()[0] if str(exc) else ''}); rerun with --resume") from None


def load_shadows(out: Path, cfg: FitConfig) -> np.ndarray:
    """(image samples, H, W, 3) float32 ``nlos_shadow``, in sample order (``load_split``'s)."""
    return load_block_light(out, cfg)["nlos_shadow"]


def load_block_light(out: Path, cfg: FitConfig) -> dict[str, np.ndarray]:
    """Component -> (image samples, H, W, 3) float32 of what the step stored (:func:`components`)."""
    from ..data.store import f16_decode

    comps = components(cfg)
    parts = {c: [] for c in comps}
    for b, idx in _blocks(cfg.transport_people, cfg.samples):
        path = _path(out, b)
        if not _readable(path, idx, comps):
            raise NlosError(f"{path}: missing or damaged shadow block; rerun nlos fit with --resume")
        with np.load(path, allow_pickle=False) as z:
            for c in comps:
                parts[c].append(f16_decode(z, c))
    return {c: np.concatenate(v) for c, v in parts.items()}


__all__ = ["BLOCK", "WORLD_COMPONENTS", "load_block_light", "load_shadows", "render_shadows", "shadow_dir"]
