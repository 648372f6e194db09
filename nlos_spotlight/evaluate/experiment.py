"""``nlos evaluate RUN --data DIR --out REPORT [--seeds N]``: the paper's experiments on held-out scenes.

Trains what is missing (every method of ``methods.METHODS`` at every seed, resumable), runs each on
the test split under sensor noise, and writes Tables 1-3, Figures 5-7, the spot SNR against the
oracle, ``raw.csv`` (every prediction), ``summary.csv`` (every table number per seed),
``report.md``, ``report.html`` and ``evaluation.json`` (config, seeds, versions, timings).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from ..errors import NlosError
from ..train.checkpoint import load_trained
from ..data.tensors import load_scene_tensors, split_ids
from . import decimation as dec
from .methods import BY_NAME, FLOOR_NET, Method, select
from .metrics import per_class
from .predictions import Predictions, evaluate_models, predict_scene
from .runs import ensure_run, run_config, run_path, seeds_of

PAPER = {"accuracy": 96.1, "error_cm": 8.10, "latency_ms": 7.0}
"""The WACV 2024 paper's synthetic results (ours): posture accuracy %, mean error cm, ms per estimate."""


@dataclass
class Evaluation:
    """Everything the report is made from."""

    methods: list[Method]
    seeds: list[int]
    scene_ids: list[str]
    preds: dict[str, dict[int, Predictions]] = field(default_factory=dict)
    """method -> seed -> predictions on the test split (unseen rooms)."""
    seen: dict[str, dict[int, Predictions]] = field(default_factory=dict)
    """method -> seed -> predictions on the held-out samples of the training rooms (seen rooms)."""
    seen_ids: list[str] = field(default_factory=list)
    """Training rooms with held-out samples (empty when the run held none out)."""
    skipped: dict[str, str] = field(default_factory=dict)
    """method -> why it was not run."""
    decimation: dict = field(default_factory=dict)
    """Fig. 7 numbers: ratios, accuracy and error (seeds, ratios), snap distances."""
    snr: dict = field(default_factory=dict)
    """method -> mean over scenes and seeds of (SNR of its spot / oracle SNR)."""
    seconds: dict[str, float] = field(default_factory=dict)
    test_data: Path | None = None
    """Dataset the test scenes come from (the training dataset unless ``--test-data`` named another)."""


def run_all(run_dir: Path, data: Path, seeds: int, names: list[str] | None, progress: bool,
            test_data: Path | None = None) -> Evaluation:
    """Train what is missing on ``data`` and score on the test split of ``test_data`` (default:
    ``data``; another dataset's rooms, e.g. ``benchmarks/configs/unseen-test.yaml``)."""
    from ..console import console

    base = run_config(run_dir)
    tdata = test_data or data
    ids = split_ids(tdata, "test")
    ev = Evaluation(select(names), seeds_of(base, seeds), ids, test_data=tdata)
    scenes = [load_scene_tensors(tdata / "scenes" / sid, base.ien_features) for sid in ids]
    ev.seen_ids, seen = seen_rooms(data, base)
    flash = scenes[0].flash_direct is not None
    for m in ev.methods:
        if m.policy == "flash" and not flash:
            ev.skipped[m.name] = "the dataset stores no flash images"
            console.print(f"[yellow]skip {m.name}: {ev.skipped[m.name]}[/yellow]")
            continue
        ev.preds[m.name] = {}
        if m.arch == FLOOR_NET:
            _floor_net(run_dir, base, ev, m, data, scenes, progress)
            continue
        for seed in ev.seeds:
            t0 = time.perf_counter()
            path = ensure_run(run_dir, base, m, seed, data, progress)
            ev.seconds[f"train {m.name} seed{seed}"] = time.perf_counter() - t0
            models = load_trained(path)
            ev.preds[m.name][seed] = evaluate_models(models, scenes, ids, seed)
            msg = f"{m.name} seed {seed}: unseen rooms {fmt_short(per_class(ev.preds[m.name][seed]))}"
            if seen:
                if models.config.holdout_every != base.holdout_every:
                    raise NlosError(f"{path}: trained with holdout_every {models.config.holdout_every}, the run "
                                    f"with {base.holdout_every}: its seen-room samples differ (retrain it)")
                ev.seen.setdefault(m.name, {})[seed] = evaluate_models(models, seen, ev.seen_ids, seed, seen=True)
                msg += f"; seen rooms {fmt_short(per_class(ev.seen[m.name][seed]))}"
            console.print(msg)
    t0 = time.perf_counter()
    ev.decimation = decimation_study(run_dir, base, ev, scenes)
    ev.seconds["decimation study"] = time.perf_counter() - t0
    ev.snr = spot_snr(ev, tdata)
    return ev


