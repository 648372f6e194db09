"""Ray casting through Embree (embreex): first hits and shadow rays.

All visibility in the renderer comes from here; there is no Python-level BVH
or per-ray loop. Embree works in float32, so shadow-ray end points are pulled
in by a relative epsilon and origins are pushed off their surface.
"""

from __future__ import annotations

import os
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

EPS = 1e-4
"""Offset (m) of shadow-ray origins and ends from their surfaces."""
CHUNK = 1 << 22
"""Rays per Embree call; bounds temporary memory."""
PARALLEL_MIN = 1 << 16
"""Below this many rays a batch runs on the calling thread."""
_POOL = None


def _workers() -> int:
    """Threads for one batch of rays: the process's torch thread budget (a fit worker told to use
    one thread keeps to one; two processes of two threads each on two cores fought), at most 8."""
    torch = sys.modules.get("torch")  # not imported here: rays serve torch-free callers too
    n = torch.get_num_threads() if torch is not None else (os.cpu_count() or 1)
    return max(1, min(8, n))


def _pool() -> ThreadPoolExecutor:
    global _POOL
    if _POOL is None:
        _POOL = ThreadPoolExecutor(8, thread_name_prefix="embree")  # threads start as batches need them
    return _POOL


@dataclass
class Hits:
    """First-hit records for N rays."""

    hit: np.ndarray
    """(N,) bool, the ray hit a triangle."""
    t: np.ndarray
    """(N,) float64 distance along the (unit) direction; inf on a miss."""
    face: np.ndarray
    """(N,) int64 triangle index (-1 on a miss)."""
    bary: np.ndarray
    """(N, 3) float64 barycentric weights of the three vertices."""


class RayEngine:
    """An Embree scene over one triangle soup (vertices (V,3), faces (F,3))."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        self.vertices = np.asarray(vertices, dtype=np.float64)
        self.faces = np.asarray(faces, dtype=np.int64)
        self._scene = rtcore_scene.EmbreeScene()
        tris = self.vertices[self.faces].astype(np.float32)
        TriangleMesh(self._scene, tris)  # registers itself in the scene

    def first_hit(self, origins: np.ndarray, directions: np.ndarray) -> Hits:
        """Closest hit along each unit direction."""
        n = len(origins)
        t = np.full(n, np.inf)
        face = np.full(n, -1, dtype=np.int64)
        bary = np.zeros((n, 3))
        for s in range(0, n, CHUNK):
            sl = slice(s, s + CHUNK)
            r = self._scene.run(np.ascontiguousarray(origins[sl], dtype=np.float32),
                                np.ascontiguousarray(directions[sl], dtype=np.float32), output=1)
            prim = r["primID"].astype(np.int64)
            ok = prim >= 0
            face[sl] = prim
            t[sl] = np.where(ok, r["tfar"], np.inf)
            u, v = r["u"].astype(np.float64), r["v"].astype(np.float64)
            bary[sl] = np.where(ok[:, None], np.stack([1 - u - v, u, v], axis=1), 0.0)
        hit = face >= 0
        # Recompute t in float64 from the triangle plane: Embree's float32 t is too coarse for shading.
        if hit.any():
            p = self.surface_point(face[hit], bary[hit])
            t[hit] = np.einsum("ij,ij->i", p - origins[hit], directions[hit])
        return Hits(hit, t, face, bary)

    def surface_point(self, face: np.ndarray, bary: np.ndarray) -> np.ndarray:
        tri = self.vertices[self.faces[face]]
        return np.einsum("ij,ijk->ik", bary, tri)

    def occluded(self, a: np.ndarray, b: np.ndarray, normal_a: np.ndarray | None = None,
                 normal_b: np.ndarray | None = None) -> np.ndarray:
        """(N,) bool: something blocks the open segment a->b.

        Surface points are offset along their normals toward the other end so
        that a segment never hits the triangle it starts or ends on.
        """
        return self.occluded_rays(*segment_rays(a, b, normal_a, normal_b))

    def occluded_rays(self, origins: np.ndarray, dirs: np.ndarray, lengths: np.ndarray) -> np.ndarray:
        """(N,) bool: a triangle lies within ``lengths`` along each unit direction."""
        out = np.zeros(len(origins), dtype=bool)

        def run(sl: slice) -> None:
            r = self._scene.run(np.ascontiguousarray(origins[sl], dtype=np.float32),
                                np.ascontiguousarray(dirs[sl], dtype=np.float32), query="OCCLUDED",
                                dists=np.ascontiguousarray(lengths[sl], dtype=np.float32))
            out[sl] = r >= 0

        step = min(CHUNK, max(PARALLEL_MIN, -(-len(origins) // _workers())))
        slices = [slice(s, s + step) for s in range(0, len(origins), step)]
        if len(slices) == 1:
            run(slices[0])
        else:  # Embree releases the GIL for most of a batch: threads scale on a few cores
            list(_pool().map(run, slices))
        return out


def segment_rays(a: np.ndarray, b: np.ndarray, normal_a: np.ndarray | None = None,
                 normal_b: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(origins, unit directions, lengths) of the open segments a -> b, each end pushed off its
    surface toward the other (:func:`_offset`) and the far end pulled in by :data:`EPS`."""
    a = _offset(a, b, normal_a)
    b = _offset(b, a, normal_b)
    d = b - a
    length = np.linalg.norm(d, axis=1)
    d = d / np.maximum(length, 1e-30)[:, None]
    return a, d, np.maximum(length - EPS, 0.0)


