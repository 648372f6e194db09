"""Camera and projector placement, occluders, and the ray-cast checks of the hidden region.

All visibility here is Embree (:class:`~nlos_spotlight.render.rays.RayEngine`) against the static
geometry, batched, no per-ray Python loop.

* **Hidden.** A person of radius ``margin`` and up to ``body_height`` tall standing anywhere in
  the hidden region must be invisible to the camera *and* the projector: sample points on vertical
  segments (several heights) over a grid of the region grown by the margin; every segment from
  the camera or projector position to any of them must be blocked by static geometry.
* **Relay.** The light must be able to go wall -> person -> wall: from sample points in the
  region, a good fraction of the camera-visible LOS points (first hits of camera rays) must be
  visible, on the same side of their surface as the camera.
* **Person positions.** Uniform over the part of the region whose distance to the nearest
  camera-visible LOS surface (on the person's side of it) is 0.6-2.4 m (2-8 ft, DESIGN section 7),
  where a 0.3 m cylinder around the body axis meets no static geometry, and from where the body
  sees some of the camera-visible surfaces.

Placement: :func:`tripod` (camera and projector), :func:`occluders` (free-standing pieces beside
the line of sight) and :func:`find_region` (the hidden rectangle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..render.camera import pixel_rays
from ..render.rays import RayEngine
from ..scene.format import Camera, HiddenRegion, Projector, Scene

CHECK_HEIGHTS = (0.02, 0.3, 0.6, 0.9, 1.2, 1.5, 1.75, 1.9)
"""Heights above the floor (m) of the hidden-check points on each vertical segment."""


# ----------------------------------------------------------------------------- primitives
def visible(engine: RayEngine, source: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N,) bool: the open segment source -> point meets no static geometry."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    src = np.broadcast_to(np.asarray(source, dtype=np.float64), points.shape).copy()
    return ~engine.occluded(src, points)


def segment_points(xy: np.ndarray, floor_z: float, heights=CHECK_HEIGHTS) -> np.ndarray:
    """(N * len(heights), 3) points on the vertical segments above floor positions ``xy`` (N, 2)."""
    h = np.asarray(heights, dtype=np.float64)
    p = np.repeat(xy, len(h), axis=0)
    return np.concatenate([p, floor_z + np.tile(h, len(xy))[:, None]], axis=1)


def region_grid(region: HiddenRegion, spacing: float, margin: float,
                jitter: np.random.Generator | None = None) -> np.ndarray:
    """Floor positions covering the region grown by ``margin``: a grid of ``spacing`` plus the
    boundary of the grown rectangle (its corners rounded like a disk of radius margin)."""
    lo, hi = region.min - margin, region.max + margin
    nx = max(2, int(math.ceil((hi[0] - lo[0]) / spacing)) + 1)
    ny = max(2, int(math.ceil((hi[1] - lo[1]) / spacing)) + 1)
    gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], nx), np.linspace(lo[1], hi[1], ny), indexing="ij")
    pts = np.stack([gx.ravel(), gy.ravel()], 1)
    if jitter is not None:
        pts = pts + jitter.uniform(-0.5, 0.5, pts.shape) * spacing
        pts = np.clip(pts, lo, hi)
    # keep points within `margin` of the region (rounded corners), then add the exact outline
    d = np.linalg.norm(np.maximum(0, np.maximum(region.min - pts, pts - region.max)), axis=1)
    pts = pts[d <= margin + 1e-9]
    ang = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    corners = np.array([[region.min[0], region.min[1]], [region.max[0], region.min[1]],
                        [region.max[0], region.max[1]], [region.min[0], region.max[1]]])
    ring = (corners[:, None, :] + margin * np.stack([np.cos(ang), np.sin(ang)], 1)[None]).reshape(-1, 2)
    dr = np.linalg.norm(np.maximum(0, np.maximum(region.min - ring, ring - region.max)), axis=1)
    ring = ring[dr >= margin - 1e-9]
    edges = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        t = np.linspace(0, 1, max(2, int(np.linalg.norm(b - a) / spacing) + 1))[:, None]
        e = a + t * (b - a)
        n = np.array([b[1] - a[1], a[0] - b[0]])
        n = n / np.linalg.norm(n)
        c = (region.min + region.max) / 2
        if np.dot(n, (a + b) / 2 - c) < 0:
            n = -n
        edges.append(e + margin * n)
    return np.concatenate([pts, ring, *edges])


@dataclass
class HiddenCheck:
    """Result of the ray-cast hidden check."""

    ok: bool
    """No check point is visible from the camera or the projector."""
    points: int
    """Number of check points (floor positions x heights)."""
    seen_by_camera: int
    """Check points with an unobstructed segment to the camera."""
    seen_by_projector: int
    """Check points with an unobstructed segment to the projector."""


def hidden_check(engine: RayEngine, sources: dict[str, np.ndarray], region: HiddenRegion, margin: float = 0.25,
                 spacing: float = 0.1, heights=CHECK_HEIGHTS, rng: np.random.Generator | None = None) -> HiddenCheck:
    """Cast a segment from every source to every check point of the region grown by ``margin``."""
    pts = segment_points(region_grid(region, spacing, margin, rng), region.floor_z, heights)
    seen = {k: int(visible(engine, s, pts).sum()) for k, s in sources.items()}
    return HiddenCheck(all(v == 0 for v in seen.values()), len(pts), seen.get("camera", 0), seen.get("projector", 0))


# ----------------------------------------------------------------------------- LOS points
@dataclass
class LosPoints:
    """Camera-visible static surface points."""

    pos: np.ndarray
    """(N, 3) first hits of camera rays."""
    normal: np.ndarray
    """(N, 3) unit normals turned toward the camera."""
    face: np.ndarray
    """(N,) static face index."""


def thin(los: LosPoints, cell: float = 0.04) -> LosPoints:
    """One point per ``cell``-sized voxel (near surfaces are sampled far more densely than needed)."""
    key = np.floor(los.pos / cell).astype(np.int64)
    _, idx = np.unique(key, axis=0, return_index=True)
    idx.sort()
    return LosPoints(los.pos[idx], los.normal[idx], los.face[idx])


def los_points(engine: RayEngine, cam: Camera, n: int = 32, normals: np.ndarray | None = None) -> LosPoints:
    """First hits of an n x n grid of camera rays (same fov and aspect as the camera)."""
    probe = Camera(cam.position, cam.look_at, cam.up, cam.fov_deg, n, max(1, round(n * cam.height / cam.width)))
    dirs, origin = pixel_rays(probe, 1)
    d = dirs.reshape(-1, 3)
    h = engine.first_hit(np.broadcast_to(origin, d.shape).copy(), d)
    face = h.face[h.hit]
    pos = origin + d[h.hit] * h.t[h.hit, None]
    if normals is None:
        tri = engine.vertices[engine.faces[face]]
        normals_f = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    else:
        normals_f = normals[face]
    nrm = normals_f / np.maximum(np.linalg.norm(normals_f, axis=1, keepdims=True), 1e-30)
    nrm = np.where(((origin - pos) * nrm).sum(1, keepdims=True) < 0, -nrm, nrm)
    return LosPoints(pos, nrm, face)


@dataclass
class RelayCheck:
    """How well the hidden region and the camera-visible surfaces see each other."""

    mean_fraction: float
    """Mean over region samples of the fraction of camera-visible LOS points they see."""
    low_fraction: float
    """10th percentile of that fraction over the region samples."""
    seen_anything: float
    """Fraction of floor positions from which some height of the body sees a camera-visible LOS point."""
    point_score: np.ndarray
    """(N,) per LOS point: fraction of region samples that see it."""


def relay_check(engine: RayEngine, los: LosPoints, region: HiddenRegion, n: int = 5,
                heights=(0.4, 1.0, 1.6)) -> RelayCheck:
    """Region samples (n x n grid x heights) against every LOS point: same side and unobstructed."""
    gx, gy = np.meshgrid(np.linspace(region.min[0], region.max[0], n), np.linspace(region.min[1], region.max[1], n),
                         indexing="ij")
    q = segment_points(np.stack([gx.ravel(), gy.ravel()], 1), region.floor_z, heights)
    m, k = len(q), len(los.pos)
    if k == 0:
        return RelayCheck(0.0, 0.0, 0.0, np.zeros(0))
    qq = np.repeat(q, k, axis=0)
    pp = np.tile(los.pos, (m, 1))
    nn = np.tile(los.normal, (m, 1))
    side = ((qq - pp) * nn).sum(1) > 1e-6
    vis = np.zeros(m * k, dtype=bool)
    idx = np.flatnonzero(side)
    vis[idx] = ~engine.occluded(pp[idx], qq[idx], nn[idx], None)
    vis = vis.reshape(m, k)
    frac = vis.mean(1)
    per_position = vis.reshape(-1, len(heights), k).any(axis=(1, 2))
    return RelayCheck(float(frac.mean()), float(np.quantile(frac, 0.1)), float(per_position.mean()), vis.mean(0))


# ----------------------------------------------------------------------------- person positions
def los_distance(xy: np.ndarray, floor_z: float, los: LosPoints, body_height: float = 1.9,
                 max_distance: float = np.inf) -> np.ndarray:
    """(N,) distance from each body axis (vertical segment above ``xy``) to the nearest camera-visible
    LOS point whose surface faces the person (on the camera's side of it); inf if none (or if none
    lies within ``max_distance``, which only speeds things up)."""
    out = np.full(len(xy), np.inf)
    if len(xy) == 0 or len(los.pos) == 0:
        return out
    p, n = los.pos, los.normal
    if np.isfinite(max_distance):  # drop LOS points too far from every position
        lo, hi = xy.min(0) - max_distance, xy.max(0) + max_distance
        keep = np.all((p[:, :2] >= lo) & (p[:, :2] <= hi), axis=1)
        p, n = p[keep], n[keep]
        if len(p) == 0:
            return out
    # the axis point nearest each LOS point; the axis starts just above the floor so that the floor
    # around the person counts as a surface facing them
    pz = np.clip(p[:, 2], floor_z + 0.02, floor_z + body_height)
    dz = pz - p[:, 2]
    pxy, nxy = p[:, :2], n[:, :2]
    # expanded forms so that the pair terms are two small matrix products
    const_d = (pxy * pxy).sum(1) + dz * dz  # (k,)
    const_f = -(nxy * pxy).sum(1) + n[:, 2] * dz
    for a in range(0, len(xy), 2048):
        q = xy[a:a + 2048]
        d2 = (q * q).sum(1)[:, None] - 2.0 * (q @ pxy.T) + const_d[None]
        facing = (q @ nxy.T) + const_f[None] > 0
        out[a:a + 2048] = np.sqrt(np.maximum(np.where(facing, d2, np.inf).min(1), 0.0))
    return out


def collides(engine: RayEngine, xy: np.ndarray, floor_z: float, radius: float = 0.3, body_height: float = 1.9,
             directions: int = 24) -> np.ndarray:
    """(N,) bool: static geometry enters the cylinder of ``radius`` around the body axis (floor excluded).

    At eight heights: rays from the axis outward in ``directions`` directions, and rays along the
    edges of polygons inscribed in the circles of radius ``radius`` and ``radius / 2`` (anything
    that enters the cylinder at that height crosses the outer polygon; thin panels poking in between
    the radial rays are caught there). Plus vertical rays from just above the floor on three rings.
    """
    n = len(xy)
    if n == 0:
        return np.zeros(0, dtype=bool)
    hs = floor_z + np.array([0.06, 0.3, 0.6, 0.9, 1.2, 1.5, 1.75, body_height])
    ang = np.arange(directions) * 2 * np.pi / directions
    ring = np.stack([np.cos(ang), np.sin(ang)], 1)
    o_list, d_list, l_list = [], [], []
    # radial rays
    o_list.append(np.zeros((directions, 2)))
    d_list.append(ring)
    l_list.append(np.full(directions, radius))
    # polygon edges at two radii
    for r in (radius, 0.5 * radius):
        p0, p1 = r * ring, r * np.roll(ring, -1, axis=0)
        e = p1 - p0
        length = np.linalg.norm(e, axis=1)
        o_list.append(p0)
        d_list.append(e / length[:, None])
        l_list.append(length)
    o2, d2, l2 = np.concatenate(o_list), np.concatenate(d_list), np.concatenate(l_list)  # (k, 2) per height
    k = len(o2)
    # (n, h, k) horizontal rays
    org = np.empty((n, len(hs), k, 3))
    org[..., 0] = xy[:, None, None, 0] + o2[None, None, :, 0]
    org[..., 1] = xy[:, None, None, 1] + o2[None, None, :, 1]
    org[..., 2] = hs[None, :, None]
    dirs = np.zeros((n, len(hs), k, 3))
    dirs[..., :2] = d2[None, None]
    lens = np.broadcast_to(l2, (n, len(hs), k))
    offs = np.concatenate([r * np.stack([np.cos(a), np.sin(a)], 1)
                           for r, c in ((0.0, 1), (0.5 * radius, 6), (0.95 * radius, 12))
                           for a in [np.arange(c) * 2 * np.pi / max(c, 1) + 0.3]])
    ov = np.concatenate([np.repeat(xy, len(offs), 0) + np.tile(offs, (n, 1)),
                         np.full((n * len(offs), 1), floor_z + 0.03)], 1)
    dv = np.tile([0.0, 0.0, 1.0], (len(ov), 1))
    lv = np.full(len(ov), body_height - 0.03)
    hit = engine.occluded_rays(np.concatenate([org.reshape(-1, 3), ov]), np.concatenate([dirs.reshape(-1, 3), dv]),
                               np.concatenate([lens.reshape(-1), lv]))
    m = org.shape[0] * org.shape[1] * org.shape[2]
    return hit[:m].reshape(n, -1).any(1) | hit[m:].reshape(n, -1).any(1)


def sees_relay(engine: RayEngine, xy: np.ndarray, floor_z: float, los: LosPoints, min_fraction: float = 0.02,
               heights=(0.5, 1.0, 1.5), max_points: int = 256) -> np.ndarray:
    """(N,) bool: from the body axis above ``xy`` (at ``heights``), at least ``min_fraction`` of the
    camera-visible LOS points (an even subsample of at most ``max_points``) are visible on their
    camera side: light can go wall -> person -> wall."""
    n = len(xy)
    if n == 0 or len(los.pos) == 0:
        return np.zeros(n, dtype=bool)
    step = max(1, int(math.ceil(len(los.pos) / max_points)))
    p, nrm = los.pos[::step], los.normal[::step]
    q = segment_points(xy, floor_z, heights)  # (n * h, 3)
    k, m = len(p), len(q)
    qq = np.repeat(q, k, axis=0)
    pp = np.tile(p, (m, 1))
    nn = np.tile(nrm, (m, 1))
    side = ((qq - pp) * nn).sum(1) > 1e-6
    vis = np.zeros(m * k, dtype=bool)
    idx = np.flatnonzero(side)
    vis[idx] = ~engine.occluded(pp[idx], qq[idx], nn[idx], None)
    frac = vis.reshape(n, len(heights), k).any(1).mean(1)
    return frac >= min_fraction


def on_floor(engine: RayEngine, xy: np.ndarray, floor_z: float, tol: float = 0.1) -> np.ndarray:
    """(N,) bool: a ray down from 0.3 m above the floor at ``xy`` meets a surface within ``tol`` of
    the floor height (a scanned room: the person stands on its floor, not outside its walls)."""
    if len(xy) == 0:
        return np.zeros(0, dtype=bool)
    org = np.concatenate([xy, np.full((len(xy), 1), floor_z + 0.3)], 1)
    h = engine.first_hit(org, np.broadcast_to([0.0, 0.0, -1.0], org.shape).copy())
    return h.hit & (np.abs(h.t - 0.3) <= tol)


class SceneGeometry:
    """Ray engine and camera-visible points of a scene (built once, reused by the checks)."""

    def __init__(self, scene: Scene, los_n: int = 48, engine: RayEngine | None = None):
        """``engine``: the static scene's ray engine when the caller has one (else it is built)."""
        self.scene = scene
        if engine is None:
            mesh, _ = scene.static_mesh()
            engine = RayEngine(mesh.vertices, mesh.faces)
        self.engine = engine
        self.los = thin(los_points(self.engine, scene.camera, los_n))

    def valid_positions(self, xy: np.ndarray, distance=(0.6, 2.4), radius: float = 0.3,
                        body_height: float = 1.9, min_seen: float = 0.02, floor: bool = False) -> np.ndarray:
        """(N,) bool: inside the region, at an allowed LOS distance, free of static geometry, and
        seeing at least ``min_seen`` of the camera-visible points; with ``floor``, also standing on
        a floor (:func:`on_floor`: scans, whose walls have holes a person outside could see through)."""
        reg = self.scene.hidden_region
        return valid_positions(self.engine, self.los, reg, xy, distance, radius, body_height, min_seen, floor)


