"""``nlos generate``: deterministic, sharded, resumable dataset generation (docs/dataset-format.md).

Work is split by scene: shard I of N builds the scenes whose index is I mod N, so shards can run on
different machines over copies of (or a shared) output directory and merge by copying the scene
directories together. Every file is written atomically; a scene is finished when its ``done.json``
(content digests of its files) exists, and a rerun skips finished scenes and finished samples, so a
killed run resumes with nothing lost or duplicated. When every scene is done, ``manifest.json``
records the config, seeds, versions and one ``content_sha256`` over all content.
"""

from __future__ import annotations

import functools
import json
import platform
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..errors import NlosError
from ..render.settings import resolve_device
from ..config_file import flatten
from .config import ROOM_FAMILY, DatasetConfig, room_dir, sample_count
from .store import (FORMAT, READABLE, atomic_json, content_sha256, file_digest, read_manifest, remove_stale_temporaries,
                    scene_id)


@dataclass
class ScenePlan:
    """One scene of the dataset."""

    index: int
    """Global scene index (its shard is index mod N)."""
    split: str
    """'train', 'val' or 'test'."""
    seed: int
    """Seed of the room generator."""
    family: str
    """Room layout family."""

    @property
    def id(self) -> str:
        return scene_id(self.split, self.index)


def plan(cfg: DatasetConfig) -> list[ScenePlan]:
    from ..world.rooms import FAMILIES

    if cfg.room:
        return [ScenePlan(i, cfg.split_of(i), int(s), ROOM_FAMILY)
                for i, s in enumerate(np.random.SeedSequence(cfg.seed).generate_state(cfg.num_scenes))]
    fams = cfg.families or list(FAMILIES)
    unknown = [f for f in fams if f not in FAMILIES]
    if unknown:
        raise NlosError(f"config: unknown room family '{unknown[0]}' (choose from {', '.join(FAMILIES)})")
    seeds = np.random.SeedSequence(cfg.seed).generate_state(cfg.num_scenes)
    return [ScenePlan(i, cfg.split_of(i), int(seeds[i]), fams[i % len(fams)]) for i in range(cfg.num_scenes)]


def versions() -> dict[str, str]:
    """The versions of Python and of the packages that decide what is rendered and trained (a copy:
    recorded in every manifest and checkpoint)."""
    return dict(_versions())


@functools.lru_cache(maxsize=1)
def _versions() -> tuple[tuple[str, str], ...]:
    # read once a process: the metadata scan costs ~30 ms, and a fit checkpoints dozens of times
    import importlib.metadata as md

    out = {"python": platform.python_version()}
    for pkg in ("nlos-spotlight", "torch", "numpy", "scipy", "trimesh", "embreex", "fast-simplification", "anny"):
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            pass
    return tuple(out.items())


FORMAT_1_VALUES = {"transport_samples_per_scene": -1, "stored_spots_top": 6, "trajectories_per_train_scene": 0,
                   "room": "", "extra_spots": [], "footprint_jitter": False}
"""Config fields added since nlos-dataset/1, at the values that mean what an older dataset holds (its
config.json lacks them): a run with those values may continue it; other missing fields differ."""


def _check_config(out: Path, cfg: DatasetConfig) -> None:
    path = out / "config.json"
    if path.exists():
        try:
            old = json.loads(path.read_text())
        except json.JSONDecodeError:
            raise NlosError(f"{path}: corrupted (invalid JSON); remove it to start over") from None
        old = flatten(DatasetConfig, old) if isinstance(old, dict) else {}  # written before the render block: flat
        old = {**{k: v for k, v in FORMAT_1_VALUES.items() if k not in old}, **old}
        if old.get("room") and cfg.room and room_dir(out, old["room"]) == room_dir(out, cfg.room):
            old["room"] = cfg.room  # the same room, named from another place
        new = flatten(DatasetConfig, cfg.to_dict())
        if old != new:
            diff = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
            raise NlosError(f"{out} holds a dataset made with another config (differs in: {', '.join(diff)})")
    else:
        atomic_json(path, cfg.to_dict())


GENERATE_THREADS = 1
"""torch intra-op threads while generating. Parallelism comes from shards (one process each): the
per-person tensors are small, and with the cores busy (other shards, other users) two threads per
process made a person 0.2-12 s instead of 0.22 s (measured, 2 cores;
benchmarks/generate_images_speed.py). One thread also makes the bytes independent of core count."""