def _offset(p: np.ndarray, toward: np.ndarray, normal: np.ndarray | None) -> np.ndarray:
    d = toward - p
    d = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-30)
    if normal is None:
        return p + EPS * d
    side = np.sign(np.einsum("ij,ij->i", normal, d))[:, None]
    return p + EPS * (side * normal + d)


def pair_rays(pa, na, pb, nb, dir_ab=None, cos_a=None, cos_b=None, need=None):
    """Shadow rays for (a_i, b_j) pairs from torch pair geometry (see ``kernels.pair_geometry``).

    ``need`` (Na, Nb) bool selects the pairs to cast (default all). Without ``dir_ab``, ``cos_a``
    and ``cos_b`` the geometry of the selected pairs is computed here from the points (as
    ``pair_geometry`` does), so that no (Na, Nb, 3) array need exist. Returns float32 numpy
    origins (M, 3), unit directions (M, 3) and lengths (M,), each end pushed off its surface
    toward the other end; built in torch because this runs per person.
    """
    import torch

    with torch.no_grad():
        if need is None:
            need = torch.ones(len(pa), len(pb), dtype=torch.bool, device=pa.device)
        ia, ib = need.nonzero(as_tuple=True)
        if dir_ab is None:
            d = pb[ib] - pa[ia]
            d_ab = d / (d * d).sum(-1).sqrt().unsqueeze(-1)
            sa, sb = torch.sign((d_ab * na[ia]).sum(-1)), torch.sign(-(d_ab * nb[ib]).sum(-1))
        else:
            d_ab, sa, sb = dir_ab[ia, ib], torch.sign(cos_a[ia, ib]), torch.sign(cos_b[ia, ib])
        o = pa[ia] + EPS * (sa.unsqueeze(-1) * na[ia] + d_ab)
        e = pb[ib] + EPS * (sb.unsqueeze(-1) * nb[ib] - d_ab)
        d = (e - o).float()
        length = d.norm(dim=1)
        d = d / length.clamp(min=1e-30).unsqueeze(1)
        return (o.float().cpu().numpy(), d.cpu().numpy(), (length - EPS).clamp(min=0).cpu().numpy())


