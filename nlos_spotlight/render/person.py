"""The hidden person as area samples of a posed body mesh.

``Person.from_mesh`` turns the body's surface integral into weighted point samples by one of two
rules (``quadrature``):

* ``"faces"`` (deterministic): every face is cut into k x k congruent sub-triangles, one sample
  at each sub-triangle's centroid with the sub-triangle's area as weight (the composite centroid
  rule: exact for integrands linear over a sub-triangle, error O(h^2) in its size h for smooth
  ones). Every face keeps its own normal and gets at least one sample, so ``n`` only adds
  samples beyond the face count. The extra samples go where the light varies within a face:
  the integrand is smooth on a face except where the body shadows itself or hides itself from
  the walls (an arm beside the torso, a chin over the chest), and those visibility edges are
  what the error is made of (measured: without visibility, one centroid a face is within 0.03%).
  So ``k = max(1, round(sqrt(n a w / sum(a w))))`` with ``a`` the face area and the weight
  ``w = SHADOW_FLOOR + shadow_variation`` (how often the body's own occlusion changes across the
  face, from a few rays per face), which puts the density in proportion to ``w``. Edges crossing
  sub-triangles make the error fall only about as 1/n (not 1/n^2). Measured at the dataset
  settings, worst of six postures against 30,000 samples: 2.8% at one sample a face (1500),
  0.64% at n = 4000 with the density by area alone, 0.37% with the shadow weight
  (``benchmarks/person_convergence.py``, ``docs/body-model.md``). Cost grows with n.
* ``"mc"``: n stratified samples, faces by systematic sampling of the area CDF, points in them
  by the R2 sequence. At n = 192-512 most faces of a 1500-face body get no sample, so the
  sampled normals are a random subset: 2-20% error.

Of the renderer's sampling errors, the spot samples' and the pixel sub-samples' are the same for
every person in a room (systematic: they cancel in the difference between two people), while the
body-sampling error differs from person to person and from posture to posture: it is noise on
exactly the signal a network has to learn, so it must stay well below the difference between
postures (7-40% at one place and facing in the benchmark; 2-4% for the arm postures elsewhere).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..scene.format import TriMesh
from .rays import EPS, RayEngine

PLASTIC = 0.7548776662466927  # 1 / plastic number: the R2 low-discrepancy sequence
QUADRATURES = ("faces", "mc")
"""Body sampling rules of :meth:`Person.from_mesh` (see the module docstring)."""
MAX_SPLIT = 64
"""Largest k of the ``faces`` rule (k x k sub-triangles on one face)."""
SHADOW_FLOOR = 0.1
"""Weight of a face whose self-occlusion does not vary (``shadow_variation`` adds 0-1 to it)."""
SHADOW_DIRECTIONS = 64
"""Directions over the sphere (about half in front of a face) that ``shadow_variation`` probes."""


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
        """Samples of ``mesh`` by ``quadrature`` (one of :data:`QUADRATURES`): n of them for
        ``"mc"``; about n, and at least one a face, for ``"faces"``."""
        if quadrature == "faces":
            face, bary, area = face_quadrature(mesh.face_areas(), n, SHADOW_FLOOR + shadow_variation(mesh))
        elif quadrature == "mc":
            face, bary, area = monte_carlo(mesh.face_areas(), n)
        else:
            raise ValueError(f"person quadrature: unknown {quadrature!r} (known: {', '.join(QUADRATURES)})")
        return cls._at(mesh, face, bary, area, albedo, _watertight(mesh))

    @classmethod
    def sampled(cls, mesh: TriMesh, albedo, sampling) -> "Person":
        """:meth:`from_mesh` at a sampling's body count and rule (``render.settings.ImageSampling``:
        a config's ``render`` block or a ``RenderSettings``), so that neither is left behind."""
        return cls.from_mesh(mesh, albedo, sampling.person_samples, sampling.person_quadrature)

    @classmethod
    def _at(cls, mesh: TriMesh, face, bary, area, albedo, closed: bool) -> "Person":
        pos = np.einsum("ij,ijk->ik", bary, mesh.vertices[mesh.faces[face]])
        alb = np.broadcast_to(np.asarray(albedo, dtype=np.float64), (len(face), 3)).copy()
        # the closed-mesh shortcut skips pairs behind a face's normal: on a mesh wound inward those
        # are the outside ones, so its normals are turned outward (the material is two-sided)
        sign = -1.0 if closed and signed_volume(mesh) < 0 else 1.0
        return cls(mesh, pos, sign * mesh.face_normals()[face], area, alb, closed)

    def resampled(self, n: int, offset: float = 0.5) -> "Person":
        """The same body by ``n`` stratified samples (the ``"mc"`` rule, strata shifted by
        ``offset``): a coarser quadrature for a smooth term (``RenderSettings.bounce_body_samples``).
        Consistent, and over offsets unbiased to about 1e-3 (the strata and the points within
        them share the one offset), far under its Monte Carlo noise."""
        albedo = self.albedo[0]
        if not np.allclose(self.albedo, albedo):
            raise ValueError("Person.resampled: the body's albedo varies over its samples")
        face, bary, area = monte_carlo(self.mesh.face_areas(), n, offset)
        return Person._at(self.mesh, face, bary, area, albedo, self.closed)

    def translated_mesh(self, t: np.ndarray) -> TriMesh:
        return TriMesh(self.mesh.vertices + t, self.mesh.faces)

    def __len__(self) -> int:
        return len(self.pos)


