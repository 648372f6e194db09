"""A step of ``nlos fit``: the spot light each person's body blocks, under the chosen spot.

A photograph with the person minus one without holds, besides the light the body scatters
(``nlos``), the light it stops on the way to and from the static surfaces that relay the spot
(``nlos_shadow``, ``render/shadow.py``): in the copy room a median 38% of the scattered light, in
the living room more than all of it (benchmarks/robustness.py). It depends on the spot, so it is
rendered once the spot is chosen, for the image samples only, by ``workers`` processes in blocks
of :data:`BLOCK` people (``ROOM_MODEL/shadow/block-NNNNN.npz``, written atomically: a rerun renders
only the missing blocks), with the same pixel footprint as the people's light. Training adds it to
every person's light (``SceneTensors.shadow``); it scales with the projector, not with clothing.
"""

from __future__ import annotations

import json
import multiprocessing as mp
from pathlib import Path

import numpy as np

from ..errors import NlosError
from .config import FitConfig

BLOCK = 100
"""People per shadow file (a worker's unit of work: one renderer precompute per block)."""
RELAY_SETS = 8
"""Sets of relay points a block draws (``shadow_relay='per-person'``): each set's static visibility
is cast once and shared by the block's people that use it (about 1/8 of them)."""
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


def _readable(path: Path, indices: list[int]) -> bool:
    try:
        with np.load(path, allow_pickle=False) as z:
            return z["indices"].tolist() == indices and z["nlos_shadow"].shape[0] == len(indices)
    except Exception:  # a torn block is rendered again
        return False


def _one_thread() -> None:
    import torch

    torch.set_num_threads(1)


def _render_block(out: str, cfg: dict, aim: list, block: int, indices: list[int]) -> int:
    """One block: the people rendered again as the dataset drew them (``SceneBuilder.rerender``),
    their ``nlos_shadow`` under the spot aimed at ``aim``."""
    from ..data.store import atomic_npz, f16_encode
    from ..render.settings import RenderSettings
    from .run import room_builder

    out_p, fc = Path(out), FitConfig(**cfg)
    builder, dcfg = room_builder(out_p, fc)
    settings = RenderSettings(pixel_samples=dcfg.pixel_samples, transport_pixel_samples=dcfg.transport_pixel_samples,
                              pixel_footprint=dcfg.pixel_footprint, spot_samples=dcfg.spot_samples,
                              person_samples=dcfg.person_samples, shadow_samples=fc.shadow_samples, device="cpu")
    img = builder.rerender(indices, settings, np.asarray(aim, np.float64), ("nlos_shadow",),
                           relay_offsets(indices, fc))["nlos_shadow"]
    half, scale = f16_encode(img, True)
    atomic_npz(_path(out_p, block), indices=np.asarray(indices, np.int64), nlos_shadow=half, nlos_shadow_scale=scale)
    return len(indices)


def render_shadows(out: Path, cfg: FitConfig, spot: dict, progress: bool = True) -> None:
    """Render (or finish) every image sample's ``nlos_shadow`` under ``spot`` (``spot.json``'s record)."""
    from concurrent.futures import ProcessPoolExecutor, as_completed

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from ..console import QUIET, console
    from ..data.store import atomic_json, remove_stale_temporaries

    out, d = Path(out), shadow_dir(out)
    meta = {"face": int(spot["face"]), "aim": [float(a) for a in spot["aim"]], "shadow_samples": cfg.shadow_samples,
            "pixel_footprint": cfg.pixel_footprint, "shadow_relay": cfg.shadow_relay}
    stored = {"shadow_relay": "fixed", **json.loads((d / "meta.json").read_text())} if (d / "meta.json").exists() else meta
    if stored != meta:
        for p in d.glob("block-*.npz"):  # another spot or setting: nothing to keep
            p.unlink()
    d.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(d)
    atomic_json(d / "meta.json", meta)
    todo = [(b, idx) for b, idx in _blocks(cfg.transport_people, cfg.samples) if not _readable(_path(out, b), idx)]
    total = cfg.samples - cfg.transport_people
    columns = (TextColumn("shadow"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn())
    with Progress(*columns, console=console, disable=QUIET or not progress) as bar:
        task = bar.add_task("shadow", total=total, completed=total - sum(len(i) for _, i in todo))
        if not todo:
            return
        args = (str(out), cfg.to_dict(), meta["aim"])
        if cfg.workers == 1:  # in this process
            for b, idx in todo:
                bar.advance(task, _render_block(*args, b, idx))
            return
        with ProcessPoolExecutor(max_workers=cfg.workers, mp_context=mp.get_context("spawn"),
                                 initializer=_one_thread) as pool:
            jobs = [pool.submit(_render_block, *args, b, idx) for b, idx in todo]
            for job in as_completed(jobs):
                try:
                    bar.advance(task, job.result())
                except Exception as exc:
                    for j in jobs:
                        j.cancel()
                    raise NlosError(f"{d}: rendering the shadow failed ({type(exc).__name__}: "
                                    f"{str(exc).splitlines()[0] if str(exc) else ''}); rerun with --resume") from None


def load_shadows(out: Path, cfg: FitConfig) -> np.ndarray:
    """(image samples, H, W, 3) float32 ``nlos_shadow``, in sample order (``load_split``'s)."""
    from ..data.store import f16_decode

    parts = []
    for b, idx in _blocks(cfg.transport_people, cfg.samples):
        path = _path(out, b)
        if not _readable(path, idx):
            raise NlosError(f"{path}: missing or damaged shadow block; rerun nlos fit with --resume")
        with np.load(path, allow_pickle=False) as z:
            parts.append(f16_decode(z, "nlos_shadow"))
    return np.concatenate(parts)


__all__ = ["BLOCK", "load_shadows", "render_shadows", "shadow_dir"]
