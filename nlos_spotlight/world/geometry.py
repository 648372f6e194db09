"""Mesh primitives of the procedural world: subdivided panels, boxes, walls with openings.

Everything returns :class:`~nlos_spotlight.scene.format.TriMesh` in world coordinates (meters,
z up) with optional per-vertex colors (the texture: colors multiply the material's diffuse).
A *texture* here is a callable ``tex(s, t) -> (N, 3)`` of a panel's local coordinates in meters
(``s`` along its first edge, ``t`` along its second) plus the cell size it needs to be resolved;
panels are subdivided to the coarser of the wanted cell and the texture's cell, so that faces stay
few where nothing needs carrying.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Callable

import numpy as np

from ..scene.format import TriMesh

ColorFn = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass
class Texture:
    """Per-vertex color pattern of a panel."""

    fn: ColorFn
    """(s, t) local coordinates in meters, each (N,) -> (N, 3) colors in [0, 1]."""
    ds: float = math.inf
    """Largest cell along s that still carries the pattern, m."""
    dt: float = math.inf
    """Largest cell along t, m."""
    flat: bool = False
    """Cells carry one flat color each (vertices are not shared: sharp edges, e.g. planks, book spines)."""


def _n(length: float, cell: float) -> int:
    return max(1, int(math.ceil(length / cell - 1e-9)))


@lru_cache(maxsize=512)
def _grid(nu: int, nv: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Parameters a, b of the (nu+1) x (nv+1) grid vertices and its triangles (cached, read-only)."""
    a, b = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1), indexing="ij")
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
    v00, v10, v01, v11 = idx[:-1, :-1], idx[1:, :-1], idx[:-1, 1:], idx[1:, 1:]
    faces = np.concatenate([np.stack([v00, v10, v11], -1).reshape(-1, 3),
                            np.stack([v00, v11, v01], -1).reshape(-1, 3)]).astype(np.int64)
    out = (a.ravel(), b.ravel(), faces)
    for x in out:
        x.flags.writeable = False
    return out


def _len(x: np.ndarray) -> float:
    return math.sqrt(float(x @ x))


def panel(origin, u, v, cell: float = math.inf, tex: Texture | None = None, nu: int | None = None,
          nv: int | None = None) -> TriMesh:
    """Planar grid origin + a u + b v, (a, b) in [0, 1]^2, normal along u x v.

    Subdivided into cells no larger than ``cell`` (and the texture's cells); colored by ``tex``.
    """
    o, u, v = (np.asarray(x, dtype=np.float64) for x in (origin, u, v))
    lu, lv = _len(u), _len(v)
    if nu is None:
        nu = _n(lu, min(cell, tex.ds if tex else math.inf))
    if nv is None:
        nv = _n(lv, min(cell, tex.dt if tex else math.inf))
    if tex is not None and tex.flat:
        return _flat_panel(o, u, v, lu, lv, nu, nv, tex)
    a, b, faces = _grid(nu, nv)
    verts = o + a[:, None] * u + b[:, None] * v
    col = None if tex is None else np.clip(tex.fn(a * lu, b * lv), 0.0, 1.0)
    return TriMesh(verts, faces.copy(), col)


def _flat_panel(o, u, v, lu, lv, nu, nv, tex: Texture) -> TriMesh:
    """Cells with their own four vertices, each one color (evaluated at the cell center)."""
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    i, j = i.ravel(), j.ravel()
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)
    a = (i[:, None] + corners[None, :, 0]) / nu  # (C, 4)
    b = (j[:, None] + corners[None, :, 1]) / nv
    verts = (o + a.reshape(-1, 1) * u + b.reshape(-1, 1) * v)
    base = 4 * np.arange(len(i))
    faces = np.concatenate([np.stack([base, base + 1, base + 2], 1), np.stack([base, base + 2, base + 3], 1)])
    col = np.clip(tex.fn((i + 0.5) / nu * lu, (j + 0.5) / nv * lv), 0.0, 1.0)
    return TriMesh(verts, faces.astype(np.int64), np.repeat(col, 4, axis=0))


def merge(meshes: list[TriMesh]) -> TriMesh:
    """Concatenate meshes; missing colors become white when any mesh has colors."""
    meshes = [m for m in meshes if m is not None and len(m.faces)]
    colored = any(m.vertex_colors is not None for m in meshes)
    verts, faces, cols, off = [], [], [], 0
    for m in meshes:
        verts.append(m.vertices)
        faces.append(m.faces + off)
        off += len(m.vertices)
        if colored:
            cols.append(m.vertex_colors if m.vertex_colors is not None else np.ones_like(m.vertices))
    return TriMesh(np.concatenate(verts), np.concatenate(faces), np.concatenate(cols) if colored else None)


