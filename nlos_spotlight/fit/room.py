"""A user's room as an ``nlos-scene/1`` scene: geometry, materials, camera, projector, hidden region.

The room comes from a scene directory (its camera, projector, hidden region and materials, each
overridable by flags) or a bare scan (PLY/OBJ, meters, any up axis). A bare scan is read as
``nlos spotlight`` reads it (``scene.setup.load_setup``: cleaned, turned z up by the smallest
rotation, camera and projector from flags or derived defaults), and given:

* **materials**: its face or vertex colors, sRGB-decoded, as diffuse albedo (clipped to
  :data:`ALBEDO_RANGE`: a scan's colors carry its lighting, and no wall is black or a perfect
  white); without colors, :data:`DEFAULT_ALBEDO` gray (painted plaster);
* **light**: the paper's projector (4000 lm into a 3-degree spot, ``world.calibration``) and a
  dim room: :data:`AMBIENT_LUX` on the walls the camera sees, :data:`HIDDEN_LUX` in the hidden area
  (the geometric middles of the synthetic rooms' ranges);
* **the hidden region**: ``--hidden-region`` (floor x, y in the z-up frame) or, when missing, the
  largest hidden floor rectangle where a person may stand (:func:`default_region`; printed, like
  every other default). Its floor height is the scan's floor (:func:`floor_height`).

Whatever its source, the hidden region is checked by ray casting (:func:`check_hidden`): a person up
to 1.9 m tall and 0.25 m around, anywhere in the region, must not be in the photograph (outside
the camera's view or behind geometry) nor in the projector's beam toward any surface the camera
sees. A region that is not is refused with how much of it each reaches. The synthetic rooms use a
stricter rule (walls hide the region from the tripod whatever the view); scanned rooms rarely
have a wall or partition tall enough between a tripod and free floor (none of the three scans in
``../shared/data/real-scans`` does), while what the physics needs is only that the person is out
of the picture and out of the beam.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import NlosError
from ..scene.format import Ambient, Camera, HiddenRegion, Material, Projector, Scene, Shape, TriMesh

ALBEDO_RANGE = (0.03, 0.9)
"""Diffuse albedo a scan's decoded color is clipped to."""
DEFAULT_ALBEDO = 0.6
"""Diffuse albedo of a scan without colors (painted plaster, gray)."""
AMBIENT_LUX = 9.0
"""Illuminance of the camera-visible walls from room light, lux (synthetic rooms: 2-40)."""
HIDDEN_LUX = 0.45
"""Illuminance in the hidden area, lux (synthetic rooms: 0.1-2)."""
MAX_VISIBLE_FRACTION = 0.01
"""Largest fraction of the hidden check's points the camera or projector may see (stray rays
through a scan's holes); more is refused."""
MIN_REGION_SIDE_M = 1.2
"""Smallest side of a default hidden region, m (a person and room to move)."""
MIN_STANDABLE_FRACTION = 0.02
"""Smallest fraction of any hidden region where a person may stand."""
MIN_VALID_FRACTION = 0.15
"""Smallest fraction of a default hidden region where a person may stand (synthetic rooms: the same)."""


@dataclass
class RoomSetup:
    """The scene of a fit and where each of its parts came from (printed and saved)."""

    scene: Scene
    """The room (no person), camera at the fit's resolution."""
    sources: dict = field(default_factory=dict)
    """Part -> 'scene', 'flags' or 'default' (camera, projector, hidden_region, materials)."""
    file_to_world: np.ndarray = field(default_factory=lambda: np.eye(4))
    """(4, 4) from the input file's coordinates to the scene's (z up)."""
    hidden: dict = field(default_factory=dict)
    """The hidden check: points, seen_by_camera, seen_by_projector."""


