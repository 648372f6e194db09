"""Procedural indoor scenes at real scale (DESIGN section 7), written as ``nlos-scene/1`` scenes.

``generate_room(seed, cfg)`` draws a layout family, builds its shell (:mod:`.layouts`), furnishes
it (:mod:`.furnish`, :mod:`.furniture`, materials from :mod:`.materials`), sets up the camera and
projector as a person would and puts occluders in front of them, then finds a hidden region of at
least 3 m x 3 m and checks it by ray casting (:mod:`.placement`): no point of a 0.25 m-radius,
1.9 m-tall person anywhere in it is visible from the camera or the projector, while from the
region a good fraction of the camera-visible surfaces is visible (light can go wall -> person ->
wall). A layout that fails is redrawn. Everything is deterministic in the seed.

The generated scene has no person (``scene.human is None``); :func:`person_positions` samples
where one may stand.
"""

from __future__ import annotations

import dataclasses
import math
import time
import weakref
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from ..errors import NlosError
from ..render.rays import RayEngine
from ..scene.format import Ambient, Camera, HiddenRegion, Projector, Scene, Shape, TriMesh
from .calibration import AMBIENT_LUX, HIDDEN_LUX, PROJECTOR_INTENSITY, ambient_radiance_per_channel
from .furnish import furnish
from .furniture import Kit, Part
from .geometry import merge, transform
from .layouts import FAMILY_BUILDERS
from .materials import Palette, quantize_colors
from .placement import (SceneGeometry, find_region, hidden_check, los_points, occluders, relay_check, thin, tripod,
                        valid_positions)

LOS_GRID = 96
"""Camera rays per side for the camera-visible points that person distances are measured to."""

FAMILIES: tuple[str, ...] = ("l_corner", "doorway", "corridor_junction", "partitioned_room", "cluttered_office")
"""The layout families."""


@dataclass
class RoomConfig:
    """Everything that shapes a generated room (with the seed)."""

    families: list[str] = field(default_factory=list)
    """Layout families to draw from (empty: all of FAMILIES)."""
    family_weights: dict[str, float] = field(default_factory=dict)
    """Relative probability of each family among ``families`` (missing: 1)."""
    resolution: int = 64
    """Camera image width, pixels."""
    height: int = 0
    """Camera image height, pixels (0: same as resolution)."""
    fov_range: tuple[float, float] = (40.0, 60.0)
    """Horizontal field of view range, degrees."""
    camera_height_range: tuple[float, float] = (1.1, 1.7)
    """Tripod height range of the camera, m."""
    camera_distance_range: tuple[float, float] = (1.5, 4.0)
    """Distance range from the camera to the main relay wall, m."""
    projector_offset_range: tuple[float, float] = (0.15, 0.6)
    """How far beside the camera the projector stands, m."""
    projector_intensity: tuple[float, float, float] = (PROJECTOR_INTENSITY,) * 3
    """Projector radiant intensity on the axis per channel, W/sr (4000 lm: ``world.calibration``)."""
    beam_width_deg: float = 3.0
    """Spot half-angle of full intensity, degrees (to be calibrated)."""
    cutoff_deg: float = 5.0
    """Spot half-angle where the light ends, degrees (to be calibrated)."""
    ambient_radiance_range: tuple[float, float] = tuple(ambient_radiance_per_channel(v) for v in AMBIENT_LUX)
    """Range of the ambient radiance on the LOS surfaces per channel (``AMBIENT_LUX``), drawn log-uniformly."""
    hidden_radiance_range: tuple[float, float] = tuple(ambient_radiance_per_channel(v) for v in HIDDEN_LUX)
    """Range of the hidden region's ambient radiance per channel (``HIDDEN_LUX``), drawn log-uniformly."""
    furniture_density: float = 1.0
    """How full the walls get (0: bare shells; 1: typical; 2: crowded)."""
    occluder_count: tuple[int, int] = (1, 3)
    """Range of free-standing occluders (chairs, plants, pillars, coat racks...) in front of the camera."""
    max_occluded_fraction: float = 0.35
    """Largest fraction of the camera's view the occluders may cover."""
    texture: bool = True
    """Vertex-color textures (wood grain, planks, wallpaper, posters, book spines)."""
    cell_size: float = 0.4
    """Largest cell of the wall and floor meshes, m (sets the face count)."""
    min_hidden_size: float = 3.0
    """Smallest side of the hidden region, m."""
    max_hidden_size: float = 4.0
    """Largest side of the hidden region, m (the upper size is drawn per scene)."""
    body_radius: float = 0.25
    """Radius of the person for the hidden check (the region is grown by it), m."""
    body_height: float = 1.9
    """Tallest person, m."""
    min_relay_fraction: float = 0.05
    """Smallest mean fraction of camera-visible LOS points seen from the hidden region."""
    min_valid_fraction: float = 0.15
    """Smallest fraction of the hidden region where a person may stand (LOS distance and no collision)."""
    los_distance_range: tuple[float, float] = (0.6, 2.4)
    """Person to nearest camera-visible LOS surface, m (2-8 ft)."""
    min_seen_fraction: float = 0.02
    """A valid person position sees at least this fraction of the camera-visible LOS points."""
    max_attempts: int = 40
    """Layouts drawn before giving up."""

    def __post_init__(self):
        for f in self.families:
            if f not in FAMILIES:
                raise NlosError(f"room config: unknown family '{f}' (choose from {', '.join(FAMILIES)})")
        for f, w in self.family_weights.items():
            if f not in FAMILIES or not (w >= 0 and math.isfinite(w)):
                raise NlosError(f"room config: bad family weight {f}={w}")
        if self.resolution < 1 or self.height < 0:
            raise NlosError("room config: resolution must be at least 1")
        if self.min_hidden_size <= 0 or self.max_hidden_size < self.min_hidden_size:
            raise NlosError("room config: need 0 < min_hidden_size <= max_hidden_size")