_BOX_FACES = ("-x", "+x", "-y", "+y", "-z", "+z")
_BOX_VERTS = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=np.float64)  # corner (x, y, z) bits
_BOX_TRIS = np.array([[0, 1, 3], [0, 3, 2],   # -x (x = 0): y-z plane, normal -x
                      [4, 6, 7], [4, 7, 5],   # +x
                      [0, 4, 5], [0, 5, 1],   # -y
                      [2, 3, 7], [2, 7, 6],   # +y
                      [0, 2, 6], [0, 6, 4],   # -z
                      [1, 5, 7], [1, 7, 3]],  # +z
                     dtype=np.int64)


def box(lo, hi, cell: float = math.inf, tex: Texture | None = None, skip: tuple[str, ...] = (),
        tex_faces: tuple[str, ...] | None = None) -> TriMesh:
    """Axis-aligned box with outward normals, faces named '-x', '+x', '-y', '+y', '-z', '+z'.

    ``skip`` leaves faces out (e.g. the back of a piece against a wall); ``tex`` colors the faces
    in ``tex_faces`` (default all) with s along the face's horizontal edge, t along the other.
    """
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    d = hi - lo
    if tex is None and math.isinf(cell):
        keep = [i for i, name in enumerate(_BOX_FACES) if name not in skip]
        faces = _BOX_TRIS.reshape(6, 2, 3)[keep].reshape(-1, 3)
        return TriMesh(lo + _BOX_VERTS * d, faces.copy())
    x, y, z = np.eye(3) * d
    spec = {  # origin, u, v with u x v outward
        "-x": (lo, z, y), "+x": (lo + x, y, z),
        "-y": (lo, x, z), "+y": (lo + y, z, x),
        "-z": (lo, y, x), "+z": (lo + z, x, y),
    }
    out = []
    for name, (o, u, v) in spec.items():
        if name in skip:
            continue
        t = tex if (tex is not None and (tex_faces is None or name in tex_faces)) else None
        if t is not None and name in ("-x", "+y"):  # keep s horizontal and t vertical on the sides
            m = panel(o, v, u, cell, t)
            m.faces = m.faces[:, ::-1].copy()
        else:
            m = panel(o, u, v, cell, t)
        out.append(m)
    m = merge(out)
    if tex is not None and m.vertex_colors is None:
        m.vertex_colors = np.ones_like(m.vertices)
    return m


def cylinder(base, radius: float, height: float, sides: int = 10, caps: bool = True, radius_top: float | None = None,
             tex: Texture | None = None) -> TriMesh:
    """A vertical prism (or frustum with ``radius_top``) standing on ``base`` (3,)."""
    base = np.asarray(base, dtype=np.float64)
    rt = radius if radius_top is None else radius_top
    ang = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    ring = np.stack([np.cos(ang), np.sin(ang), np.zeros(sides)], 1)
    bottom = base + radius * ring
    top = base + rt * ring + [0, 0, height]
    verts = [bottom, top]
    i = np.arange(sides)
    j = (i + 1) % sides
    faces = [np.stack([i, j, sides + j], 1), np.stack([i, sides + j, sides + i], 1)]
    if caps:
        verts.append(np.stack([base, base + [0, 0, height]]))
        c0, c1 = 2 * sides, 2 * sides + 1
        faces.append(np.stack([np.full(sides, c0), j, i], 1))
        faces.append(np.stack([np.full(sides, c1), sides + i, sides + j], 1))
    v = np.concatenate(verts)
    col = None
    if tex is not None:
        s = np.concatenate([ang * radius, ang * rt] + ([np.zeros(2)] if caps else []))
        col = np.clip(tex.fn(s, v[:, 2] - base[2]), 0, 1)
    return TriMesh(v, np.concatenate(faces).astype(np.int64), col)


def blob(center, radii, subdivisions: int = 1, rng: np.random.Generator | None = None, jitter: float = 0.0) -> TriMesh:
    """An ellipsoid (icosphere) with optional radial jitter: foliage, cushions."""
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions)
    v = np.asarray(s.vertices, dtype=np.float64)
    if rng is not None and jitter > 0:
        v = v * (1 + jitter * rng.uniform(-1, 1, size=(len(v), 1)))
    return TriMesh(v * np.asarray(radii) + np.asarray(center, dtype=np.float64), np.asarray(s.faces, dtype=np.int64))