RAY_BACKENDS = ("auto", "embree", "drjit")
"""Occlusion engines of the renderer's per-person rays: ``embree`` (:class:`RayEngine`, the
reference), ``drjit`` (``rays_drjit.DrJitRays``: Mitsuba 3, CPU or CUDA), ``auto`` (drjit where
Mitsuba runs, else embree). Measured at the fit's settings in the copy room, image samples on one
core: 3.00 people/s (drjit) against 2.06 (embree), the images within 1e-4
(``benchmarks/render_throughput.py``: its .json's ``new`` and ``new-embree``;
``tests/render/test_rays_drjit.py``)."""


def occlusion_engine(static: RayEngine, backend: str = "auto", device: str = "cpu", threads: int | None = None):
    """The engine for occlusion rays against ``static``'s mesh: ``static`` itself or a Dr.Jit copy."""
    if backend not in RAY_BACKENDS:
        raise ValueError(f"rays: expected one of {', '.join(RAY_BACKENDS)}, got {backend!r}")
    if backend == "embree":
        return static
    from . import rays_drjit

    if backend == "auto" and not rays_drjit.available(device):
        return static
    return rays_drjit.DrJitRays(static.vertices, static.faces, device, threads)


@dataclass
class RayTally:
    """What a process's :class:`SceneRays` queries have cost since :meth:`reset`: the renderer's
    per-person shadow rays (``benchmarks/render_throughput.py`` reads it)."""

    rays: int = 0
    """Shadow rays tested."""
    seconds: float = 0.0
    """Wall seconds inside the ray engine."""
    calls: int = 0
    """Queries (each a batch of rays)."""
    keep: list | None = None
    """When a list, each query's (origins, directions, lengths) is appended to it."""

    def reset(self) -> None:
        self.rays, self.seconds, self.calls = 0, 0.0, 0

    def add(self, rays: int, seconds: float) -> None:
        self.rays, self.seconds, self.calls = self.rays + rays, self.seconds + seconds, self.calls + 1


TALLY = RayTally()
"""This process's :class:`RayTally`."""


class SceneRays:
    """Static geometry plus, optionally, a person: visibility through both.

    Shadow rays go through one BVH over the room and the body together, built on first use (a
    few ms for rooms of a few thousand faces): one traversal a ray with an early exit on any hit,
    instead of one pass through each BVH and the gathers between them. Measured at the demo
    settings (143 candidates, 3,850 body samples): a full-transport person 1.09 -> 0.62 s.
    """

    def __init__(self, static: RayEngine, person=None):
        """``person``: the posed body as a mesh (``vertices``, ``faces``), or None."""
        self.static = static
        self.person = person
        self._joined: RayEngine | None = None

    @property
    def joined(self) -> RayEngine:
        if self._joined is None and hasattr(self.static, "with_body"):  # Dr.Jit: the room's BVH instanced
            self._joined = self.static.with_body(self.person)
        if self._joined is None:
            v = np.concatenate([self.static.vertices, np.asarray(self.person.vertices, dtype=np.float64)])
            f = np.concatenate([self.static.faces, np.asarray(self.person.faces, dtype=np.int64)
                                + len(self.static.vertices)])
            self._joined = RayEngine(v, f)
        return self._joined

    def occluded_rays(self, origins: np.ndarray, dirs: np.ndarray, lengths: np.ndarray) -> np.ndarray:
        """(N,) bool for prepared float32 rays (see :func:`pair_rays`)."""
        engine = self.static if self.person is None else self.joined
        t = time.perf_counter()
        out = engine.occluded_rays(origins, dirs, lengths)
        TALLY.add(len(origins), time.perf_counter() - t)
        if TALLY.keep is not None:
            TALLY.keep.append((origins, dirs, lengths))
        return out

    def occluded(self, a, b, normal_a=None, normal_b=None) -> np.ndarray:
        return (self.static if self.person is None else self.joined).occluded(a, b, normal_a, normal_b)
