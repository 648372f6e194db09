"""What changed between the empty-room burst and each capture, as ``nlos predict`` reports it.

A room model trained under a capture variation (``nlos fit --capture-preset``) projects the
variation's directions out of every photograph (``models.nuisance``); a second fit of the same
directions beside the training people's light (``NuisanceProjection.drift``) gives the drift it
estimated: projector and room light (relative, the exposure included), camera
shift (output pixels) and roll, the spot's pan and tilt. A capture is flagged when any of them
exceeds :data:`TOLERANCE_SIGMAS` times what two captures differ by under the preset the model was
trained on (``render.variation.difference_sigmas``): a 1-in-300 event there per direction, so
beyond it the network reads a photograph unlike any it was trained on. A direction whose standard
error in this capture (sensor noise and the person's own light make it uncertain) exceeds
:data:`MEASURABLE` of its tolerance cannot be judged from the photograph and does not flag; the
line says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from ..models.nuisance import DIRECTIONS

TOLERANCE_SIGMAS = 3.0
"""A capture is flagged beyond this many sigmas of the trained preset's capture difference."""
MEASURABLE = 0.25
"""A direction flags only where its standard error is below this fraction of its tolerance."""
UNITS = {"projector": ("%", 100.0), "ambient": ("%", 100.0), "shift_x": ("px", 1.0), "shift_y": ("px", 1.0),
         "roll": ("urad", 1e6), "aim_pan": ("mdeg", 1e3 * 180 / math.pi), "aim_tilt": ("mdeg", 1e3 * 180 / math.pi)}
"""How each direction is printed: unit and factor from its coefficient."""


@dataclass
class Drift:
    """Per capture (N): the estimated drift and whether it exceeds what the room model tolerates."""

    coefficients: np.ndarray
    """(N, 7) in ``models.nuisance.DIRECTIONS`` order (relative gains, output pixels, radians)."""
    tolerance: np.ndarray
    """(7,) the flag's thresholds in the same units."""
    errors: np.ndarray | None = None
    """(N, 7) the coefficients' standard errors (None: every direction measurable)."""

    @property
    def measurable(self) -> np.ndarray:
        """(N, 7) bool: the direction's standard error is below :data:`MEASURABLE` of its tolerance."""
        if self.errors is None:
            return np.ones(self.coefficients.shape, bool)
        return self.errors < MEASURABLE * self.tolerance

    @property
    def flagged(self) -> np.ndarray:
        """(N,) bool: some measurable direction beyond its tolerance."""
        return ((np.abs(self.coefficients) > self.tolerance) & self.measurable).any(axis=1)

    def worst(self, i: int) -> str:
        """The direction of capture ``i`` furthest beyond (or nearest to) its tolerance."""
        return DIRECTIONS[int(np.argmax(np.abs(self.coefficients[i]) / self.tolerance))]

    def line(self, i: int) -> str:
        """One line for capture ``i``."""
        c = self.coefficients[i]
        f = lambda k: f"{c[k] * UNITS[DIRECTIONS[k]][1]:+.3g} {UNITS[DIRECTIONS[k]][0]}"
        text = (f"projector {f(0)}, room light {f(1)}, camera shift {f(2)} / {f(3)}, roll {f(4)}, "
                f"spot {f(5)} / {f(6)}")
        blind = [DIRECTIONS[k] for k in np.flatnonzero(~self.measurable[i])]
        if blind:
            text += f" ({', '.join(blind)}: too uncertain in this capture to judge)"
        if not self.flagged[i]:
            return f"drift: {text}: within what the room model tolerates"
        k = DIRECTIONS.index(self.worst(i))
        tol = f"{self.tolerance[k] * UNITS[DIRECTIONS[k]][1]:.3g} {UNITS[DIRECTIONS[k]][0]}"
        return (f"drift: {text}: BEYOND what the room model tolerates ({DIRECTIONS[k]} over {tol}); "
                "retake the empty-room burst and this capture (docs/your-room.md, 'Stability budget')")

    def rows(self) -> list[dict]:
        return [{**{d: float(v) for d, v in zip(DIRECTIONS, c)}, "flagged": bool(f)}
                for c, f in zip(self.coefficients, self.flagged)]


def tolerance(variation_name: str, burst_frames: int, f_px: float, depth_m: float) -> np.ndarray:
    """(7,) :data:`TOLERANCE_SIGMAS` x the capture difference's sigma under the named preset."""
    from ..render.variation import difference_sigmas, preset

    return TOLERANCE_SIGMAS * np.asarray(difference_sigmas(preset(variation_name), burst_frames, f_px, depth_m))


def estimate_drift(net, images: np.ndarray, background: np.ndarray, clipped: np.ndarray | None,
                   tol: np.ndarray, batch_size: int = 256) -> Drift:
    """The drift fit's coefficients (``NuisanceProjection.drift``) for every frame (N, H, W, 3) against
    the empty-room ``background``."""
    proj = net.nuisance
    out = []
    with torch.inference_mode():
        bg = torch.as_tensor(np.ascontiguousarray(background), dtype=torch.float32, device=proj.fraction.device)
        for s in range(0, len(images), batch_size):
            x = torch.as_tensor(np.ascontiguousarray(images[s:s + batch_size]), dtype=torch.float32, device=bg.device)
            c = None if clipped is None else torch.as_tensor(np.ascontiguousarray(clipped[s:s + batch_size]),
                                                            device=bg.device)
            coef, se = proj.drift(x - bg, bg.expand_as(x), c)
            out.append(torch.stack([coef, se]).double().cpu().numpy())
    both = np.concatenate(out, axis=1)
    return Drift(both[0], np.asarray(tol, np.float64), both[1])


__all__ = ["Drift", "MEASURABLE", "TOLERANCE_SIGMAS", "estimate_drift", "tolerance"]
