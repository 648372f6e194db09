"""Policies that need no geometry: a random landed spot, and the projector off."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .base import Illumination


def random_spot(scene, scene_dir: Path, rng: np.random.Generator) -> Illumination:
    """A face drawn uniformly among the candidates whose spot lands on a surface."""
    landed = np.flatnonzero(scene.landed.cpu().numpy())
    return Illumination("spot", int(rng.choice(landed)))


def ambient_only(scene, scene_dir: Path, rng: np.random.Generator) -> Illumination:
    """No projector: the person is lit only by the hidden region's ambient light."""
    return Illumination("ambient")
