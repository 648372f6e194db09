"""Small geometric building blocks for scenes written in code (tests, examples, the world)."""

from __future__ import annotations

import numpy as np

from .format import TriMesh


def quad(origin, u, v, nu: int = 1, nv: int = 1) -> TriMesh:
    """Planar grid origin + a u + b v, (a, b) in [0, 1]^2, with nu x nv cells (normal u x v)."""
    origin, u, v = (np.asarray(x, dtype=np.float64) for x in (origin, u, v))
    a, b = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1), indexing="ij")
    verts = origin + a.reshape(-1, 1) * u + b.reshape(-1, 1) * v
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
    v00, v10, v01, v11 = idx[:-1, :-1], idx[1:, :-1], idx[:-1, 1:], idx[1:, 1:]
    faces = np.concatenate([np.stack([v00, v10, v11], -1).reshape(-1, 3),
                            np.stack([v00, v11, v01], -1).reshape(-1, 3)])
    return TriMesh(verts, faces)


def box(lo, hi) -> TriMesh:
    """Axis-aligned closed box with outward normals."""
    import trimesh

    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    tm = trimesh.creation.box(extents=hi - lo)
    return TriMesh(np.asarray(tm.vertices) + (lo + hi) / 2, np.asarray(tm.faces, dtype=np.int64))


def corrugated(origin, u, v, amplitude: float, periods: float, nu: int = 48, nv: int = 4) -> TriMesh:
    """A wall like :func:`quad` displaced along its normal by amplitude * sin(2 pi periods a)."""
    m = quad(origin, u, v, nu, nv)
    u, v = np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64)
    n = np.cross(u, v)
    n /= np.linalg.norm(n)
    a = (m.vertices - np.asarray(origin)) @ u / (u @ u)
    m.vertices = m.vertices + amplitude * np.sin(2 * np.pi * periods * a)[:, None] * n
    return m


def merge(*meshes: TriMesh) -> TriMesh:
    """Concatenate meshes (colors dropped unless all have vertex colors)."""
    verts, faces, off = [], [], 0
    for m in meshes:
        verts.append(m.vertices)
        faces.append(m.faces + off)
        off += len(m.vertices)
    vcol = None
    if all(m.vertex_colors is not None for m in meshes):
        vcol = np.concatenate([m.vertex_colors for m in meshes])
    return TriMesh(np.concatenate(verts), np.concatenate(faces), vcol)


def mannequin(position, height: float = 1.75, facing_deg: float = 0.0, arms_deg: float = 0.0) -> TriMesh:
    """A coarse stand-in body from capsules (torso, head, legs, arms), feet at ``position``.

    Only for tests and examples of the renderer; the world uses a real body model.
    ``arms_deg`` raises both arms from hanging (0) to horizontal (90).
    """
    import trimesh

    s = height / 1.75
    parts = [((0.0, 0.0, 1.15), 0.16, 0.45, 0.0),       # torso
             ((0.0, 0.0, 1.63), 0.11, 0.02, 0.0),        # head
             ((0.0, -0.1, 0.45), 0.075, 0.75, 0.0),      # legs
             ((0.0, 0.1, 0.45), 0.075, 0.75, 0.0)]
    meshes = []
    for (x, y, z), r, h, _ in parts:
        c = trimesh.creation.capsule(height=h * s, radius=r * s, count=[10, 10])
        c.apply_translation(np.array([x, y, z]) * s)
        meshes.append(c)
    for side in (-1, 1):
        arm = trimesh.creation.capsule(height=0.55 * s, radius=0.05 * s, count=[8, 8])
        arm.apply_translation([0, 0, -0.3 * s])  # hang from the shoulder at the origin
        rot = trimesh.transformations.rotation_matrix(np.radians(arms_deg) * side, [1, 0, 0])
        arm.apply_transform(rot)
        arm.apply_translation(np.array([0, side * 0.24, 1.4]) * s)
        meshes.append(arm)
    tm = trimesh.util.concatenate(meshes)
    tm.apply_transform(trimesh.transformations.rotation_matrix(np.radians(facing_deg), [0, 0, 1]))
    tm.apply_translation(np.asarray(position, dtype=np.float64))
    return TriMesh(np.asarray(tm.vertices, dtype=np.float64), np.asarray(tm.faces, dtype=np.int64))
