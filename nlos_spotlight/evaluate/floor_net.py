"""FloorNet as a method of ``nlos evaluate`` (``floor_net``): trained on the evaluation's training
rooms (``train/floor_net.py``, as many steps as the evaluated run) and read in the test rooms under
the spot ours' IEN picks there, with sensor noise drawn as its training draws it.

Layout: ``RUN/methods/floor_net/seed<k>/`` (``floor_net.pt``, ``floor_net.json``); a finished one is
reused.
"""

from __future__ import annotations

from pathlib import Path

import torch
import torch.nn.functional as F

from ..train.checkpoint import TrainedModels
from ..train.floor_net import WEIGHTS, FloorNetTraining, load_floor_net, predict, room_arrays, train_run
from .predictions import Predictions, illumination_for


def ensure_floor_net(run_dir: Path, base, seed: int, data: Path, progress: bool = False) -> Path:
    """The FloorNet run of ``seed`` under the evaluated run, trained if missing."""
    from ..console import console

    path = run_dir / "methods" / "floor_net" / f"seed{seed}"
    if not (path / WEIGHTS).is_file():
        cfg = FloorNetTraining(name="evaluate", rooms=10**6, steps=base.steps, seed=seed,
                               validate_every=max(1, base.steps // 10))
        train_run(cfg, data, path, console.print if progress else None)
    return path


def evaluate_floor_net(path: Path, ours: TrainedModels, scenes: list, ids: list[str], seed: int) -> Predictions:
    """FloorNet's predictions on every sample of ``scenes`` under ours' IEN spot in each (the noise
    of seed ``seed``, the same for every scene order)."""
    run = load_floor_net(path)
    out = Predictions()
    gen = torch.Generator().manual_seed(10_000 + seed)
    for k, (s, sid) in enumerate(zip(scenes, ids)):
        ill = illumination_for(ours, s, k, seed)
        out.spots[sid] = ill
        r = room_arrays(Path(s.scene_dir), [ill.face], "all")
        with torch.no_grad():
            pos, logits, _ = predict(run.net, r, 0, torch.arange(s.num_samples), gen)
        out.add_scene(sid, s, pos.numpy(), F.softmax(logits, dim=1).numpy())
    return out


__all__ = ["ensure_floor_net", "evaluate_floor_net"]