@dataclass
class Room:
    """A generated room."""

    scene: Scene
    """The ``nlos-scene/1`` scene (no person)."""
    family: str
    """Its layout family."""
    seed: int
    """The seed it was generated from."""
    relay_faces: np.ndarray
    """(K,) sorted indices of the static faces the camera sees."""
    kinds: list[str]
    """What each shape is ('wall', 'fridge', 'whiteboard', ...), aligned with ``scene.shapes``."""
    aim_point: np.ndarray
    """(3,) a camera- and projector-visible point at the center of the relay area (well seen from the region)."""
    aim_face: int
    """The static face holding ``aim_point``."""
    stats: dict = field(default_factory=dict)
    """Face count, region size, check results, attempts and rejection reasons, generation time."""


def _family(rng: np.random.Generator, cfg: RoomConfig) -> str:
    fams = list(cfg.families) or list(FAMILIES)
    w = np.array([cfg.family_weights.get(f, 1.0) for f in fams], dtype=np.float64)
    if w.sum() <= 0:
        raise NlosError("room config: family weights sum to zero")
    return fams[int(rng.choice(len(fams), p=w / w.sum()))]


def _engine(parts: list[Part]) -> tuple[RayEngine, np.ndarray]:
    m = merge([p.mesh for p in parts])
    owner = np.concatenate([np.full(len(p.mesh.faces), i) for i, p in enumerate(parts)])
    return RayEngine(m.vertices, m.faces), owner


def _view_ok(engine: RayEngine, owner: np.ndarray, parts: list[Part], cam: Camera, proj: Projector,
             cfg: RoomConfig) -> str | None:
    """None when the camera's view is sensible; else why not."""
    los = los_points(engine, cam, 24)
    if len(los.face) < 0.9 * 24 * max(1, round(24 * cam.height / cam.width)):
        return "view_leaks"
    roles = np.array([parts[i].role for i in owner[los.face]])
    if (roles == "occluder").mean() > cfg.max_occluded_fraction:
        return "occluded_view"
    if (roles != "shell").mean() < 0.04:  # the camera must see some furniture or occluders (non-planar LOS)
        return "bare_view"
    d = cam.look_at - cam.position
    h = engine.first_hit(cam.position[None], (d / np.linalg.norm(d))[None])
    if not h.hit[0] or parts[owner[h.face[0]]].role == "occluder" or h.t[0] < 0.8:
        return "target_blocked"
    if engine.occluded(cam.position[None], proj.position[None])[0]:
        return "projector_blocked"
    return None


