"""Flash policy (Tancik et al. 2018): a wide beam from the camera lights the whole view.

The flash images are rendered at dataset generation (``data/scene_builder.py``: an emitter at the
camera, beam over the field of view, the projector's total flux); this policy only selects them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import NlosError
from .base import Illumination


def flash_illumination(scene, scene_dir: Path, rng: np.random.Generator) -> Illumination:
    """``Illumination('flash')``; an error when the dataset stores no flash images."""
    if scene.flash_direct is None or scene.flash_nlos is None:
        raise NlosError(f"{scene_dir}: the dataset stores no flash images (regenerate it)")
    return Illumination("flash")