def generate(cfg: DatasetConfig, out: str | Path, shard: tuple[int, int] = (0, 1), progress: bool = True,
             threads: int = GENERATE_THREADS, part: tuple[int, int] = (0, 1), fuse: bool = False,
             device: str = "cpu") -> dict:
    """Build this shard's scenes; write the manifest if that completes the dataset. Returns the shard record.

    ``threads``: torch threads while it runs (restored afterwards), see :data:`GENERATE_THREADS`.
    ``part``: (i, n), only the image samples of index i mod n within each scene
    (``SceneBuilder.build``: several processes on one room). ``fuse``: the renderer's torch pair
    kernels fused by torch.compile (``render/fused.py``: the same numbers to float rounding), for a
    GPU; on a CPU the compiled pair loops (``render/pair_loops.py``) serve every person and this
    changes nothing. ``device``: 'cpu', 'cuda' or 'auto' (``render.settings.resolve_device``): on a GPU
    the renderer's torch pair kernels and Dr.Jit's OptiX rays (``render/rays_drjit.py``; the same numbers
    to float rounding). Execution choices, not part of the dataset's config, recorded in the shard
    record.
    """
    before = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        return _generate(cfg, out, shard, progress, part, fuse, device)
    finally:
        torch.set_num_threads(before)


def _generate(cfg: DatasetConfig, out: str | Path, shard: tuple[int, int], progress: bool,
              part: tuple[int, int] = (0, 1), fuse: bool = False, device: str = "cpu") -> dict:
    from ..console import QUIET, console

    out = Path(out)
    i, n = shard
    if not (n >= 1 and 0 <= i < n):
        raise NlosError(f"--shard: expected I/N with 0 <= I < N, got {i}/{n}")
    from .config import check_memory, validate

    validate(cfg, "config")  # before anything is written: a refused config leaves nothing behind
    device = resolve_device(device)
    check_memory(cfg, "config")
    if out.exists() and not out.is_dir():
        raise NlosError(f"--out: {out} is a file, not a dataset directory")
    plan(cfg)  # unknown families are refused before anything is written
    if cfg.room:
        from ..scene.io import load_scene

        load_scene(room_dir(out, cfg.room))  # so is a room that is not a readable scene
    out.mkdir(parents=True, exist_ok=True)
    _check_config(out, cfg)
    if part[1] == 1:  # with several parts at work, another's temporary may be in flight
        remove_stale_temporaries(out)
    mine = [p for p in plan(cfg) if p.index % n == i]
    total = sum(sample_count(cfg, p.split) for p in mine)
    t0 = time.perf_counter()
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    columns = (TextColumn("generate"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn())
    with Progress(*columns, console=console, disable=QUIET or not progress) as bar:
        task = bar.add_task("samples", total=total)
        from .scene_builder import SceneBuilder

        for p in mine:
            SceneBuilder(cfg, p, out, fuse, device).build(lambda k=1: bar.advance(task, k), part)
    record = {"shard": f"{i}/{n}", "scenes": [p.id for p in mine], "seconds": time.perf_counter() - t0,
              "versions": versions(), "torch_threads": torch.get_num_threads(), "fused_kernels": fuse,
              "device": device}
    (out / "shards").mkdir(exist_ok=True)
    name = f"{i}-of-{n}" + ("" if part == (0, 1) else f"-part-{part[0]}-of-{part[1]}")
    atomic_json(out / "shards" / f"{name}.json", record)
    finalize(cfg, out)
    return record


def finalize(cfg: DatasetConfig, out: Path) -> dict | None:
    """Write ``manifest.json`` if every scene is done; returns it (or None if scenes are missing)."""
    digests, splits = {}, {"train": [], "val": [], "test": []}
    for p in plan(cfg):
        done = out / "scenes" / p.id / "done.json"
        if not done.exists():
            return None
        try:
            rec = json.loads(done.read_text())
        except json.JSONDecodeError:
            raise NlosError(f"{done}: corrupted (invalid JSON); delete it to rebuild that scene") from None
        digests.update({f"scenes/{p.id}/{k}": v for k, v in rec["digests"].items()})
        splits[p.split].append({"id": p.id, "family": p.family, "seed": p.seed, "samples": rec["samples"],
                                "transport_samples": rec.get("transport_samples", rec["samples"])})
    manifest = {"format": FORMAT, "config": cfg.to_dict(), "seed": cfg.seed, "splits": splits,
                "num_files": len(digests), "content_sha256": content_sha256(digests), "versions": versions()}
    atomic_json(out / "manifest.json", manifest)
    return manifest


def verify(out: Path) -> dict:
    """Recompute every digest and the content hash; raise NlosError on any mismatch or corruption."""
    out = Path(out)
    manifest = read_manifest(out)
    if manifest.get("format") not in READABLE:
        raise NlosError(f"{out}: format {manifest.get('format')!r}, this reader supports {', '.join(READABLE)}")
    digests = {}
    for split in manifest["splits"].values():
        for s in split:
            rec = json.loads((out / "scenes" / s["id"] / "done.json").read_text())
            for rel, dig in rec["digests"].items():
                path = out / "scenes" / s["id"] / rel
                if not path.exists():
                    raise NlosError(f"{path}: missing dataset file")
                if file_digest(path) != dig:
                    raise NlosError(f"{path}: content does not match its digest (corrupted or edited)")
                digests[f"scenes/{s['id']}/{rel}"] = dig
    if content_sha256(digests) != manifest["content_sha256"]:
        raise NlosError(f"{out}: content_sha256 mismatch")
    return manifest
