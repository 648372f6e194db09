"""Clean scanned meshes: merge duplicate vertices, drop degenerate and duplicate
faces, unreferenced vertices and tiny disconnected pieces, keeping colors attached.

The work is done by trimesh. Colors ride along as float vertex/face *attributes*
(not trimesh's uint8 ``visual``), because trimesh's ``update_faces`` /
``update_vertices`` apply the same masks to attributes: face colors follow their
faces and vertex colors follow the vertex kept for each merged group (the first
one), at full float precision.
"""

from __future__ import annotations

import numpy as np

from ..errors import NlosError
from .format import TriMesh

MERGE_TOL = 1e-6
"""Default merge tolerance, as a fraction of the bounding-box diagonal."""
MIN_COMPONENT_FRACTION = 1e-3
"""Default: drop connected pieces with less than this fraction of the total area."""


def bbox_diagonal(vertices: np.ndarray) -> float:
    """Length of the axis-aligned bounding-box diagonal of (V, 3) points, m."""
    return float(np.linalg.norm(np.ptp(vertices, axis=0)))


def to_trimesh(mesh: TriMesh):
    """A ``trimesh.Trimesh`` (process=False) carrying colors as float attributes."""
    import trimesh

    vattr = {} if mesh.vertex_colors is None else {"color": np.asarray(mesh.vertex_colors, np.float64)}
    fattr = {} if mesh.face_colors is None else {"color": np.asarray(mesh.face_colors, np.float64)}
    return trimesh.Trimesh(mesh.vertices, mesh.faces, process=False,
                           vertex_attributes=vattr, face_attributes=fattr)


def from_trimesh(tm) -> TriMesh:
    """Back to :class:`TriMesh`, reading the float color attributes if present."""
    vcol = tm.vertex_attributes.get("color")
    fcol = tm.face_attributes.get("color")
    return TriMesh(np.asarray(tm.vertices, np.float64).copy(), np.asarray(tm.faces, np.int64).copy(),
                   None if vcol is None else np.asarray(vcol, np.float64).copy(),
                   None if fcol is None else np.asarray(fcol, np.float64).copy())


def tidy(tm, tol: float) -> None:
    """In place: drop faces thinner than ``tol`` (m, zero area), duplicate faces
    (same vertex set, either winding) and unreferenced vertices."""
    tm.update_faces(tm.nondegenerate_faces(height=tol))
    tm.update_faces(tm.unique_faces())
    tm.remove_unreferenced_vertices()


def clean_mesh(mesh: TriMesh, merge_tol: float = MERGE_TOL,
               min_component_fraction: float = MIN_COMPONENT_FRACTION) -> TriMesh:
    """Return a cleaned copy of ``mesh``.

    Args:
        mesh: (V, 3) vertices in m, (F, 3) faces, optional colors.
        merge_tol: vertices closer than about ``merge_tol * bbox diagonal`` are
            merged (positions are rounded to that grid, trimesh's rule); faces
            thinner than that are dropped as degenerate.
        min_component_fraction: connected pieces (faces sharing edges) whose area
            is below this fraction of the total are dropped; 0 keeps all.

    Returns:
        A new :class:`TriMesh` (V', 3) / (F', 3) with colors re-indexed.
    """
    import trimesh

    if not 0 < merge_tol < 1e-2:
        raise NlosError(f"clean_mesh: merge_tol {merge_tol} outside (0, 0.01)")
    if not 0 <= min_component_fraction < 1:
        raise NlosError(f"clean_mesh: min_component_fraction {min_component_fraction} outside [0, 1)")
    tol = merge_tol * max(bbox_diagonal(mesh.vertices), 1e-12)
    tm = to_trimesh(mesh)
    digits = int(np.floor(-np.log10(tol)))
    tm.merge_vertices(merge_tex=True, merge_norm=True, digits_vertex=digits)
    tidy(tm, tol)
    if len(tm.faces) and min_component_fraction > 0:
        labels = trimesh.graph.connected_component_labels(tm.face_adjacency, node_count=len(tm.faces))
        area = np.bincount(labels, weights=tm.area_faces)
        tm.update_faces(area[labels] >= min_component_fraction * area.sum())
        tm.remove_unreferenced_vertices()
    if len(tm.faces) == 0:
        raise NlosError("clean_mesh: no faces left after removing degenerate faces")
    return from_trimesh(tm)