def valid_positions(engine: RayEngine, los: LosPoints, region: HiddenRegion, xy: np.ndarray, distance=(0.6, 2.4),
                    radius: float = 0.3, body_height: float = 1.9, min_seen: float = 0.02,
                    floor: bool = False) -> np.ndarray:
    """See :meth:`SceneGeometry.valid_positions`; cheapest tests first."""
    ok = np.all((xy >= region.min) & (xy <= region.max), axis=1)
    if floor:
        idx = np.flatnonzero(ok)
        ok[idx] = on_floor(engine, xy[idx], region.floor_z)
    idx = np.flatnonzero(ok)
    d = los_distance(xy[idx], region.floor_z, los, body_height, distance[1])
    ok[idx] = (d >= distance[0]) & (d <= distance[1])
    idx = np.flatnonzero(ok)
    ok[idx] = ~collides(engine, xy[idx], region.floor_z, radius, body_height)
    idx = np.flatnonzero(ok)
    if min_seen > 0:
        ok[idx] = sees_relay(engine, xy[idx], region.floor_z, los, min_seen)
    return ok


# ----------------------------------------------------------------------------- placement
def _inside(x: float, y: float, rects, pad: float = 0.0) -> bool:
    return any(r[0] + pad <= x <= r[2] - pad and r[1] + pad <= y <= r[3] - pad for r in rects)


