"""Point-to-point transport kernels shared by every bounce of the renderer.

Between point sets a (Na) and b (Nb) with unit normals:
``G(a, b) = |cos_a| |cos_b| / |a - b|^2`` (DESIGN section 5), the unit
direction a -> b, and on which side of each b the point a lies.
Everything is torch and differentiable in the positions.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass
class PairGeometry:
    """Geometry of all (a, b) pairs; leading shape (Na, Nb)."""

    dir_ab: torch.Tensor
    """(Na, Nb, 3) unit vectors from a to b."""
    cos_a: torch.Tensor
    """(Na, Nb) signed n_a . dir_ab."""
    cos_b: torch.Tensor
    """(Na, Nb) signed n_b . dir_ba (positive: a is on b's normal side)."""
    inv_r2: torch.Tensor
    """(Na, Nb) 1 / |a - b|^2."""

    @property
    def g(self) -> torch.Tensor:
        """(Na, Nb) geometry term |cos_a| |cos_b| / r^2."""
        return self.cos_a.abs() * self.cos_b.abs() * self.inv_r2


def pair_geometry(pa: torch.Tensor, na: torch.Tensor, pb: torch.Tensor, nb: torch.Tensor,
                  r2_min: float = 0.0) -> PairGeometry:
    """Pair geometry for positions/normals pa, na (Na, 3) and pb, nb (Nb, 3); ``r2_min`` floors the
    squared distance of ``inv_r2`` (a bounded geometry term: instant radiosity's clamp)."""
    d = pb.unsqueeze(0) - pa.unsqueeze(1)
    r2 = (d * d).sum(-1)
    dn = d / r2.sqrt().unsqueeze(-1)
    cos_a = (dn * na.unsqueeze(1)).sum(-1)
    cos_b = -(dn * nb.unsqueeze(0)).sum(-1)
    return PairGeometry(dn, cos_a, cos_b, 1.0 / (r2.clamp(min=r2_min) if r2_min > 0 else r2))


def form_factor(pa, na, area_a, pb, nb, area_b, visible=None) -> torch.Tensor:
    """Form factor F_ab = 1/(pi A_a) sum_ij G_ij V_ij a_i b_j from area samples."""
    g = pair_geometry(pa, na, pb, nb).g
    if visible is not None:
        g = g * visible
    return (area_a @ g @ area_b) / (torch.pi * area_a.sum())
