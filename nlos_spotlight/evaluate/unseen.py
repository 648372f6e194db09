"""Rooms the networks never saw (issue 12): train on many rooms, validate and score on others.

Training rooms come from one dataset (``benchmarks/configs/unseen-train.yaml``: image samples under
~10 stored spots a room, a few full-transport people for the IEN), test rooms from another
(``unseen-test.yaml``: every person with full transport, so any policy's spot can be scored). The
validation rooms are a third set of rooms (the train dataset's ``val`` split), each under the
policy's spot there, so the best weights are chosen on rooms that are neither trained on nor
reported.

Training is resumable (``checkpoint.pt``); ``experiments/unseen-rooms/unseen_rooms.py`` keeps each policy's
scores beside it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch

from ..data.tensors import SceneTensors
from ..lighting import Illumination, policy_rng
from ..lighting.learned import policy_named
from ..train.config import TrainConfig
from ..train.loop import Trainer
from ..train.recipe import resume_validated, train_validated


def room_lights(rooms: list[SceneTensors], policy: str, seed: int, ien=None) -> list[Illumination]:
    """Each room's illumination under ``policy`` (``lighting.learned.policy_named``: a fixed one draws
    with the new-room key ``policy_rng(seed, i, new_room=True)``; 'ien' is ``ien``'s choice)."""
    fn = policy_named(policy, ien)
    return [fn(s, Path(s.scene_dir), policy_rng(seed, i, new_room=True)) for i, s in enumerate(rooms)]


def as_pairs(rooms: list[SceneTensors], lights: list[Illumination]) -> list[tuple]:
    """(spot vector or None, mode) per room, as ``score_rooms`` takes them."""
    return [(ill.spot_vector(len(s.faces)), ill.mode) for s, ill in zip(rooms, lights)]


def mean_answer(train_rooms: list[SceneTensors], test_rooms: list[SceneTensors]) -> float:
    """cm error of answering the mean training position for every test person."""
    mean = torch.cat([r.target for r in train_rooms]).mean(0)
    return float(100 * (torch.cat([r.target for r in test_rooms]) - mean).norm(dim=1).mean())


def train_unseen(cfg: TrainConfig, train_rooms: list[SceneTensors], val_rooms: list[SceneTensors],
                 val_lights: list[Illumination], out: Path, progress: bool = False) -> Trainer:
    """Train ``cfg`` (its ``steps``, validation every ``eval_every``) on ``train_rooms``, validating on
    ``val_rooms`` under ``val_lights``; returns the trainer holding the best validation weights."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.json").write_text(json.dumps({"train": cfg.to_dict(), "train_rooms": len(train_rooms),
                                                 "val_rooms": len(val_rooms)}, indent=1))
    tr = Trainer(cfg, train_rooms, out, val_scenes=val_rooms or None)
    tr.val_lights = val_lights if val_rooms else None
    resume_validated(tr, out)
    train_validated(tr, out, progress)
    return tr


def snr_fraction(rooms: list[SceneTensors], lights: list[Illumination], sensor: dict | None = None) -> np.ndarray:
    """Per room the SNR of its spot over the best candidate's (``lighting.snr``, the room's stored people)."""
    from ..lighting.snr import candidate_snr

    out = []
    for s, ill in zip(rooms, lights):
        snr = candidate_snr(s.scene_dir, 0, sensor)
        out.append(snr[ill.face] / snr.max() if ill.mode == "spot" and snr.max() > 0 else 0.0)
    return np.asarray(out)


__all__ = ["as_pairs", "mean_answer", "room_lights", "snr_fraction", "train_unseen"]
