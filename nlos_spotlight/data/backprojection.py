"""Matched-filter backprojection: where on the hidden floor a person's light on the walls came from.

The renderer says how light from the spot reaches a person and comes back to the visible walls.
Reduced to a small isotropic scatterer at a point p of the hidden area, the image it adds is, per
camera pixel c (DESIGN section 5, one bounce on each leg, Lambertian walls)::

    T_a(p, c) = S_a(p) K(p, c),   S_a(p) = V(a, p) max(0, n_a . (p - a)) / |p - a|^3,
                                  K(p, c) = rho_c V(p, c) max(0, n_c . (p - c)) / |p - c|^3,

with a the spot's point on the visible wall (normal n_a), c the surface a pixel shows (normal
n_c, albedo rho_c) and V the room's visibility. K is the same for every spot (once per room);
S_a is a vector per spot. The matched filter of a background-subtracted image I (luminance) is
the normalized correlation with each template, weighted by the inverse noise variance w_c::

    h(p) = sum_c w_c T_a(p, c) I(c) / sqrt(sum_c w_c T_a(p, c)^2),

the detection statistic of a point scatterer at p in Gaussian noise (the classic backprojection
of NLOS imaging, e.g. Velten et al. 2012, restricted to the floor and the one spot). It needs no
training: the room's scan and the spot are all it reads, so it works the same in a room nobody
trained on. Points are on a floor grid in the targets' region frame (``tensors.ground_frame``) at
a few heights; cells where a person cannot stand (``world.placement.valid_positions``: outside
the region, inside furniture, out of the walls' sight) are masked. ``locate`` answers with the
best cell.

Shapes:
    grid G cells x Z heights = P points; K (P, C) over the C pixels that show a surface;
    ``heatmap`` (B, Z, G) for images (B, H, W) or (B, H, W, 3); ``locate`` (B, 2) meters.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..scene.format import Scene


MASKS = ("placement", "free")
"""Rules for the cells a person may stand in (:attr:`FloorGrid.mask`)."""


@dataclass(frozen=True)
class FloorGrid:
    """Where the backprojector looks: a square floor grid in the region frame, at a few heights."""

    extent: float = 2.2
    """Half width of the square, m (targets of the procedural rooms lie within about 2.1 m)."""
    step: float = 0.2
    """Cell spacing, m."""
    heights: tuple[float, ...] = (0.3, 0.9, 1.5)
    """Heights above the hidden floor, m (legs, hips, chest of a standing person; a sitting or
    crouching one reaches the lower two)."""
    mask: str = "placement"
    """Cells a person may stand in: 'placement' (the dataset's rules: in the hidden region, 0.6-2.4 m
    from the visible surfaces as DESIGN section 7 asks, free of furniture, seeing the walls) or
    'free' (in the region and free of furniture only)."""

    def cells(self) -> np.ndarray:
        """(G, 2) cell centers (along the view, to its left), m."""
        g = np.arange(-self.extent, self.extent + 1e-9, self.step)
        gx, gy = np.meshgrid(g, g, indexing="ij")
        return np.column_stack([gx.ravel(), gy.ravel()])


@dataclass
class Backprojector:
    """The spot-independent part of a room's templates, and the spot factor on demand."""

    cells: np.ndarray
    """(G, 2) grid cells in the region frame, m."""
    points: np.ndarray
    """(Z * G, 3) world points: every cell at every height (height-major)."""
    valid: np.ndarray
    """(G,) bool: a person can stand in the cell."""
    kernel: np.ndarray
    """(Z * G, C) K(p, c) over the pixels that show a surface."""
    hit: np.ndarray
    """(H, W) bool: the pixel shows a surface (the C columns of ``kernel``)."""
    heights: int
    """Z."""
    engine: object
    """The room's ``render.rays.RayEngine`` (the spot factor's visibility)."""

    def spot_factor(self, aim: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """(Z * G,) S_a(p) of a spot at ``aim`` on a surface of unit ``normal`` (the lit side's)."""
        d = self.points - aim
        r = np.linalg.norm(d, axis=1)
        s = np.clip(d @ normal / r, 0.0, None) / r ** 2
        idx = np.flatnonzero(s > 0)
        blocked = self.engine.occluded(np.repeat(aim[None], len(idx), 0), self.points[idx],
                                  np.repeat(normal[None], len(idx), 0), None)
        s[idx[blocked]] = 0.0
        return s

    def heatmap(self, images: np.ndarray, spot: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
        """(B, Z, G) matched-filter statistic h(p) of images (B, H, W[, 3]) under spot factor ``spot``;
        ``weights`` (H, W[, 3]) the inverse noise variance per pixel (None: white noise)."""
        images = np.asarray(images, dtype=np.float64)
        img = (images.mean(-1) if images.ndim == 4 else images).reshape(len(images), -1)[:, self.hit.ravel()]
        w = None
        if weights is not None:
            w = np.asarray(weights, dtype=np.float64)
            w = (w.mean(-1) if w.ndim == 3 else w).ravel()[self.hit.ravel()]
        h = matched_filter(img, spot[:, None] * self.kernel, w)
        return h.reshape(len(images), self.heights, -1)

    def locate(self, images: np.ndarray, spot: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
        """(B, 2) region-frame position of the valid cell with the largest statistic over heights."""
        h = self.heatmap(images, spot, weights).max(1)
        h = np.where(self.valid[None], h, -np.inf)
        return self.cells[h.argmax(1)]


def matched_filter(images, templates, weights=None):
    """(B, P) h = sum_c w_c T(p, c) I(c) / sqrt(sum_c w_c T(p, c)^2) of luminance images (B, C) and
    templates (P, C), numpy or torch alike (the training benchmarks call it on noisy torch batches);
    ``weights`` (C,) the inverse noise variance (None: 1). Templates of zero norm give 0."""
    w = 1.0 if weights is None else weights
    norm = ((templates * templates) * w).sum(-1) ** 0.5
    inv = 1.0 / (norm + (norm == 0)) * (norm > 0)  # 0 where a template is all zero
    return ((images * w) @ templates.T) * inv


def camera_kernel(engine, points: np.ndarray, pos: np.ndarray, normal: np.ndarray, albedo: np.ndarray) -> np.ndarray:
    """(P, C) K(p, c) for world ``points`` (P, 3) and the surfaces pixels show (C, 3) each."""
    d = points[:, None, :] - pos[None]
    r = np.linalg.norm(d, axis=2)
    k = albedo.mean(1)[None] * np.clip(np.einsum("pcj,cj->pc", d, normal), 0.0, None) / r ** 3
    pi, ci = np.nonzero(k > 0)
    blocked = engine.occluded(points[pi], pos[ci], None, normal[ci])
    k[pi[blocked], ci[blocked]] = 0.0
    return k


def backprojector(scene: Scene, origin_xy: np.ndarray, fwd_xy: np.ndarray,
                  grid: FloorGrid = FloorGrid()) -> Backprojector:
    """A room's backprojector on ``grid`` around ``origin_xy`` (the region frame's axes: ``fwd_xy``
    and its left) at the hidden floor's height."""
    if grid.mask not in MASKS:  # before the kernel's rays
        raise ValueError(f"backprojection mask: expected one of {', '.join(MASKS)}, got {grid.mask!r}")
    from ..render.gbuffer import render_gbuffer
    from ..render.surface import StaticSurfaces
    from ..world.placement import SceneGeometry

    surf = StaticSurfaces(scene)
    g = render_gbuffer(scene, surf)
    cells = grid.cells()
    left = np.array([-fwd_xy[1], fwd_xy[0]])
    world_xy = origin_xy + cells[:, :1] * fwd_xy + cells[:, 1:] * left
    floor_z = scene.hidden_region.floor_z
    points = np.concatenate([np.column_stack([world_xy, np.full(len(cells), floor_z + h)]) for h in grid.heights])
    hit = g.hit
    kernel = camera_kernel(surf.engine, points, g.position[hit], g.normal[hit], g.albedo[hit])
    rules = {} if grid.mask == "placement" else {"distance": (0.0, np.inf), "min_seen": 0.0}
    valid = SceneGeometry(scene, engine=surf.engine).valid_positions(world_xy, **rules)
    return Backprojector(cells, points, valid, kernel, hit, len(grid.heights), surf.engine)


@functools.lru_cache(maxsize=8)
def room_backprojector(scene_dir: str, grid: FloorGrid = FloorGrid()) -> tuple[Backprojector, dict]:
    """A dataset room's backprojector (region frame of its targets) and its static arrays (aim
    points, LOS mesh, camera pose), cached per room."""
    from ..scene.io import load_scene
    from .tensors import region_center, view_forward_xy

    d = Path(scene_dir)
    scene = load_scene(d)
    from .static import read_static

    st = read_static(d)
    pose = st["camera_to_world"]
    return backprojector(scene, region_center(d), view_forward_xy(pose), grid), st


def candidate_spot_factor(scene_dir: str, face: int, grid: FloorGrid = FloorGrid()) -> np.ndarray:
    """(Z * G,) S_a(p) of a dataset room's candidate ``face``: its stored aim point, its LOS face's
    normal turned toward the camera (the candidate is a face the camera sees)."""
    bp, st = room_backprojector(str(scene_dir), grid)
    tri = st["los_vertices"][st["los_faces"][face]]
    n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    aim = st["aim_points"][face]
    n = n / np.linalg.norm(n) * np.sign(n @ (st["camera_to_world"][:3, 3] - aim) + 1e-300)
    return bp.spot_factor(aim, n)


__all__ = ["MASKS", "Backprojector", "FloorGrid", "backprojector", "camera_kernel", "candidate_spot_factor",
           "matched_filter", "room_backprojector"]
