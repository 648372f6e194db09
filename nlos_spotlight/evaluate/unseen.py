"""Rooms the networks never saw (issue 12): train on many rooms, validate and score on others.

Training rooms come from one dataset (``benchmarks/configs/unseen-train.yaml``: image samples under
~10 stored spots a room, a few full-transport people for the IEN), test rooms from another
(``unseen-test.yaml``: every person with full transport, so any policy's spot can be scored). The
validation rooms are a third set of rooms (the train dataset's ``val`` split), each under the
policy's spot there, so the best weights are chosen on rooms that are neither trained on nor
reported.

A run is resumable like ``evaluate.seen.run_seen``: ``result.json`` once finished, ``checkpoint.pt``
while it trains.
"""

from __future__ import annotations

import dataclasses
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..data.tensors import SceneTensors
from ..lighting import Illumination, policy_rng
from ..lighting.learned import policy_named
from ..train.config import TrainConfig
from ..train.loop import Trainer, _validation_pass
from .seen import score_rooms


@dataclass
class UnseenResult:
    """Scores of one run on rooms it never saw."""

    posture_accuracy: float
    """Six-way accuracy, %."""
    posture3_accuracy: float
    """Upright / sitting / crouching accuracy, %."""
    error_cm: float
    """Mean localization error, cm."""
    mean_answer_cm: float
    """Error of answering the training people's mean position (region frame), cm: the chance level."""
    confusion: list[list[int]]
    """6 x 6 counts, rows true posture, columns predicted."""
    spots: list[int]
    """Each test room's spot face (-1 for flash or ambient)."""
    train_rooms: int
    """Rooms trained on."""
    steps: int
    """Optimizer steps taken."""
    seconds: float
    """Wall time of training and scoring."""


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
    ckpt = out / "checkpoint.pt"
    if ckpt.exists():
        tr.load(ckpt)
    stop = tr.stopped_early
    while tr.step < tr.total_steps and not stop:
        tr.train_step()
        if tr.validation_due:
            stop = _validation_pass(tr, out)
            tr.save(ckpt)
            if progress:
                print(f"  {out.name}: step {tr.step}/{tr.total_steps} best val {tr.best_val:.3f}", flush=True)
    if (out / "best.pt").exists():
        tr.load(out / "best.pt")
    return tr


def run_unseen(cfg: TrainConfig, train_rooms: list[SceneTensors], val_rooms: list[SceneTensors],
               test_rooms: list[SceneTensors], out: Path, progress: bool = False) -> UnseenResult:
    """Train (or resume) and score on ``test_rooms`` under ``cfg.policy`` there (fixed policies with
    the new-room key; 'ien': the run's IEN). Keeps ``result.json`` and the best weights (``best.pt``)."""
    done = out / "result.json"
    if done.exists():
        return UnseenResult(**json.loads(done.read_text()))
    t0 = time.perf_counter()
    # validation rooms hold image samples: a policy whose spot they store there (the new-room
    # random draw and the IEN's choice are not stored), else the oracle
    val_policy = cfg.policy if cfg.policy in ("oracle", "center", "adaptive") else "oracle"
    tr = train_unseen(cfg, train_rooms, val_rooms, room_lights(val_rooms, val_policy, cfg.seed), out, progress)
    lights = room_lights(test_rooms, cfg.policy, cfg.seed, tr.ien)
    res = score_rooms(tr.net, cfg.net, tr.sensor, test_rooms, as_pairs(test_rooms, lights), cfg.sensor_noise,
                      cfg.seed)
    res.pop("per_person"), res.pop("photos")
    result = UnseenResult(**res, mean_answer_cm=mean_answer(train_rooms, test_rooms), train_rooms=len(train_rooms),
                          steps=tr.step, seconds=time.perf_counter() - t0)
    tmp = done.with_name(".result.json.tmp")
    tmp.write_text(json.dumps(dataclasses.asdict(result), indent=1))
    os.replace(tmp, done)
    (out / "checkpoint.pt").unlink(missing_ok=True)
    return result


def snr_fraction(rooms: list[SceneTensors], lights: list[Illumination], sensor: dict | None = None) -> np.ndarray:
    """Per room the SNR of its spot over the best candidate's (``lighting.snr``, the room's stored people)."""
    from ..lighting.snr import candidate_snr

    out = []
    for s, ill in zip(rooms, lights):
        snr = candidate_snr(s.scene_dir, 0, sensor)
        out.append(snr[ill.face] / snr.max() if ill.mode == "spot" and snr.max() > 0 else 0.0)
    return np.asarray(out)


__all__ = ["UnseenResult", "as_pairs", "mean_answer", "room_lights", "run_unseen", "snr_fraction", "train_unseen"]
