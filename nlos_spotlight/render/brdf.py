"""Two-sided diffuse + GGX BRDF (DESIGN section 4), differentiable in torch.

f(wi, wo) = kd / pi + ks * D(h) G1(wi) G1(wo) / (4 |cos_i| |cos_o|),
with GGX D (alpha = roughness, not squared), Smith G1, Fresnel = 1, and
f = 0 when wi and wo lie on opposite sides of the surface. This is
Mitsuba 3's ``twosided(roughconductor(material="none", distribution="ggx"))``
plus a Lambertian lobe. The BRDF is symmetric in (wi, wo) (reciprocity).
"""

from __future__ import annotations

import math

import torch

COS_EPS = 1e-7


def ggx_d(cos_h: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
    """GGX normal distribution D(h) = alpha^2 / (pi ((alpha^2 - 1) cos^2 + 1)^2)."""
    a2 = alpha * alpha
    return a2 / (math.pi * ((a2 - 1) * cos_h * cos_h + 1) ** 2)


def smith_g1(cos_v: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
    """Smith masking for GGX: 2 / (1 + sqrt(1 + alpha^2 tan^2 theta_v))."""
    c2 = (cos_v * cos_v).clamp(min=COS_EPS)
    tan2 = (1 - c2).clamp(min=0) / c2
    return 2 / (1 + torch.sqrt(1 + alpha * alpha * tan2))


def brdf(normal: torch.Tensor, wi: torch.Tensor, wo: torch.Tensor, kd: torch.Tensor,
         ks: torch.Tensor | None = None, alpha: torch.Tensor | None = None) -> torch.Tensor:
    """Evaluate f for unit vectors; shapes broadcast: normal/wi/wo (..., 3), kd/ks (..., 3), alpha (...).

    Returns (..., 3). ``ks=None`` skips the glossy lobe (pure Lambertian).
    """
    cos_i = (normal * wi).sum(-1)
    cos_o = (normal * wo).sum(-1)
    same = (cos_i * cos_o > 0).to(kd.dtype)
    f = kd / math.pi
    if ks is not None:
        h = wi + wo
        h = h / h.norm(dim=-1, keepdim=True).clamp(min=1e-12)
        cos_h = ((normal * h).sum(-1)).abs()
        spec = ggx_d(cos_h, alpha) * smith_g1(cos_i, alpha) * smith_g1(cos_o, alpha)
        spec = spec / (4 * cos_i.abs().clamp(min=COS_EPS) * cos_o.abs().clamp(min=COS_EPS))
        f = f + ks * spec.unsqueeze(-1)
    return f * same.unsqueeze(-1)