def _near(x: float, y: float, rects, pad: float) -> bool:
    return any(r[0] - pad < x < r[2] + pad and r[1] - pad < y < r[3] + pad for r in rects)


def _overlap(a, b, pad: float = 0.0) -> bool:
    return a[0] < b[2] + pad and b[0] < a[2] + pad and a[1] < b[3] + pad and b[1] < a[3] + pad


def tripod(rng: np.random.Generator, lay, cfg) -> tuple[Camera, Projector] | None:
    """Camera on a tripod in the layout's camera zone looking at the relay wall near the hidden
    region; the projector beside it (0.15-0.6 m to one side, a little lower or higher)."""
    from ..scene.format import Projector

    x0, y0, x1, y1 = lay.camera_zone
    if x1 <= x0 or y1 <= y0:
        return None
    foot = [r for r, _ in lay.footprints]
    for _ in range(25):
        x, y = rng.uniform(x0, x1), rng.uniform(y0, y1)
        if _near(x, y, foot, 0.45) or _near(x, y, lay.keepout, 0.2):
            continue
        h = rng.uniform(*cfg.camera_height_range)
        target = lay.target(rng)
        cam = Camera(np.array([x, y, h]), target, np.array([0.0, 0.0, 1.0]), float(rng.uniform(*cfg.fov_range)),
                     cfg.resolution, cfg.height or cfg.resolution)
        fwd = target - cam.position
        fwd_h = np.array([fwd[0], fwd[1], 0.0]) / np.hypot(fwd[0], fwd[1])
        right = np.array([fwd_h[1], -fwd_h[0], 0.0])
        side = 1.0 if rng.uniform() < 0.5 else -1.0
        off = rng.uniform(*cfg.projector_offset_range)
        p = cam.position + side * off * right + rng.uniform(-0.1, 0.1) * fwd_h + [0, 0, rng.uniform(-0.25, 0.1)]
        p[2] = float(np.clip(p[2], 1.0, 1.8))
        if not _inside(p[0], p[1], lay.camera_floor, 0.15) or _near(p[0], p[1], foot, 0.2):
            continue
        proj = Projector(p, np.asarray(cfg.projector_intensity, dtype=np.float64), cfg.beam_width_deg, cfg.cutoff_deg)
        return cam, proj
    return None


