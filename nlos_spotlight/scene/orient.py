"""Find the up axis of a room scan and bring it to the scene convention (z up,
floor at z = 0).

Scans rarely say which way is up: OBJ/glTF exports are y-up, CAD is z-up and
RGB-D reconstructions (ICL-NUIM, BundleFusion) live in a camera frame that is
y-*down* and often tilted. We read gravity from the geometry:

1. Dominant planes: area-weighted face normals, folded so that n and -n count
   alike, are histogrammed on a Fibonacci sphere; peaks (area within 10 degrees
   of a direction, at least 5% of the total) are refined to the principal axis
   of the normals near them.
2. Axis: rooms are bounded by floor and ceiling and full of horizontal tops, so
   the up axis is the plane normal with the most parallel area, among those that
   have a perpendicular dominant plane (walls). Near ties (a small room whose
   walls have as much area as floor plus ceiling, e.g. the copyroom scan) are
   broken by a prior: the file's x axis is horizontal in every common
   convention (y-up, z-up, and camera frames, which have little roll), so the
   score is multiplied by ``1 - 0.2 |d_x|``: it only decides between
   candidates within about 20% of each other. On an arbitrarily rotated scan
   of such a room the prior can be wrong: pass the up axis explicitly.
3. Sign: scans show rooms from the inside, so bounding planes face inward at
   both ends and cannot tell floor from ceiling. Horizontal surfaces in the
   middle of the height range are mostly tops of furniture (tables, counters,
   seats, shelves) seen from above, so up is where they face. When the middle
   holds too little horizontal area to decide, the floor is taken to be the
   larger of the two bounding planes.

Measured on the real scans in ``shared/data/real-scans`` (see the tests): both
ICL-NUIM files are y-*down* (their README says y up; the sofa and desks stand
on the +y end), copyroom's up is about (0, -0.80, -0.59), 37 degrees off -y.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import NlosError
from .format import TriMesh

PLANE_DEG = 10.0
"""A face belongs to a plane direction when its normal is within this angle."""
MIN_PLANE_FRACTION = 0.05
"""A dominant plane direction holds at least this fraction of the total area
(a uniform sphere puts 3% within 10 degrees of any axis)."""
X_PRIOR = 0.2
"""Penalty on candidate up axes along the file's x axis (near-tie breaker)."""
_COS = np.cos(np.radians(PLANE_DEG))
_SIN = np.sin(np.radians(PLANE_DEG))


def fibonacci_sphere(n: int) -> np.ndarray:
    """(n, 3) nearly uniform unit directions."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = np.pi * (1.0 + 5.0 ** 0.5) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


@lru_cache(maxsize=1)
def _sphere_grid() -> tuple[np.ndarray, "object", "object"]:
    """Histogram directions (~3.2 degrees apart), their KD-tree and the sparse
    (N, N) 0/1 matrix of pairs within PLANE_DEG: built once, reused."""
    from scipy.spatial import cKDTree

    grid = fibonacci_sphere(4000)
    tree = cKDTree(grid)
    chord = 2.0 * np.sin(np.radians(PLANE_DEG) / 2.0)
    near = tree.sparse_distance_matrix(tree, chord, output_type="coo_matrix").tocsr()
    near.data[:] = 1.0
    return grid, tree, near


def _normals_areas(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(F', 3) unit normals, (F',) areas (m^2), (F', 3) centroids of non-degenerate faces."""
    a = mesh.face_areas()
    keep = a > 0
    if not np.any(keep):
        raise NlosError("orientation: mesh has no faces with area")
    return mesh.face_normals()[keep], a[keep], mesh.centroids()[keep]


def _refine(d: np.ndarray, n: np.ndarray, a: np.ndarray, iters: int = 4) -> np.ndarray:
    """Principal axis of the area-weighted normals within PLANE_DEG of +-d."""
    for _ in range(iters):
        sel = np.abs(n @ d) > _COS
        if not np.any(sel):
            break
        m = (n[sel] * a[sel, None]).T @ n[sel]
        d = np.linalg.eigh(m)[1][:, -1]
    return d / np.linalg.norm(d)


def dominant_planes(mesh: TriMesh, max_planes: int = 8,
                    min_fraction: float = MIN_PLANE_FRACTION) -> tuple[np.ndarray, np.ndarray]:
    """Directions of the large planes of a mesh (floor, walls, ...), sign-free.

    Returns:
        axes: (K, 3) unit normals, at least 25 degrees apart, biggest first.
        fractions: (K,) fraction of the total area within 10 degrees of each.
    """
    n, a, _ = _normals_areas(mesh)
    grid, tree, near = _sphere_grid()
    # n and -n are the same plane: count both so the histogram is symmetric.
    hist = (np.bincount(tree.query(n)[1], weights=a, minlength=len(grid))
            + np.bincount(tree.query(-n)[1], weights=a, minlength=len(grid)))
    score = near @ hist / a.sum()
    axes: list[np.ndarray] = []
    cos_sep = np.cos(np.radians(25.0))
    for k in np.argsort(-score):
        if score[k] < min_fraction or len(axes) == max_planes:
            break
        if all(abs(grid[k] @ p) < cos_sep for p in axes):
            axes.append(_refine(grid[k], n, a))
    if not axes:
        return np.zeros((0, 3)), np.zeros(0)
    axes_arr = np.array(axes)
    fractions = (np.abs(n @ axes_arr.T) > _COS).T @ a / a.sum()
    order = np.argsort(-fractions)
    return axes_arr[order], fractions[order]


