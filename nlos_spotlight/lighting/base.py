"""What the projector does in one scene: a spot on one candidate face, a flash, or nothing.

Shapes: a spot is a face index into the scene's T candidates (the LOS mesh faces the dataset
stores); ``spot_vector`` turns it into the one-hot y (T,) of ``image(y) = D y + A B E y + ...``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import torch

MODES = ("spot", "flash", "ambient")


@dataclass(frozen=True)
class Illumination:
    """One scene's illumination under a policy."""

    mode: str
    """'spot' (projector on ``face``), 'flash' (wide beam from the camera), 'ambient' (projector off)."""
    face: int = -1
    """Candidate face index for mode 'spot', else -1."""

    def spot_vector(self, num_candidates: int, device=None) -> torch.Tensor | None:
        """One-hot y (T,) for a spot, None otherwise."""
        if self.mode != "spot":
            return None
        y = torch.zeros(num_candidates, device=device)
        y[self.face] = 1.0
        return y


PolicyFn = Callable[["object", Path, np.random.Generator], Illumination]
"""(SceneTensors, scene directory, rng) -> Illumination; a fixed policy sees no person."""