OCCLUDERS = {"office_chair": 2.0, "wooden_chair": 1.0, "plant": 2.0, "floor_lamp": 1.0, "coat_rack": 1.0,
             "bin": 0.5, "pillar": 0.6}
"""Free-standing occluders and their weights; a cluttered office adds desks and boxes, a home a dining table."""


def occluders(rng: np.random.Generator, lay, kit, cam: Camera, proj, count: int) -> list:
    """Free-standing pieces between the camera and the wall, beside the line of sight."""
    from . import furniture as F

    out = []
    c, t = cam.position[:2], cam.look_at[:2]
    axis = t - c
    dist = float(np.linalg.norm(axis))
    axis = axis / dist
    perp = np.array([-axis[1], axis[0]])
    table = dict(OCCLUDERS)
    if lay.family == "cluttered_office":
        table.update(desk=2.5, boxes=1.0)
    if lay.theme == "home":
        table.update(table=1.0)
    names = list(table)
    weights = np.array([table[n] for n in names])
    for _ in range(count):
        for _try in range(12):
            name = names[int(rng.choice(len(names), p=weights / weights.sum()))]
            f = rng.uniform(0.3, 0.75)
            lateral = rng.uniform(0.3, 0.9) * (1 if rng.uniform() < 0.5 else -1)
            xy = c + f * dist * axis + lateral * perp
            if np.linalg.norm(xy - c) < 0.7 or np.linalg.norm(xy - proj.position[:2]) < 0.6:
                continue
            if name == "pillar":
                parts = F.pillar(kit, lay.ceiling)
            elif name == "desk":  # a free-standing desk, centered on its own origin
                w, d = rng.uniform(1.1, 1.6), rng.uniform(0.6, 0.8)
                parts = F.place(F.desk(kit, w, d, monitor=kit.chance(0.8), chair=kit.chance(0.7)),
                                F.Frame.at(-w / 2, -d / 2, (1, 0), (0, 1)))
            elif name == "table":  # a dining table with chairs
                parts = F.table(kit, rng.uniform(0.9, 1.4), rng.uniform(0.7, 0.9), int(rng.integers(0, 3)))
            elif name == "boxes":
                parts = F.place(F.boxes(kit, 0.7, 0.5), F.Frame.at(-0.35, -0.25, (1, 0), (0, 1)))
            else:
                parts = F.FREE_STANDING[name](kit)
            parts = F.place(parts, F.Frame.yaw(xy[0], xy[1], rng.uniform(0, 2 * np.pi)), "occluder")
            x0, y0, x1, y1, top = F.footprint(parts)
            rect = (x0, y0, x1, y1)
            if not (_inside(x0, y0, lay.camera_floor, 0.1) and _inside(x1, y1, lay.camera_floor, 0.1)):
                continue
            if any(_overlap(rect, r, 0.05) for r in lay.keepout) or \
                    any(_overlap(rect, r, 0.05) for r, _ in lay.footprints):
                continue
            out.extend(parts)
            lay.footprints.append((rect, top))
            break
    return out