def _up_sign(mesh: TriMesh, d: np.ndarray) -> float:
    """+1 if up is +d, -1 if -d (see the module docstring, step 3)."""
    n, a, c = _normals_areas(mesh)
    h, nd = c @ d, n @ d
    order = np.argsort(h)
    cw = np.cumsum(a[order]) / a.sum()
    lo, hi = h[order][np.searchsorted(cw, 0.01)], h[order][min(np.searchsorted(cw, 0.99), len(h) - 1)]
    t = (h - lo) / max(hi - lo, 1e-12)
    flat = np.abs(nd) > _COS
    at_lo, at_hi = flat & (t < 0.05), flat & (t > 0.95)
    # +1 when normals face the room interior (scans), -1 for an outward-facing mesh.
    inward = (a[at_lo] * np.sign(nd[at_lo])).sum() - (a[at_hi] * np.sign(nd[at_hi])).sum()
    facing = 1.0 if inward >= 0 else -1.0
    mid = flat & (t > 0.2) & (t < 0.8)
    net = (a[mid] * np.sign(nd[mid])).sum()
    if a[mid].sum() > 0.005 * a.sum() and abs(net) > 0.1 * a[mid].sum():
        return float(np.sign(net)) * facing
    return 1.0 if a[at_lo].sum() >= a[at_hi].sum() else -1.0


def detect_up_axis(mesh: TriMesh) -> np.ndarray:
    """Estimate the up direction of a room scan.

    Returns:
        (3,) unit vector in the mesh's own frame (e.g. (0, -1, 0) for a y-down file).

    Raises:
        NlosError: when the mesh has no dominant planes to read gravity from.
    """
    return _detect_up(mesh, *dominant_planes(mesh))


def _detect_up(mesh: TriMesh, axes: np.ndarray, frac: np.ndarray) -> np.ndarray:
    if len(axes) == 0:
        raise NlosError("cannot detect the up axis: the mesh has no dominant planes; give the up axis explicitly")
    perpendicular = (np.abs(axes @ axes.T) < _SIN).sum(axis=1)
    eligible = perpendicular >= 1 if np.any(perpendicular >= 1) else np.ones(len(axes), bool)
    score = np.where(eligible, frac * (1.0 - X_PRIOR * np.abs(axes[:, 0])), -np.inf)
    d = axes[int(np.argmax(score))]
    return d * _up_sign(mesh, d)


def _horizontal_axis(axes: np.ndarray, up: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to ``up``: the normal of the biggest wall (of the
    (K, 3) plane ``axes``) when there is one, so walls end up axis aligned; else the
    file axis least parallel to up."""
    walls = [w for w in axes if abs(w @ up) < _SIN]
    w = walls[0] if walls else np.eye(3)[int(np.argmin(np.abs(up)))]
    w = w - up * (w @ up)
    w /= np.linalg.norm(w)
    return w if w[np.argmax(np.abs(w))] > 0 else -w  # deterministic sign


def _floor_height(mesh: TriMesh, up: np.ndarray) -> float:
    """Height along ``up`` of the floor: the area-weighted median height of upward
    faces in the lowest 10% of the height range (or the 1% height quantile)."""
    n, a, c = _normals_areas(mesh)
    h = c @ up
    order = np.argsort(h)
    cw = np.cumsum(a[order]) / a.sum()
    lo, hi = h[order][np.searchsorted(cw, 0.01)], h.max()
    sel = (n @ up > _COS) & (h < lo + 0.1 * (hi - lo))
    if a[sel].sum() <= 0:
        return float(lo)
    hs, ws = h[sel], a[sel]
    o = np.argsort(hs)
    return float(hs[o][np.searchsorted(np.cumsum(ws[o]), 0.5 * ws.sum())])


def z_up_transform(mesh: TriMesh, up: np.ndarray | None = None) -> np.ndarray:
    """(4, 4) rigid transform taking the mesh to z up, biggest wall facing +-x,
    floor at z = 0. ``up`` (3,) overrides the detected up direction."""
    axes, frac = dominant_planes(mesh)
    if up is None:
        u = _detect_up(mesh, axes, frac)
    else:
        u = np.asarray(up, dtype=np.float64)
        if u.shape != (3,) or not np.all(np.isfinite(u)) or np.linalg.norm(u) < 1e-12:
            raise NlosError(f"up axis must be a non-zero 3-vector, got {up!r}")
        u = u / np.linalg.norm(u)
    x = _horizontal_axis(axes, u)
    rot = np.stack([x, np.cross(u, x), u])  # rows: new x, y, z; det = +1
    out = np.eye(4)
    out[:3, :3] = rot
    out[2, 3] = -_floor_height(mesh, u)
    return out


def to_z_up(mesh: TriMesh, up: np.ndarray | None = None) -> tuple[TriMesh, np.ndarray]:
    """Rotate a scan so up is +z and translate it so the floor is at z = 0.

    Returns:
        The moved mesh (new arrays, colors shared) and the (3, 3) rotation R:
        ``new = R @ old + (0, 0, -floor height)``.
    """
    t = z_up_transform(mesh, up)
    verts = mesh.vertices @ t[:3, :3].T + t[:3, 3]
    return TriMesh(verts, mesh.faces.copy(), mesh.vertex_colors, mesh.face_colors), t[:3, :3].copy()
