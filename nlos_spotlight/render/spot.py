"""The projector's spot: angular profile and a deterministic cone quadrature.

Profile (Mitsuba 3 ``spot``): f(theta) = 1 for theta <= beam_width,
(cutoff - theta) / (cutoff - beam_width) up to the cutoff, 0 beyond.

Light leaving the projector is represented by K rays inside the cutoff cone
on a Fibonacci spiral of equal solid-angle cells, each carrying flux
``intensity * f(theta_k) * dOmega`` (W). Where such a ray lands (first hit) is
an LOS sample x_s with E_P(x_s) dA_s = I f dOmega, which is exactly the
measure of DESIGN section 5's integral over S, including projector
visibility and non-planar surfaces.
"""

from __future__ import annotations

import numpy as np
import torch

GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


def spot_profile(theta: torch.Tensor | np.ndarray, beam_width_deg: float, cutoff_deg: float):
    """f(theta) for angles in radians (numpy or torch)."""
    lib = torch if isinstance(theta, torch.Tensor) else np
    b, c = np.radians(beam_width_deg), np.radians(cutoff_deg)
    ramp = (c - theta) / (c - b)
    return lib.where(theta <= b, lib.ones_like(theta) if lib is torch else 1.0, lib.clip(ramp, 0.0, 1.0))


def cone_directions(axis: np.ndarray, cutoff_deg: float, k: int) -> tuple[np.ndarray, np.ndarray, float]:
    """K unit directions (K, 3) around ``axis``, their angles theta (K,) and the solid angle per ray."""
    axis = axis / np.linalg.norm(axis)
    one_minus_cos = 1.0 - np.cos(np.radians(cutoff_deg))
    i = np.arange(k) + 0.5
    cos_t = 1.0 - i / k * one_minus_cos
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t**2))
    phi = np.arange(k) * GOLDEN_ANGLE
    u, v = _basis(axis)
    d = (cos_t[:, None] * axis + sin_t[:, None] * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v))
    return d, np.arccos(np.clip(cos_t, -1, 1)), 2 * np.pi * one_minus_cos / k


def _basis(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.array([1.0, 0.0, 0.0]) if abs(w[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(w, a)
    u /= np.linalg.norm(u)
    return u, np.cross(w, u)