def generate_room(seed: int, cfg: RoomConfig | None = None) -> Room:
    """A procedural room, deterministic in ``seed`` (numpy Generator from it)."""
    cfg = cfg or RoomConfig()
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    family = _family(rng, cfg)
    reasons: Counter = Counter()
    for attempt in range(cfg.max_attempts):
        kit = Kit(rng, Palette(rng), cfg.texture, cfg.cell_size)
        lay = FAMILY_BUILDERS[family](kit)
        x0, y0, x1, y1 = lay.camera_zone
        lay.camera_zone = (x0, max(y0, cfg.camera_distance_range[0]), x1, min(y1, cfg.camera_distance_range[1]))
        furnish(lay, kit, cfg.furniture_density)
        for _ in range(4):
            placed = tripod(rng, lay, cfg)
            if placed is None:
                reasons["no_tripod_spot"] += 1
                continue
            cam, proj = placed
            saved = list(lay.footprints)
            n_occ = int(rng.integers(cfg.occluder_count[0], cfg.occluder_count[1] + 1))
            if family == "cluttered_office":
                n_occ += 1
            parts = lay.parts + occluders(rng, lay, kit, cam, proj, n_occ)
            engine, owner = _engine(parts)
            why = _view_ok(engine, owner, parts, cam, proj, cfg)
            if why is None:
                why, result = _hidden_and_relay(engine, lay, cam, proj, rng, cfg, saved)
            if why is not None:
                reasons[why] += 1
                lay.footprints = saved
                continue
            region, hc, rc, valid = result
            room = _finish(rng, family, seed, kit.pal, parts, cam, proj, region, cfg)
            room.stats.update(attempts=attempt + 1, rejected=dict(reasons), hidden_check_points=hc.points,
                              hidden_seen=hc.seen_by_camera + hc.seen_by_projector,
                              relay_mean_fraction=rc.mean_fraction, relay_low_fraction=rc.low_fraction,
                              relay_seen_anything=rc.seen_anything, valid_fraction=valid,
                              camera_wall_distance=float(cam.position[1]),  # the main relay wall is y = 0 here
                              seconds=time.perf_counter() - t0)
            return room
    raise NlosError(f"room generator: no valid {family} layout in {cfg.max_attempts} attempts (seed {seed}; "
                    f"rejections {dict(reasons)})")


def _hidden_and_relay(engine, lay, cam, proj, rng, cfg: RoomConfig, furniture_footprints):
    los = los_points(engine, cam, 32)  # for the relay check
    fine = thin(los_points(engine, cam, LOS_GRID))  # for distances to the LOS surface (grazing floors need density)
    region = find_region(engine, [cam.position, proj.position], lay.hidden_zone, lay.anchor, rng,
                         cfg.min_hidden_size, cfg.max_hidden_size, cfg.body_radius, blocked=furniture_footprints,
                         los=thin(fine, 0.1), distance=cfg.los_distance_range, body_height=cfg.body_height)
    if region is None:
        return "no_hidden_region", None
    hc = hidden_check(engine, {"camera": cam.position, "projector": proj.position}, region, cfg.body_radius,
                      spacing=0.1, rng=rng)
    if not hc.ok:
        return "hidden_check", None
    rc = relay_check(engine, los, region)
    if rc.mean_fraction < cfg.min_relay_fraction or rc.seen_anything < 0.75:
        return "relay_check", None
    gx, gy = np.meshgrid(np.linspace(region.min[0], region.max[0], 16), np.linspace(region.min[1], region.max[1], 16),
                         indexing="ij")
    xy = np.stack([gx.ravel(), gy.ravel()], 1)
    valid = float(valid_positions(engine, fine, region, xy, cfg.los_distance_range, 0.3, cfg.body_height,
                                  cfg.min_seen_fraction).mean())
    if valid < cfg.min_valid_fraction:
        return "few_valid_positions", None
    return None, (region, hc, rc, valid)


