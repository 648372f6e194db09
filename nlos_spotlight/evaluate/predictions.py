"""Run one trained method on held-out scenes: its spot per scene, its predictions per sample.

Every test image is formed from the stored transport under the method's illumination and goes
through the sensor model (average metering, shot, read and quantization noise, clipping) with a fixed seed, so
all methods see equally noisy photographs and a rerun gives the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from ..lighting import Illumination, policy_rng
from ..lighting.learned import policy_named
from ..render.sensor import SensorConfig
from ..train.checkpoint import TrainedModels
from ..train.imaging import capture
from ..data.tensors import SceneTensors


@dataclass
class Predictions:
    """Per-sample results of one method and seed over the test scenes (N samples)."""

    scene: list[str] = field(default_factory=list)
    """(N,) scene id."""
    sample: list[int] = field(default_factory=list)
    """(N,) sample index within its scene."""
    true_xy: list[np.ndarray] = field(default_factory=list)
    """(N, 2) true floor position, camera ground frame, m."""
    pred_xy: list[np.ndarray] = field(default_factory=list)
    """(N, 2) predicted position, m."""
    true_posture: list[int] = field(default_factory=list)
    """(N,) true posture index."""
    probs: list[np.ndarray] = field(default_factory=list)
    """(N, 6) predicted posture probabilities."""
    trajectory: list[tuple[int, int]] = field(default_factory=list)
    """(N, 2) trajectory id and frame, (-1, -1) for static samples."""
    spots: dict[str, Illumination] = field(default_factory=dict)
    """Scene id -> the illumination used there."""

    def add_scene(self, sid: str, s: SceneTensors, pos: np.ndarray, prob: np.ndarray) -> None:
        """Append every sample of scene ``s``: predicted positions (N, 2) and probabilities (N, 6)."""
        for i in range(s.num_samples):
            self.scene.append(sid)
            self.sample.append(i)
            self.true_xy.append(s.target[i].numpy())
            self.pred_xy.append(pos[i])
            self.true_posture.append(int(s.posture[i]))
            self.probs.append(prob[i])
            self.trajectory.append(tuple(int(v) for v in s.trajectory[i]))

    def arrays(self) -> dict[str, np.ndarray]:
        return {"true_xy": np.array(self.true_xy).reshape(-1, 2), "pred_xy": np.array(self.pred_xy).reshape(-1, 2),
                "true_posture": np.array(self.true_posture, dtype=int),
                "probs": np.array(self.probs).reshape(-1, 6), "trajectory": np.array(self.trajectory).reshape(-1, 2)}


def illumination_for(models: TrainedModels, s: SceneTensors, scene_index: int, seed: int,
                     seen: bool = False) -> Illumination:
    """The method's illumination of scene ``s``. In a training room (``seen``, ``scene_index`` its
    index in the train split) a fixed policy keeps the spot it was trained with (``train.loop``'s
    draw), as a user would; in a new room the Random policy draws afresh."""
    policy = policy_named(models.config.policy, models.ien)
    rng = policy_rng(models.config.seed, scene_index) if seen else policy_rng(seed, scene_index, new_room=True)
    return policy(s, Path(s.scene_dir), rng)


def predict_scene(models: TrainedModels, s: SceneTensors, ill: Illumination, generator: torch.Generator,
                  batch: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) positions and (N, 6) posture probabilities for every sample of ``s`` under ``ill``."""
    h, w = s.ambient.shape[:2]
    sensor = SensorConfig.at((h, w), models.config.sensor)
    y = ill.spot_vector(len(s.faces))
    pos, prob = [], []
    with torch.no_grad():
        for start in range(0, s.num_samples, batch):
            idx = torch.arange(start, min(start + batch, s.num_samples))
            ph = capture(s, idx, y, ill.mode, sensor, generator, True, models.config.net)
            p, logits = models.net(ph.images, ph.background, ph.clipped, ph.geometry)
            pos.append(p.numpy())
            prob.append(F.softmax(logits, dim=1).numpy())
    if not pos:  # a room with no samples (e.g. none held out of it)
        return np.zeros((0, 2)), np.zeros((0, 6))
    return np.concatenate(pos), np.concatenate(prob)


def evaluate_models(models: TrainedModels, scenes: list[SceneTensors], ids: list[str], seed: int,
                    seen: bool = False) -> Predictions:
    """Predictions of one trained method on every sample of ``scenes``: the test rooms, or with
    ``seen`` the held-out samples of the training rooms (in train-split order)."""
    out = Predictions()
    gen = torch.Generator().manual_seed(10_000 + seed + 5_000 * seen)  # the same noise for every method of a seed
    for k, (s, sid) in enumerate(zip(scenes, ids)):
        ill = illumination_for(models, s, k, seed, seen)
        out.spots[sid] = ill
        out.add_scene(sid, s, *predict_scene(models, s, ill, gen))
    return out