def parse_region(text: str) -> tuple[np.ndarray, np.ndarray]:
    """``XMIN,YMIN,XMAX,YMAX`` (m) -> (min (2,), max (2,))."""
    from ..args import parse_numbers

    v = parse_numbers(text, "XMIN,YMIN,XMAX,YMAX", "--hidden-region")
    lo, hi = v[:2], v[2:]
    if np.any(hi <= lo):
        raise NlosError(f"--hidden-region: XMAX must exceed XMIN and YMAX exceed YMIN, got {text!r}")
    if np.any(hi - lo > 50):
        raise NlosError(f"--hidden-region: {text!r} is more than 50 m a side (meters expected)")
    return lo, hi


def scan_materials(mesh: TriMesh) -> tuple[Material, TriMesh, str]:
    """Material and mesh (with albedo colors) of a bare scan; the last item says which rule applied."""
    from ..render.color import srgb_to_linear

    lo, hi = ALBEDO_RANGE
    if mesh.face_colors is not None or mesh.vertex_colors is not None:
        fc = None if mesh.face_colors is None else np.clip(srgb_to_linear(mesh.face_colors), lo, hi)
        vc = None if mesh.vertex_colors is None else np.clip(srgb_to_linear(mesh.vertex_colors), lo, hi)
        rule = f"{'face' if fc is not None else 'vertex'} colors, sRGB-decoded, clipped to {lo}-{hi}"
        return Material(np.ones(3)), TriMesh(mesh.vertices, mesh.faces, vc, fc), rule
    return Material(np.full(3, DEFAULT_ALBEDO)), mesh, f"no colors: gray albedo {DEFAULT_ALBEDO}"


def floor_height(mesh: TriMesh) -> float:
    """z of the floor of a z-up room: the area-weighted 5th percentile height of upward faces
    (the lowest large horizontal surface; ignores stray fragments below it)."""
    n, a, c = mesh.face_normals(), mesh.face_areas(), mesh.centroids()
    up = (np.abs(n[:, 2]) > 0.9) & (a > 0)
    if not up.any():
        return float(np.quantile(mesh.vertices[:, 2], 0.01))
    z, w = c[up, 2], a[up]
    order = np.argsort(z)
    cum = np.cumsum(w[order]) / w.sum()
    return float(z[order][np.searchsorted(cum, 0.05)])


def seen_by(engine, camera: Camera, projector: Projector, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N,) bool each: the camera photographs the point (inside its view, nothing between), and the
    projector's beam can light it (nothing between, and within the beam's cutoff of the direction to
    some surface point the camera sees: every spot candidate lies there, closer than the point)."""
    from ..render.camera import project
    from ..world.placement import los_points, visible

    rc = project(camera, points)
    inside = np.isfinite(rc).all(1) & (rc[:, 0] >= 0) & (rc[:, 0] <= camera.height) & (rc[:, 1] >= 0) \
        & (rc[:, 1] <= camera.width)
    cam = inside & visible(engine, camera.position, points)
    los = los_points(engine, camera, 48).pos
    d_los = los - projector.position
    r_los = np.linalg.norm(d_los, axis=1)
    d = points - projector.position
    r = np.linalg.norm(d, axis=1)
    cos = (d @ d_los.T) / np.maximum(r[:, None] * r_los[None], 1e-12)  # (N, L)
    in_beam = ((cos >= np.cos(np.radians(projector.cutoff_deg))) & (r[:, None] < r_los[None])).any(1)
    proj = in_beam & visible(engine, projector.position, points)
    return cam, proj


def check_hidden(engine, camera: Camera, projector: Projector, region: HiddenRegion) -> dict:
    """The hidden check (module docstring): a region the camera photographs or the beam can light
    is refused with how much of it each reaches."""
    from ..world.placement import region_grid, segment_points

    pts = segment_points(region_grid(region, 0.1, 0.25), region.floor_z)
    cam, proj = seen_by(engine, camera, projector, pts)
    rec = {"points": int(len(pts)), "seen_by_camera": int(cam.sum()), "seen_by_projector": int(proj.sum()),
           "rule": "not photographed by the camera (outside its view or behind geometry) and not in the "
                   "projector's beam toward any surface the camera sees; person 0-1.9 m tall, 0.25 m around"}
    if max(cam.mean(), proj.mean()) > MAX_VISIBLE_FRACTION:
        raise NlosError(
            f"hidden region {region.min.tolist()}-{region.max.tolist()} is not hidden: the camera photographs "
            f"{100 * cam.mean():.1f}% and the projector's beam can reach {100 * proj.mean():.1f}% of its check "
            "points (person 0-1.9 m tall, 0.25 m around); move it out of the camera's view")
    return rec


NEAR_WALL_M = 0.75
"""A camera whose view is mostly nearer than this faces a wall, not a room."""


def camera_hits(engine, camera: Camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(camera origin (3,), faces (K,), points (K, 3)) of what the camera's pixel centres see."""
    from ..render.camera import pixel_rays

    dirs, origin = pixel_rays(camera, 1)
    dirs = dirs.reshape(-1, 3)
    hits = engine.first_hit(np.broadcast_to(origin, dirs.shape).copy(), dirs)
    face = hits.face[hits.hit]
    return origin, face, engine.surface_point(face, hits.bary[hits.hit])