def transform(mesh: TriMesh, rot: np.ndarray, trans) -> TriMesh:
    """p -> rot p + trans; a reflection (det < 0) reverses the winding to keep normals outward."""
    faces = mesh.faces if np.linalg.det(rot) > 0 else mesh.faces[:, ::-1].copy()
    return TriMesh(mesh.vertices @ rot.T + np.asarray(trans, dtype=np.float64), faces,
                   None if mesh.vertex_colors is None else mesh.vertex_colors.copy())


def rot_z(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def plane_with_holes(origin, u_dir, v_dir, length: float, height: float, holes=(), cell: float = 0.4,
                     tex: Texture | None = None) -> TriMesh:
    """Rectangle origin + s u_dir + t v_dir, s in [0, length], t in [0, height], minus rectangular
    ``holes`` (s0, s1, t0, t1); split on the holes' edges into panels (normal u_dir x v_dir)."""
    o, ud, vd = (np.asarray(x, dtype=np.float64) for x in (origin, u_dir, v_dir))
    ss = sorted({0.0, length, *[min(max(h[k], 0.0), length) for h in holes for k in (0, 1)]})
    ts = sorted({0.0, height, *[min(max(h[k], 0.0), height) for h in holes for k in (2, 3)]})
    out = []
    for s0, s1 in zip(ss[:-1], ss[1:]):
        for t0, t1 in zip(ts[:-1], ts[1:]):
            if s1 - s0 < 1e-6 or t1 - t0 < 1e-6:
                continue
            sc, tc = (s0 + s1) / 2, (t0 + t1) / 2
            if any(h[0] < sc < h[1] and h[2] < tc < h[3] for h in holes):
                continue
            sub = None
            if tex is not None:
                sub = Texture(lambda s, t, s0=s0, t0=t0: tex.fn(s + s0, t + t0), tex.ds, tex.dt, tex.flat)
            out.append(panel(o + s0 * ud + t0 * vd, (s1 - s0) * ud, (t1 - t0) * vd, cell, sub))
    return merge(out)


@dataclass
class WallSpec:
    """A straight wall between floor plan points p0 -> p1 (xy), from z0 to z1."""

    p0: tuple[float, float]
    p1: tuple[float, float]
    z0: float
    z1: float
    thickness: float = 0.0
    """0: one double-sided plane; > 0: a slab centered on the segment, with reveals and caps."""
    openings: tuple = ()
    """(s0, s1, z0, z1) holes, s measured from p0 along the wall."""
    caps: tuple[bool, bool] = (False, False)
    """Close the slab's ends at p0, p1 (free-standing partitions)."""


def wall_mesh(w: WallSpec, cell: float, tex: Texture | None = None) -> TriMesh:
    p0, p1 = np.array([*w.p0, w.z0]), np.array([*w.p1, w.z0])
    d = p1 - p0
    length = float(np.linalg.norm(d))
    ud = d / length
    vd = np.array([0.0, 0.0, 1.0])
    h = w.z1 - w.z0
    holes = [(a, b, c - w.z0, e - w.z0) for a, b, c, e in w.openings]
    if w.thickness <= 0:
        return plane_with_holes(p0, ud, vd, length, h, holes, cell, tex)
    n = np.cross(vd, ud)  # horizontal normal, left of the direction p0 -> p1
    half = 0.5 * w.thickness * n
    parts = [plane_with_holes(p0 + half, ud, vd, length, h, holes, cell, tex),
             plane_with_holes(p0 - half, ud, vd, length, h, holes, cell, tex)]
    # reveals: the inner faces of every opening, and caps
    t = w.thickness
    for a, b, c, e in holes:
        for s in (a, b):
            parts.append(panel(p0 - half + s * ud + c * vd, t * n, (e - c) * vd, cell))
        if e < h - 1e-6:
            parts.append(panel(p0 - half + a * ud + e * vd, t * n, (b - a) * ud, cell))
        if c > 1e-6:
            parts.append(panel(p0 - half + a * ud + c * vd, t * n, (b - a) * ud, cell))
    if w.caps[0]:
        parts.append(panel(p0 - half, t * n, h * vd, cell))
    if w.caps[1]:
        parts.append(panel(p1 - half, t * n, h * vd, cell))
    parts.append(panel(p0 - half + h * vd, t * n, length * ud, cell))  # top (seen where below the ceiling)
    return merge(parts)