# ---------------------------------------------------------------------------------- assembly
def _finish(rng, family, seed, pal: Palette, parts: list[Part], cam: Camera, proj: Projector, region: HiddenRegion,
            cfg: RoomConfig) -> Room:
    """Turn and mirror the room (multiples of 90 degrees), group parts into shapes, add ambient light."""
    k = int(rng.integers(4))
    c, s = [(1, 0), (0, 1), (-1, 0), (0, -1)][k]
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=np.float64)
    if rng.uniform() < 0.5:
        rot = rot @ np.diag([-1.0, 1.0, 1.0])
    groups: dict[tuple[str, str], list[TriMesh]] = {}
    for p in parts:
        groups.setdefault((p.kind, p.material), []).append(transform(p.mesh, rot, np.zeros(3)))
    shapes, kinds, count = [], [], Counter()
    for (kind, mat), meshes in groups.items():
        m = merge(meshes)
        m.vertices = m.vertices.astype(np.float32).astype(np.float64)  # what a PLY file holds: exact round trip
        if cfg.texture and m.vertex_colors is not None and not np.allclose(m.vertex_colors, 1.0):
            m.vertex_colors = quantize_colors(m.vertex_colors)
        else:
            m.vertex_colors = None
        shapes.append(Shape(f"{kind}_{count[kind]:02d}.ply", mat, m))
        kinds.append(kind)
        count[kind] += 1
    used = {s.material for s in shapes}
    materials = {n: m for n, m in pal.materials.items() if n in used}
    cam2 = Camera(rot @ cam.position, rot @ cam.look_at, cam.up.copy(), cam.fov_deg, cam.width, cam.height)
    proj2 = Projector(rot @ proj.position, proj.intensity.copy(), proj.beam_width_deg, proj.cutoff_deg)
    corners = np.array([[region.min[0], region.min[1], 0], [region.max[0], region.max[1], 0]]) @ rot.T
    region2 = HiddenRegion(corners[:, :2].min(0), corners[:, :2].max(0), region.floor_z)
    amb = Ambient(_ambient(rng, cfg.ambient_radiance_range), _ambient(rng, cfg.hidden_radiance_range))
    scene = Scene(shapes, materials, cam2, proj2, ambient=amb, hidden_region=region2)
    geo = SceneGeometry(scene, los_n=32)
    aim, face = _aim(geo, region2)
    relay_faces = np.union1d(los_points(geo.engine, cam2, max(64, 2 * cam.width)).face, [face])
    lo, hi = region2.min, region2.max
    stats = {"faces": scene.num_faces, "shapes": len(shapes), "materials": len(materials),
             "hidden_size": (float(hi[0] - lo[0]), float(hi[1] - lo[1])), "relay_faces": int(len(relay_faces))}
    return Room(scene, family, int(seed), relay_faces, kinds, aim, face, stats)


def _ambient(rng: np.random.Generator, r: tuple[float, float]) -> np.ndarray:
    level = math.exp(rng.uniform(math.log(r[0]), math.log(r[1])))
    tint = 1 + rng.uniform(-0.08, 0.08) * np.array([1.0, 0.0, -1.0])  # warm to cool
    return level * tint


def _aim(geo: SceneGeometry, region: HiddenRegion) -> tuple[np.ndarray, int]:
    """The score-weighted center of the LOS points best seen from the region and lit by the projector."""
    rc = relay_check(geo.engine, geo.los, region, n=4, heights=(0.5, 1.2))
    score = rc.point_score
    lit = ~geo.engine.occluded(np.broadcast_to(geo.scene.projector.position, geo.los.pos.shape).copy(), geo.los.pos,
                               None, geo.los.normal)
    ceiling = (np.abs(geo.los.normal[:, 2]) > 0.9) & (geo.los.pos[:, 2] > region.floor_z + 2.0)
    score = np.where(lit & ~ceiling, score, 0.0)  # a spot on the ceiling is allowed, but not as the center
    if score.max() <= 0:
        i = int(np.argmin(np.linalg.norm(geo.los.pos - geo.scene.camera.look_at, axis=1)))
        return geo.los.pos[i].copy(), int(geo.los.face[i])
    good = score >= 0.5 * score.max()
    center = (geo.los.pos[good] * score[good, None]).sum(0) / score[good].sum()
    cand = np.flatnonzero(good)
    i = cand[int(np.argmin(np.linalg.norm(geo.los.pos[cand] - center, axis=1)))]
    return geo.los.pos[i].copy(), int(geo.los.face[i])


# ---------------------------------------------------------------------------------- people
_GEOMETRY: dict[int, tuple[weakref.ref, SceneGeometry]] = {}


def scene_geometry(scene: Scene) -> SceneGeometry:
    """Ray engine and camera-visible points of ``scene`` (cached while the scene object lives)."""
    hit = _GEOMETRY.get(id(scene))
    if hit is not None and hit[0]() is scene:
        return hit[1]
    geo = SceneGeometry(scene, LOS_GRID)
    for key in [k for k, (ref, _) in _GEOMETRY.items() if ref() is None]:
        del _GEOMETRY[key]
    _GEOMETRY[id(scene)] = (weakref.ref(scene), geo)
    return geo