def monte_carlo(areas: np.ndarray, n: int, offset: float = 0.5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(face, barycentric, area) of n stratified samples: systematic over the area CDF, R2 points;
    ``offset`` in [0, 1) shifts the strata (another set of points of the same rule)."""
    cdf = np.cumsum(areas) / areas.sum()
    u = (np.arange(n) + offset) / n
    face = np.minimum(np.searchsorted(cdf, u), len(areas) - 1)
    r1 = (offset + np.arange(n) * PLASTIC) % 1.0
    r2 = (offset + np.arange(n) * PLASTIC**2) % 1.0
    s = np.sqrt(r1)
    bary = np.stack([1 - s, s * (1 - r2), s * r2], axis=1)
    return face, bary, np.full(n, areas.sum() / n)


def face_splits(areas: np.ndarray, n: int, weight: np.ndarray | None = None) -> np.ndarray:
    """k per face: k x k sub-triangles, their density in proportion to ``weight``; at least one a face."""
    aw = areas if weight is None else areas * weight
    k = np.rint(np.sqrt(aw * (max(n, 1) / aw.sum())))
    return np.clip(k, 1, MAX_SPLIT).astype(np.int64)


def subtriangle_centroids(k: int) -> np.ndarray:
    """(k^2, 3) barycentric centroids of the k x k congruent sub-triangles of a triangle."""
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    up = i + j <= k - 1  # k (k + 1) / 2 upright sub-triangles
    down = i + j <= k - 2  # k (k - 1) / 2 inverted ones
    uv = np.concatenate([np.stack([i[up] + 1 / 3, j[up] + 1 / 3], 1),
                         np.stack([i[down] + 2 / 3, j[down] + 2 / 3], 1)]) / k
    return np.column_stack([uv, 1 - uv.sum(1)])


def face_quadrature(areas: np.ndarray, n: int, weight: np.ndarray | None = None):
    """(face, barycentric, area) of the composite centroid rule (``face_splits``), in face order."""
    k = face_splits(areas, n, weight)
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


def sphere_directions(m: int) -> np.ndarray:
    """(m, 3) unit vectors evenly spread over the sphere (Fibonacci lattice)."""
    z = 1 - (2 * np.arange(m) + 1) / m
    phi = np.pi * (1 + 5**0.5) * np.arange(m)
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def shadow_variation(mesh: TriMesh, m: int = SHADOW_DIRECTIONS) -> np.ndarray:
    """(F,) in [0, 1]: how much the body's occlusion of itself changes across each face.

    From the four centroids of a face's 2 x 2 sub-triangles, rays go out along the directions in
    front of it; the result is the cosine-weighted fraction of directions in which some but not
    all of the four rays hit the body. 0 where the view from the face is the same all over it.
    """
    normal = mesh.face_normals()
    pts = np.einsum("mj,fjk->fmk", subtriangle_centroids(2), mesh.vertices[mesh.faces])  # (F, 4, 3)
    sphere = sphere_directions(m)
    cos = normal @ sphere.T
    face, d = np.nonzero(cos > 0)
    origins = (pts[face] + EPS * normal[face, None]).reshape(-1, 3)
    dirs = np.repeat(sphere[d], 4, axis=0)
    reach = np.full(len(origins), 2 * np.ptp(mesh.vertices, axis=0).max() + 1.0)
    hit = RayEngine(mesh.vertices, mesh.faces).occluded_rays(origins, dirs, reach).reshape(-1, 4)
    mixed = hit.any(axis=1) & ~hit.all(axis=1)
    w = cos[face, d]
    return np.bincount(face, w * mixed, len(normal)) / np.maximum(np.bincount(face, w, len(normal)), 1e-30)


def signed_volume(mesh: TriMesh) -> float:
    """Volume enclosed by a closed mesh, negative when its faces are wound inward (divergence theorem)."""
    a, b, c = (mesh.vertices[mesh.faces[:, i]] for i in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


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