def _floor_net(run_dir: Path, base, ev: Evaluation, m: Method, data: Path, scenes: list, progress: bool) -> None:
    """``m``'s predictions at every seed (``evaluate/floor_net.py``): unseen rooms only, since
    FloorNet trains on every person of the training rooms."""
    from ..console import console
    from .floor_net import ensure_floor_net, evaluate_floor_net

    for seed in ev.seeds:
        t0 = time.perf_counter()
        path = ensure_floor_net(run_dir, base, seed, data, progress)
        ev.seconds[f"train {m.name} seed{seed}"] = time.perf_counter() - t0
        ours = load_trained(run_path(run_dir, base, BY_NAME["ours"], seed))  # its IEN picks the spot
        ev.preds[m.name][seed] = evaluate_floor_net(path, ours, scenes, ev.scene_ids, seed)
        console.print(f"{m.name} seed {seed}: unseen rooms {fmt_short(per_class(ev.preds[m.name][seed]))}")


def seen_rooms(data: Path, base) -> tuple[list[str], list]:
    """Training rooms reduced to the samples the run held out of training (``holdout_every``)."""
    if base.holdout_every <= 0:
        return [], []
    from ..data.tensors import load_split, room_samples

    keep = lambda s: room_samples(s, base.holdout_every, held=True)
    return split_ids(data, "train"), load_split(data, "train", base.ien_features, keep=keep)


def fmt_short(r: dict) -> str:
    return f"accuracy {r['accuracy']['all']:.1f}%, error {r['error_cm']['all']:.1f} cm"


def decimation_study(run_dir: Path, base, ev: Evaluation, scenes) -> dict:
    """Fig. 7: ours at every seed, on every test scene, with the IEN reading decimated dense meshes."""
    acc = np.zeros((len(ev.seeds), len(dec.RATIOS)))
    err = np.zeros_like(acc)
    snaps, verts = [], []
    for i, seed in enumerate(ev.seeds):
        models = load_trained(run_path(run_dir, base, BY_NAME["ours"], seed))
        per_scene = [dec.choices(models, s) for s in scenes]
        for j in range(len(dec.RATIOS)):
            p = Predictions()
            gen = torch.Generator().manual_seed(20_000 + seed)
            for s, sid, ch in zip(scenes, ev.scene_ids, per_scene):
                c = ch[j]
                p.add_scene(sid, s, *predict_scene(models, s, dec.as_illumination(c), gen))
                snaps.append(c.snap_m)
                verts.append(c.vertices)
            r = per_class(p)
            acc[i, j], err[i, j] = r["accuracy"]["all"], r["error_cm"]["all"]
    return {"ratios": list(dec.RATIOS), "accuracy": acc.tolist(), "error_cm": err.tolist(),
            "snap_m_mean": float(np.mean(snaps)), "dense_vertices": int(max(verts))}


def spot_snr(ev: Evaluation, data: Path) -> dict:
    """Per spot method: mean over scenes and seeds of its spot's NLOS SNR divided by the oracle's."""
    from ..lighting.snr import candidate_snr

    table = {sid: candidate_snr(data / "scenes" / sid) for sid in ev.scene_ids}
    out = {}
    for name, by_seed in ev.preds.items():
        ratios = [table[sid][ill.face] / table[sid].max() for p in by_seed.values()
                  for sid, ill in p.spots.items() if ill.mode == "spot"]
        if ratios:
            out[name] = (float(np.mean(ratios)), float(np.std(ratios)))
    return out