def person_positions(scene: Scene, rng: np.random.Generator, n: int, distance_range: tuple[float, float] = (0.6, 2.4),
                     radius: float = 0.3, body_height: float = 1.9, min_seen: float = 0.02,
                     floor: bool = False) -> np.ndarray:
    """(n, 2) floor positions drawn uniformly (rejection sampling) over the part of the hidden region
    where a person is ``distance_range`` (m) from the nearest camera-visible LOS surface facing them,
    a cylinder of ``radius`` around the body axis meets no static geometry, and the body sees at
    least ``min_seen`` of the camera-visible LOS points (so its light can reach the image); with
    ``floor``, on a floor (``world.placement.on_floor``: scanned rooms)."""
    if scene.hidden_region is None:
        raise NlosError("person_positions: the scene has no hidden_region")
    if n <= 0:
        return np.zeros((0, 2))
    geo = scene_geometry(scene)
    reg = scene.hidden_region
    out, tried = [], 0
    while sum(len(o) for o in out) < n:
        m = max(64, 3 * n)
        xy = rng.uniform(reg.min, reg.max, size=(m, 2))
        ok = geo.valid_positions(xy, distance_range, radius, body_height, min_seen, floor)
        out.append(xy[ok])
        tried += m
        if tried > 2000 * n + 20000 and sum(len(o) for o in out) == 0:
            raise NlosError("person_positions: no valid position in the hidden region "
                            f"(distance {distance_range[0]}-{distance_range[1]} m, radius {radius} m"
                            f"{', on a floor' if floor else ''})")
    return np.concatenate(out)[:n]


def room_config_from_dict(d: dict) -> RoomConfig:
    """A RoomConfig from plain values (lists become tuples where the field is a range)."""
    names = {f.name for f in dataclasses.fields(RoomConfig)}
    unknown = set(d) - names
    if unknown:
        raise NlosError(f"room config: unknown key '{sorted(unknown)[0]}'")
    return RoomConfig(**{k: tuple(v) if isinstance(v, list) and k.endswith(("range", "count", "intensity")) else v
                         for k, v in d.items()})


def _benchmark(argv: list[str] | None = None) -> None:
    """``python -m nlos_spotlight.world.rooms [--seeds N] [--families ...]``: generation time and stats per family."""
    import argparse

    ap = argparse.ArgumentParser(description="Generate rooms and report time and statistics per family.")
    ap.add_argument("--seeds", type=int, default=20, help="rooms per family (seeds 0..N-1)")
    ap.add_argument("--families", nargs="*", default=list(FAMILIES))
    ap.add_argument("--resolution", type=int, default=64)
    args = ap.parse_args(argv)
    generate_room(10_000, RoomConfig(resolution=args.resolution))  # warm up imports and caches
    print(f"{'family':18s} {'time s (mean/max)':>18s} {'faces (min-max)':>16s} {'region m (mean)':>16s} "
          f"{'attempts':>9s} {'accept':>7s} {'checks':>7s} {'relay':>6s} {'valid':>6s}  rejections")
    total = []
    for fam in args.families:
        rows, rej = [], Counter()
        for seed in range(args.seeds):
            t0 = time.perf_counter()
            room = generate_room(seed, RoomConfig(families=[fam], resolution=args.resolution))
            rows.append((time.perf_counter() - t0, room.stats))
            rej.update(room.stats["rejected"])
        t = np.array([r[0] for r in rows])
        total.extend(t)
        faces = [r[1]["faces"] for r in rows]
        size = np.mean([r[1]["hidden_size"] for r in rows], axis=0)
        accept = len(rows) / (len(rows) + sum(rej.values()))  # accepted / tried camera placements
        checks = np.mean([r[1]["hidden_check_points"] for r in rows])
        print(f"{fam:18s} {t.mean():8.2f} / {t.max():5.2f}    {min(faces):6d}-{max(faces):<6d} "
              f"{size[0]:7.2f} x {size[1]:4.2f}   {np.mean([r[1]['attempts'] for r in rows]):6.2f}  "
              f"{accept:6.2f} {checks:7.0f} {np.mean([r[1]['relay_mean_fraction'] for r in rows]):6.2f} "
              f"{np.mean([r[1]['valid_fraction'] for r in rows]):6.2f}  {dict(rej)}")
    print(f"all families: {np.mean(total):.2f} s per room (max {np.max(total):.2f} s) over {len(total)} rooms")


if __name__ == "__main__":
    _benchmark()
