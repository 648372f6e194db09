"""The hidden person as area samples of a posed body mesh.

Two rules turn the body's surface integral into weighted point samples (``Person.from_mesh``):

* ``"faces"`` (deterministic, per face): every face is cut into ``k x k`` congruent sub-triangles
  with ``k = max(1, round(sqrt(a_face n / A)))`` (``A`` the body's area), and each sub-triangle
  contributes one sample at its centroid weighted by its area. Every face is represented with
  its own normal, and each sample stands for about ``A / n`` of the surface (at least one sample
  per face, so ``n`` is a lower bound set by the face count). This is the composite centroid
  (midpoint) rule: exact for integrands linear over a sub-triangle, error O(h^2) in the
  sub-triangle size h for smooth integrands, i.e. O(1/n). The person-light integrand is smooth
  on a body face except for visibility (limbs shadowing the body and hiding it from the walls);
  those boundaries dominate the error, measured to fall about as n^-1.2 between 1500 and 5000
  samples (``benchmarks/person_convergence.py``, ``docs/body-model.md``).
* ``"mc"``: n stratified samples, faces by systematic sampling of the area CDF, points in them
  by the R2 sequence. Most faces of a 1500-face body get no sample at n = 192-512, so the
  sampled normals are a random subset: several % error, about 4x worse than ``"faces"`` at the
  same n.

Of the renderer's sampling errors, the spot samples and the pixel sub-samples are the same for
every person in a room (a systematic error that cancels in differences between people), while
the body-sampling error differs from person to person and from posture to posture: it adds
noise to exactly the signal a network must learn, so it must stay well below the difference
between postures.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..scene.format import TriMesh

PLASTIC = 0.7548776662466927  # 1 / plastic number: the R2 low-discrepancy sequence
QUADRATURES = ("faces", "mc")
"""Body sampling rules of :meth:`Person.from_mesh` (see the module docstring)."""
MAX_SPLIT = 64
"""Largest k of the ``faces`` rule (k x k sub-triangles on one face)."""


@dataclass
class Person:
    """A two-sided Lambertian body sampled by N weighted area samples."""

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
    def from_mesh(cls, mesh: TriMesh, albedo, n: int = 512, quadrature: str = "mc") -> "Person":
        """Samples of ``mesh`` by ``quadrature`` (one of :data:`QUADRATURES`); ``n`` samples for
        ``"mc"``, about ``max(n, faces)`` for ``"faces"``."""
        if quadrature == "faces":
            face, bary, area = face_quadrature(mesh.face_areas(), n)
        elif quadrature == "mc":
            face, bary, area = monte_carlo(mesh.face_areas(), n)
        else:
            raise ValueError(f"person quadrature: unknown {quadrature!r} (known: {', '.join(QUADRATURES)})")
        pos = np.einsum("ij,ijk->ik", bary, mesh.vertices[mesh.faces[face]])
        alb = np.broadcast_to(np.asarray(albedo, dtype=np.float64), (len(face), 3)).copy()
        return cls(mesh, pos, mesh.face_normals()[face], area, alb, _watertight(mesh))

    def translated_mesh(self, t: np.ndarray) -> TriMesh:
        return TriMesh(self.mesh.vertices + t, self.mesh.faces)

    def __len__(self) -> int:
        return len(self.pos)


def monte_carlo(areas: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(face, barycentric, area) of n stratified samples: systematic over the area CDF, R2 points."""
    cdf = np.cumsum(areas) / areas.sum()
    u = (np.arange(n) + 0.5) / n
    face = np.minimum(np.searchsorted(cdf, u), len(areas) - 1)
    r1 = (0.5 + np.arange(n) * PLASTIC) % 1.0
    r2 = (0.5 + np.arange(n) * PLASTIC**2) % 1.0
    s = np.sqrt(r1)
    bary = np.stack([1 - s, s * (1 - r2), s * r2], axis=1)
    return face, bary, np.full(n, areas.sum() / n)


def face_splits(areas: np.ndarray, n: int) -> np.ndarray:
    """k per face: k x k sub-triangles of about ``A / n`` each, at least one per face."""
    k = np.rint(np.sqrt(areas * (max(n, 1) / areas.sum())))
    return np.clip(k, 1, MAX_SPLIT).astype(np.int64)


def subtriangle_centroids(k: int) -> np.ndarray:
    """(k^2, 3) barycentric centroids of the k x k congruent sub-triangles of a triangle."""
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    up = i + j <= k - 1  # k (k + 1) / 2 upright sub-triangles
    down = i + j <= k - 2  # k (k - 1) / 2 inverted ones
    uv = np.concatenate([np.stack([i[up] + 1 / 3, j[up] + 1 / 3], 1),
                         np.stack([i[down] + 2 / 3, j[down] + 2 / 3], 1)]) / k
    return np.column_stack([uv, 1 - uv.sum(1)])


def face_quadrature(areas: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(face, barycentric, area) of the composite centroid rule, samples in face order."""
    k = face_splits(areas, n)
    face, bary = [], []
    for kk in np.unique(k):
        sel = np.flatnonzero(k == kk)
        pts = subtriangle_centroids(int(kk))
        face.append(np.repeat(sel, len(pts)))
        bary.append(np.tile(pts, (len(sel), 1)))
    face, bary = np.concatenate(face), np.concatenate(bary)
    order = np.argsort(face, kind="stable")
    face, bary = face[order], bary[order]
    return face, bary, areas[face] / k[face] ** 2


def _watertight(mesh: TriMesh) -> bool:
    import trimesh

    return bool(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).is_watertight)


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
