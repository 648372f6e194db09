"""Decimate meshes to a target vertex count (quadric edge collapse, ``fast-simplification``).

``fast_simplification.simplify`` takes a target *face* count; we convert it from
the vertex target with the current face/vertex ratio and repeat until the vertex
count is within ``TOLERANCE`` of the target. Its collapses never join a border
vertex with an interior one and reject any that would turn a face by more than
~78 degrees, so on open scans with long ragged borders and sliver triangles
(the plane-simplified copyroom scan stops near 1,030 vertices whatever the
target) it stalls. Then one vertex-clustering step (trimesh's ``merge_vertices``
on a grid whose cell is bisected to hit the target) takes it the rest of the
way, and edge collapse resumes if needed.

Colors are carried by proximity: each output face takes the color of the
nearest input face centroid, each output vertex that of the nearest input vertex.
"""

from __future__ import annotations

import numpy as np

from ..errors import NlosError
from .clean import bbox_diagonal, tidy
from .format import TriMesh

TOLERANCE = 0.05
"""Relative tolerance on the vertex count that ends the iteration."""
_MAX_ROUNDS = 8


def decimate(mesh: TriMesh, target_vertices: int) -> TriMesh:
    """Simplify ``mesh`` to about ``target_vertices`` vertices (within ~5%).

    Args:
        mesh: (V, 3) vertices, (F, 3) faces, optional colors.
        target_vertices: wanted vertex count, >= 4. A target at or above V
            returns an unchanged copy.

    Returns:
        A new :class:`TriMesh`; colors carried by nearest neighbour.
    """
    if isinstance(target_vertices, bool) or not isinstance(target_vertices, (int, np.integer)):
        raise NlosError(f"decimate: target_vertices must be an integer, got {target_vertices!r}")
    if target_vertices < 4:
        raise NlosError(f"decimate: target_vertices must be at least 4, got {target_vertices}")
    if target_vertices >= len(mesh.vertices):
        return _copy(mesh)
    verts, faces = _reduce(mesh.vertices, mesh.faces, int(target_vertices))
    if len(faces) == 0:
        raise NlosError(f"decimate: nothing left of the mesh at {target_vertices} vertices")
    return TriMesh(verts, faces, *_carry_colors(mesh, verts, faces))


def decimate_ratio(mesh: TriMesh, ratio: float) -> TriMesh:
    """Keep about ``ratio`` of the vertices (DESIGN's "decimation 0.1-1.0"); 1 keeps all."""
    if isinstance(ratio, bool) or not isinstance(ratio, (int, float, np.floating)) or not 0 < ratio <= 1:
        raise NlosError(f"decimate: ratio must be in (0, 1], got {ratio!r}")
    return decimate(mesh, max(4, int(round(ratio * len(mesh.vertices)))))


def _copy(mesh: TriMesh) -> TriMesh:
    cp = (lambda x: None if x is None else x.copy())
    return TriMesh(mesh.vertices.copy(), mesh.faces.copy(), cp(mesh.vertex_colors), cp(mesh.face_colors))


def _reduce(verts: np.ndarray, faces: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """Edge collapse until (V, 3)/(F, 3) has ~target vertices; cluster once it stalls."""
    tol = 1e-9 * max(bbox_diagonal(verts), 1e-12)
    p, f = np.asarray(verts, np.float64), np.asarray(faces, np.int64)
    for _ in range(_MAX_ROUNDS):
        if len(p) <= (1 + TOLERANCE) * target:
            break
        before = len(p)
        p, f = _collapse(p, f, target, tol)
        if len(p) > (1 + TOLERANCE) * target and len(p) > 0.97 * before:
            p, f = _cluster(p, f, target, tol)
    return p, f


def _collapse(p: np.ndarray, f: np.ndarray, target: int, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """One quadric edge-collapse pass; if it overshoots below the target, retry from
    the same input with a proportionally larger face target (at most twice)."""
    import fast_simplification

    count = int(len(f) * target / len(p))
    best = (p, f)
    for _ in range(3):
        if not 4 <= count < len(f):
            break
        q, g = fast_simplification.simplify(p, f.astype(np.int32), target_count=count)
        q, g = _tidied(q, g, tol)
        if abs(len(q) - target) < abs(len(best[0]) - target):
            best = (q, g)
        if len(q) >= (1 - TOLERANCE) * target:
            break
        count = int(count * target / max(len(q), 1))
    return best


def _cluster(p: np.ndarray, f: np.ndarray, target: int, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid vertex clustering with the cell size bisected so that about ``target``
    vertices remain (each cell keeps its first vertex)."""
    lo, hi = 1e-5 * bbox_diagonal(p), 0.5 * bbox_diagonal(p)
    best = (p, f)
    for _ in range(24):
        cell = np.sqrt(lo * hi)
        q, g = _merge_grid(p, f, cell, tol)
        if abs(len(q) - target) < abs(len(best[0]) - target) and len(g):
            best = (q, g)
        if abs(len(q) - target) <= 0.5 * TOLERANCE * target:
            break
        lo, hi = (cell, hi) if len(q) > target else (lo, cell)
    return best


def _merge_grid(p: np.ndarray, f: np.ndarray, cell: float, tol: float) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    # trimesh merges positions equal after rounding to 10**-digits; scaling by
    # 1/cell makes that an integer grid of the cell size we want.
    tm = trimesh.Trimesh(p / cell, f, process=False)
    tm.merge_vertices(merge_tex=True, merge_norm=True, digits_vertex=0)
    tidy(tm, tol / cell)
    return np.asarray(tm.vertices) * cell, np.asarray(tm.faces, np.int64)


def _tidied(p: np.ndarray, f: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Drop degenerate/duplicate faces and unreferenced vertices left by a pass."""
    import trimesh

    tm = trimesh.Trimesh(p, f, process=False)
    tidy(tm, tol)
    return np.asarray(tm.vertices, np.float64), np.asarray(tm.faces, np.int64)


def _carry_colors(src: TriMesh, verts: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(V', 3) vertex colors from the nearest source vertex, (F', 3) face colors from
    the nearest source face centroid; None where the source has none."""
    from scipy.spatial import cKDTree

    vcol = fcol = None
    if src.vertex_colors is not None:
        vcol = src.vertex_colors[cKDTree(src.vertices).query(verts)[1]]
    if src.face_colors is not None:
        centroids = verts[faces].mean(axis=1)
        fcol = src.face_colors[cKDTree(src.centroids()).query(centroids)[1]]
    return vcol, fcol
