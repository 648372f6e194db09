"""Oracle policy: exhaustive search over every candidate with the true materials (the upper bound).

It tries every landed spot on the stored, physically rendered transport (which knows every
albedo, gloss and occluder, and the actual people) and keeps the one with the highest mean NLOS
SNR over the scene's static samples (:mod:`.snr`). No deployable method can know this; it bounds
what a spot policy can reach under the sensor model.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import NlosError
from .base import Illumination
from .snr import candidate_snr


def oracle_spot(scene, scene_dir: Path, rng: np.random.Generator) -> Illumination:
    """argmax_t SNR_t over the landed candidates (``rng`` unused; ties go to the lowest index)."""
    values = candidate_snr(scene_dir)
    landed = scene.landed.cpu().numpy().astype(bool)
    if len(values) != len(landed):
        raise NlosError(f"{scene_dir}: {len(values)} stored candidates, the scene tensors have {len(landed)}")
    return Illumination("spot", int(np.argmax(np.where(landed, values, -np.inf))))