def find_region(engine: RayEngine, sources: list[np.ndarray], zone, anchor, rng: np.random.Generator,
                min_size: float = 3.0, max_size: float = 4.0, margin: float = 0.25, safety: float = 0.1,
                spacing: float = 0.1, blocked: list | None = None, los: LosPoints | None = None,
                distance=(0.6, 2.4), body_height: float = 1.9) -> HiddenRegion | None:
    """An axis-aligned rectangle (min_size..max_size a side; the upper size drawn per scene) inside
    ``zone`` whose points, grown by margin + safety, no source sees.

    Among the rectangles that fit, the one with the most floor where a person may stand (at an
    allowed distance from the camera-visible ``los`` points, off the ``blocked`` footprints) wins;
    ties go to the one nearest ``anchor`` (where light enters the hidden zone).
    """
    from scipy import ndimage

    x0, y0, x1, y1 = zone
    if x1 - x0 < min_size or y1 - y0 < min_size:
        return None
    pad = margin + safety + spacing
    gx = x0 - pad + spacing * np.arange(int(math.floor((x1 - x0 + 2 * pad) / spacing + 1e-9)) + 1)
    gy = y0 - pad + spacing * np.arange(int(math.floor((y1 - y0 + 2 * pad) / spacing + 1e-9)) + 1)
    xx, yy = np.meshgrid(gx, gy, indexing="ij")
    xy = np.stack([xx.ravel(), yy.ravel()], 1)
    pts = segment_points(xy, 0.0, (0.02, 0.5, 1.0, 1.5, 1.9))
    seen = np.zeros(len(pts), dtype=bool)
    for s in sources:
        seen |= visible(engine, s, pts)
    seen = seen.reshape(len(xy), -1).any(1).reshape(xx.shape)
    r = int(math.ceil((margin + safety) / spacing))
    disk = np.hypot(*np.mgrid[-r:r + 1, -r:r + 1]) <= r + 1e-9
    bad = ndimage.binary_dilation(seen, structure=disk)
    inside = (xx >= x0 - 1e-9) & (xx <= x1 + 1e-9) & (yy >= y0 - 1e-9) & (yy <= y1 + 1e-9)
    allowed = ~bad & inside
    good = allowed.copy()
    for (bx0, by0, bx1, by1), _ in (blocked or []):
        good &= ~((xx > bx0 - 0.3) & (xx < bx1 + 0.3) & (yy > by0 - 0.3) & (yy < by1 + 0.3))
    if los is not None and good.any():  # distances on every other grid point (the choice is a heuristic)
        cx, cy = xx[::2, ::2], yy[::2, ::2]
        d = los_distance(np.stack([cx.ravel(), cy.ravel()], 1), 0.0, los, body_height, distance[1]).reshape(cx.shape)
        d = np.repeat(np.repeat(d, 2, 0), 2, 1)[:xx.shape[0], :xx.shape[1]]
        good &= (d >= distance[0]) & (d <= distance[1])
    sat = np.pad(allowed.astype(np.int32).cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    sat_good = np.pad(good.astype(np.int32).cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    nmin = int(math.ceil(min_size / spacing - 1e-9))
    nmax_x = min(int(round(rng.uniform(min_size, max_size) / spacing)), allowed.shape[0] - 1)
    nmax_y = min(int(round(rng.uniform(min_size, max_size) / spacing)), allowed.shape[1] - 1)
    sizes = {(a, b) for a in range(nmin, nmax_x + 1, 2) for b in range(nmin, nmax_y + 1, 2)} | {(nmin, nmin)}
    ax, ay = anchor
    best, best_score = None, -np.inf
    total_good = max(1, int(good.sum()))
    for a, b in sorted(sizes):
        if a >= allowed.shape[0] or b >= allowed.shape[1]:
            continue
        cnt = sat[a + 1:, b + 1:] - sat[:-a - 1, b + 1:] - sat[a + 1:, :-b - 1] + sat[:-a - 1, :-b - 1]
        i, j = np.nonzero(cnt == (a + 1) * (b + 1))
        if len(i) == 0:
            continue
        n_good = sat_good[i + a + 1, j + b + 1] - sat_good[i, j + b + 1] - sat_good[i + a + 1, j] + sat_good[i, j]
        frac = n_good / ((a + 1) * (b + 1))
        dx = np.maximum(0, np.maximum(gx[i] - ax, ax - gx[i + a]))
        dy = np.maximum(0, np.maximum(gy[j] - ay, ay - gy[j + b]))
        score = n_good / total_good + 0.5 * frac - 0.02 * np.hypot(dx, dy) + 0.01 * a * b * spacing ** 2
        k = int(np.argmax(score))
        if score[k] > best_score:
            best_score = score[k]
            best = (gx[i[k]], gy[j[k]], max(a * spacing, min_size + 1e-9), max(b * spacing, min_size + 1e-9))
    if best is None:
        return None
    rx, ry, w, h = best
    return HiddenRegion(np.array([rx, ry]), np.array([rx + w, ry + h]), 0.0)