def view_depth(engine, camera: Camera) -> float:
    """Median distance (m) to what the camera's pixels see (infinity if they see nothing)."""
    origin, _, pts = camera_hits(engine, camera)
    return float(np.median(np.linalg.norm(pts - origin, axis=1))) if len(pts) else float("inf")


def check_camera_inside(mesh, camera: Camera, margin: float = 0.05) -> None:
    """Refuse a camera outside the scan's extent: it would photograph the outside of the walls, and
    the hidden-region search would be blamed for it."""
    lo, hi = mesh.vertices.min(0) - margin, mesh.vertices.max(0) + margin
    pos = np.asarray(camera.position, np.float64)
    if (pos < lo).any() or (pos > hi).any():
        box = ", ".join(f"{a} {lo[i] + margin:.2f}..{hi[i] - margin:.2f}" for i, a in enumerate("xyz"))
        raise NlosError(f"camera at {np.round(pos, 3).tolist()}: outside the scanned room ({box} m), behind its "
                        "walls; place it inside (--camera-position)")


def check_projector_sees(engine, camera: Camera, position: np.ndarray) -> None:
    """Refuse a projector that can light none of what the camera photographs (every spot's
    light would be invisible: the fit would train on blank photographs)."""
    origin, face, pts = camera_hits(engine, camera)
    if len(pts) == 0:
        return  # the camera check names this
    tri = engine.vertices[engine.faces[face]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    same_side = np.einsum("ij,ij->i", n, position - pts) * np.einsum("ij,ij->i", n, origin - pts) > 0
    seen = same_side & ~engine.occluded(np.broadcast_to(position, pts.shape).copy(), pts, None, n / np.maximum(
        np.linalg.norm(n, axis=1, keepdims=True), 1e-30) * np.sign(np.einsum("ij,ij->i", n, origin - pts))[:, None])
    if not seen.any():
        raise NlosError(f"projector at {np.round(position, 3).tolist()}: it reaches none of the surfaces the camera "
                        "photographs, so no spot would show; move it (--projector-position)")


def check_standable(scene: Scene, spacing: float = 0.1) -> float:
    """Fraction of the hidden region (a ``spacing`` grid) where a person may stand; a region with
    almost none is refused (people are placed there by rejection sampling)."""
    from ..world.placement import SceneGeometry

    hr = scene.hidden_region
    gx = np.arange(hr.min[0] + spacing / 2, hr.max[0], spacing)
    gy = np.arange(hr.min[1] + spacing / 2, hr.max[1], spacing)
    xy = np.stack(np.meshgrid(gx, gy, indexing="ij"), -1).reshape(-1, 2)
    frac = float(SceneGeometry(scene).valid_positions(xy, floor=True).mean()) if len(xy) else 0.0
    if frac < MIN_STANDABLE_FRACTION:
        raise NlosError(f"hidden region {hr.min.tolist()}-{hr.max.tolist()}: a person may stand on only "
                        f"{100 * frac:.1f}% of it (on the scan's floor, clear of furniture, 0.6-2.4 m from a surface "
                        "the camera sees, seeing it); move it or scan its floor")
    return frac


def default_region(scene: Scene, engine, max_side: float = 4.0, spacing: float = 0.1) -> HiddenRegion:
    """A floor rectangle (sides :data:`MIN_REGION_SIDE_M` to ``max_side``) whose every point is
    hidden (:func:`seen_by`, grown by 0.25 m), holding the most floor where a person may stand
    (``world.placement.valid_positions``: on the scan's floor, clear of furniture, 0.6-2.4 m from a
    surface the camera sees, seeing it), at least :data:`MIN_VALID_FRACTION` of it as in the synthetic rooms; ties go
    to the one nearest the camera's look-at point. People are placed on that floor only."""
    from scipy import ndimage

    from ..world.placement import SceneGeometry, segment_points

    mesh = scene.static_mesh()[0]
    floor_z = scene.hidden_region.floor_z
    v = mesh.vertices
    lo, hi = np.quantile(v[:, :2], 0.005, axis=0), np.quantile(v[:, :2], 0.995, axis=0)
    gx, gy = np.arange(lo[0], hi[0] + 1e-9, spacing), np.arange(lo[1], hi[1] + 1e-9, spacing)
    xx, yy = np.meshgrid(gx, gy, indexing="ij")
    xy = np.stack([xx.ravel(), yy.ravel()], 1)
    cam, proj = seen_by(engine, scene.camera, scene.projector, segment_points(xy, floor_z))
    seen = (cam | proj).reshape(len(xy), -1).any(1).reshape(xx.shape)
    r = int(np.ceil(0.25 / spacing))
    seen = ndimage.binary_dilation(seen, structure=np.hypot(*np.mgrid[-r:r + 1, -r:r + 1]) <= r + 1e-9)
    whole = HiddenRegion(lo - 1, hi + 1, floor_z)
    geo = SceneGeometry(Scene(scene.shapes, scene.materials, scene.camera, scene.projector, hidden_region=whole))
    allowed = ~seen
    valid = allowed.ravel().copy()
    idx = np.flatnonzero(valid)
    valid[idx] = geo.valid_positions(xy[idx], floor=True)
    valid = valid.reshape(xx.shape)
    sat = np.pad(allowed.astype(np.int32).cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    sat_v = np.pad(valid.astype(np.int32).cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    box = lambda t, a, b: t[a + 1:, b + 1:] - t[:-a - 1, b + 1:] - t[a + 1:, :-b - 1] + t[:-a - 1, :-b - 1]
    nmin, nmax = int(np.ceil(MIN_REGION_SIDE_M / spacing - 1e-9)), int(round(max_side / spacing))
    look = scene.camera.look_at[:2]
    best, best_key = None, None
    for a in range(nmin, min(nmax, allowed.shape[0] - 1) + 1):
        for b in range(nmin, min(nmax, allowed.shape[1] - 1) + 1):
            full = box(sat, a, b) == (a + 1) * (b + 1)
            n_valid = np.where(full, box(sat_v, a, b), 0)
            i, j = np.nonzero(full & (n_valid >= MIN_VALID_FRACTION * (a + 1) * (b + 1)))
            if len(i) == 0:
                continue
            d = np.hypot(gx[i] + a * spacing / 2 - look[0], gy[j] + b * spacing / 2 - look[1])
            keys = n_valid[i, j] - 1e-3 * d  # most floor to stand on; then nearest the light
            k = int(np.argmax(keys))
            if best_key is None or keys[k] > best_key:
                best, best_key = (gx[i[k]], gy[j[k]], a * spacing, b * spacing), keys[k]
    if best is None:
        depth = view_depth(engine, scene.camera)
        if depth == float("inf"):
            raise NlosError(f"camera at {np.round(scene.camera.position, 3).tolist()}: sees none of the scan; turn it "
                            "toward the room (--camera-look-at)")
        if depth < NEAR_WALL_M:  # the camera faces a wall: that, not the region, is what to change
            raise NlosError(f"camera at {np.round(scene.camera.position, 3).tolist()}: faces a surface a median "
                            f"{depth:.2f} m away (behind or against a wall?); move or turn it (--camera-position, "
                            "--camera-look-at)")
        raise NlosError(f"no floor area of at least {MIN_REGION_SIDE_M} m x {MIN_REGION_SIDE_M} m is out of the "
                        "camera's view and the projector's beam and free to stand in; give --hidden-region "
                        "XMIN,YMIN,XMAX,YMAX or turn the camera")
    x, y, w, h = best
    return HiddenRegion(np.array([x, y]), np.array([x + w, y + h]), floor_z)


def room_setup(source: str | Path, resolution: int, camera_position=None, camera_look_at=None,
               projector_position=None, hidden_region: str | None = None, up: str | None = None) -> RoomSetup:
    """The fit's scene from a scene directory or a bare scan (module docstring)."""
    from ..scene.setup import load_setup
    from ..scene.io import load_scene
    from ..world.calibration import PROJECTOR_INTENSITY, ambient_radiance_per_channel
    from ..world.rooms import RoomConfig

    setup = load_setup(source, camera_position, camera_look_at, projector_position, up)
    cam = setup.camera
    camera = Camera(cam.position, cam.look_at, cam.up, cam.fov_deg, resolution, resolution)
    sources = {"camera": setup.camera_source, "projector": setup.projector_source}
    if setup.kind == "scene":
        base = load_scene(setup.source)
        shapes, materials, ambient, sensor = base.shapes, base.materials, base.ambient, base.sensor
        proj = Projector(setup.projector, base.projector.intensity, base.projector.beam_width_deg,
                         base.projector.cutoff_deg)
        region, sources["materials"] = base.hidden_region, "scene"
        floor_z = region.floor_z if region is not None else floor_height(setup.mesh)
    else:
        material, mesh, rule = scan_materials(setup.mesh)
        shapes, materials, sensor = [Shape("scan.ply", "scan", mesh)], {"scan": material}, None
        rc = RoomConfig()
        proj = Projector(setup.projector, np.full(3, PROJECTOR_INTENSITY), rc.beam_width_deg, rc.cutoff_deg)
        ambient = Ambient(np.full(3, ambient_radiance_per_channel(AMBIENT_LUX)),
                          np.full(3, ambient_radiance_per_channel(HIDDEN_LUX)))
        region, sources["materials"] = None, rule
        floor_z = floor_height(setup.mesh)
    if hidden_region is not None:
        lo, hi = parse_region(hidden_region)
        region, sources["hidden_region"] = HiddenRegion(lo, hi, floor_z), "flags"
    elif region is not None:
        sources["hidden_region"] = "scene"
    scene = Scene(list(shapes), dict(materials), camera, proj, ambient=ambient, hidden_region=region, sensor=sensor)
    check_camera_inside(setup.mesh, camera)
    if region is None:
        scene.hidden_region = HiddenRegion(np.zeros(2), np.ones(2), floor_z)  # the floor height, for the search
        scene.hidden_region = default_region(scene, setup.engine)
        sources["hidden_region"] = "default"
    check_projector_sees(setup.engine, camera, proj.position)
    hidden = check_hidden(setup.engine, camera, proj, scene.hidden_region)
    hidden["standable_fraction"] = check_standable(scene)
    return RoomSetup(scene, sources, setup.file_to_world, hidden)
