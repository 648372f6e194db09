"""Cramer-Rao bound on the hidden person's floor position from one capture.

Everything but the floor position theta = (x, y) is known (room, spot, body, posture, albedo); the
capture is Gaussian with mean mu(theta) (DN) and the sensor's variance v (``noise_variance_dn``,
a burst included), pixels that clip carry nothing. The Fisher information is

    J = sum_p (d mu_p / d theta) (d mu_p / d theta)^T / v_p        (2 x 2)

and any unbiased estimator has E|theta_hat - theta|^2 >= trace(J^-1): ``crb_m`` = sqrt(trace(J^-1)),
the bound on the RMS position error (rotation-invariant, so in any floor frame). The derivative of
the image is taken by central differences through the renderer (the visibility masks included);
the tests check it against autograd through the renderer on a small scene.

Shapes: jacobian (H, W, 3, 2) radiance per meter; images (H, W, 3).
"""

from __future__ import annotations

import numpy as np
import torch

from ..render.person import Person
from ..render.sensor import SensorConfig, auto_exposure, dn_per_radiance, noise_variance_dn
from ..render.transport import Renderer

PERSON = ("nlos", "nlos_ambient")
"""The image terms that depend on the person."""


def person_image(r: Renderer, y: torch.Tensor, person: Person, t: np.ndarray) -> torch.Tensor:
    """(H, W, 3) the person's contribution at floor translation ``t`` (3,)."""
    return r.render(y, person, translation=np.asarray(t, float), components=PERSON).image


def image_jacobian(r: Renderer, y: torch.Tensor, person: Person, t: np.ndarray, h: float = 0.01) -> torch.Tensor:
    """(H, W, 3, 2) d image / d (x, y) by central differences of step ``h`` meters."""
    cols = []
    for axis in (0, 1):
        d = np.zeros(3)
        d[axis] = h
        cols.append((person_image(r, y, person, t + d) - person_image(r, y, person, t - d)) / (2 * h))
    return torch.stack(cols, dim=-1)


def fisher_crb(jac: torch.Tensor, mean_radiance: torch.Tensor, exposure: float, cfg: SensorConfig) -> float:
    """sqrt(trace(J^-1)) in meters for a capture of ``mean_radiance`` at ``exposure`` seconds."""
    k = dn_per_radiance(exposure, cfg)
    mu = mean_radiance.double().clamp(min=0) * k
    g = jac.double().reshape(-1, 2) * k
    w = (mu < cfg.full_scale_dn).reshape(-1).double() / noise_variance_dn(mu, cfg).reshape(-1)
    fisher = (g * w[:, None]).T @ g
    if float(torch.linalg.det(fisher)) <= 0:
        return float("inf")
    return float(torch.sqrt(torch.trace(torch.linalg.inv(fisher))))


def position_crb(r: Renderer, y: torch.Tensor, person: Person, t: np.ndarray, cfg: SensorConfig,
                 h: float = 0.01) -> float:
    """The bound (m) for one person at ``t`` under spot vector ``y``, metered on the person-free frame."""
    static = r.render(y, None, components=("direct", "ambient")).image
    exposure = auto_exposure(static, cfg)
    mean = static + person_image(r, y, person, t)
    return fisher_crb(image_jacobian(r, y, person, t, h), mean, exposure, cfg)
