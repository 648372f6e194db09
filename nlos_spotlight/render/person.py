"""The hidden person as area samples of a posed body mesh."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..scene.format import TriMesh

PLASTIC = 0.7548776662466927  # 1 / plastic number: the R2 low-discrepancy sequence


@dataclass
class Person:
    """A two-sided Lambertian body sampled by N stratified area samples."""

    mesh: TriMesh
    """Body mesh at zero translation (occludes rays)."""
    pos: np.ndarray
    """(N, 3) sample positions, m."""
    normal: np.ndarray
    """(N, 3) unit face normals at the samples."""
    area: np.ndarray
    """(N,) area each sample stands for, m^2 (sums to the mesh area)."""
    albedo: np.ndarray
    """(N, 3) Lambertian albedo."""
    closed: bool = False
    """The mesh is watertight: light never leaves its inner side, so those pairs need no rays."""

    @classmethod
    def from_mesh(cls, mesh: TriMesh, albedo, n: int = 512) -> "Person":
        """Stratified samples: faces by systematic sampling of the area CDF, points by the R2 sequence."""
        areas = mesh.face_areas()
        cdf = np.cumsum(areas) / areas.sum()
        u = (np.arange(n) + 0.5) / n
        face = np.minimum(np.searchsorted(cdf, u), len(areas) - 1)
        r1 = (0.5 + np.arange(n) * PLASTIC) % 1.0
        r2 = (0.5 + np.arange(n) * PLASTIC**2) % 1.0
        s = np.sqrt(r1)
        bary = np.stack([1 - s, s * (1 - r2), s * r2], axis=1)
        tri = mesh.vertices[mesh.faces[face]]
        pos = np.einsum("ij,ijk->ik", bary, tri)
        alb = np.broadcast_to(np.asarray(albedo, dtype=np.float64), (n, 3)).copy()
        import trimesh

        closed = bool(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).is_watertight)
        return cls(mesh, pos, mesh.face_normals()[face], np.full(n, areas.sum() / n), alb, closed)

    def translated_mesh(self, t: np.ndarray) -> TriMesh:
        return TriMesh(self.mesh.vertices + t, self.mesh.faces)

    def __len__(self) -> int:
        return len(self.pos)


def as_translation(t, batch: int, device, dtype) -> torch.Tensor:
    """(B, 3) translation from None, (2,), (3,), (B, 2) or (B, 3); 2-vectors move on the floor."""
    if t is None:
        return torch.zeros(batch, 3, device=device, dtype=dtype)
    t = torch.as_tensor(t, device=device, dtype=dtype)
    if t.dim() == 1:
        t = t.unsqueeze(0).expand(batch, -1)
    if t.shape[-1] == 2:
        t = torch.cat([t, torch.zeros_like(t[:, :1])], dim=1)
    if t.shape != (batch, 3):
        raise ValueError(f"translation: expected shape (B, 2|3) with B={batch}, got {tuple(t.shape)}")
    return t
