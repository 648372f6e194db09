"""A room as the user set it up: its static geometry, the camera and the projector.

A scene directory gives its static shapes, camera and projector. A bare mesh (PLY/OBJ scan,
meters) is cleaned (``scene.clean``) and turned z up by the smallest rotation that takes its up
axis (``up``, else ``scene.orient.detect_up_axis``) to +z: no translation and no turn about the
vertical, so a scan that is already z up keeps its file's coordinates. The camera and projector
come from flags or from :func:`default_camera` (derived from the mesh bounds, printed so the user
can reproduce or override it). ``nlos spotlight`` and ``nlos fit`` both start here.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import NlosError
from ..render.camera import camera_frame, pixel_rays
from ..render.rays import RayEngine
from .format import Camera, Scene, TriMesh
from .io import load_scene
from .meshio import SUFFIXES
from .orient import fibonacci_sphere
from .scan import load_scan_z_up

DEFAULT_FOV_DEG = 60.0
"""Horizontal field of view of a camera built from flags or the default (a phone or APS-C zoom)."""
DEFAULT_TARGET_VERTICES = 800
"""LOS mesh size when the run's training dataset is unknown (the paper decimates to 500-1000)."""
VISIBILITY_WIDTH = 256
"""Minimum image width (pixels) of the rays that find the camera-visible faces."""
EYE_HEIGHT_M = 1.5
"""Default camera height above the floor (capped at 60% of the room height)."""
LOOK_HEIGHT_M = 1.0
"""Height of the default camera's look-at point (capped at 40% of the room height)."""
PROJECTOR_OFFSET_M = (0.3, -0.2)
"""Default projector position relative to the camera: 0.3 m to its right, 0.2 m lower."""
CLEARANCE_M = 0.3
"""A default camera position closer than this to any surface is penalized (inside furniture)."""


@dataclass
class RoomSetup:
    """A room as the user set it up: its geometry, the camera and the projector."""

    source: Path
    """The scene directory or mesh file."""
    kind: str
    """'scene' (nlos-scene/1 directory) or 'mesh' (bare PLY/OBJ)."""
    mesh: TriMesh
    """All static geometry, world frame (m, z up): it blocks the projector."""
    camera: Camera
    """The camera whose frame the IEN reads the mesh in."""
    camera_source: str
    """'scene', 'flags' or 'default' (derived from the mesh bounds)."""
    projector: np.ndarray
    """(3,) projector position, m."""
    projector_source: str
    """'scene', 'flags' or 'default' (beside the camera)."""
    file_to_world: np.ndarray = field(default_factory=lambda: np.eye(4))
    """(4, 4) from the mesh file's coordinates to ``mesh``'s (identity for scenes)."""
    engine: RayEngine = field(repr=False, default=None)
    """Embree scene over ``mesh``."""
    scene: Scene | None = field(repr=False, default=None)
    """The loaded ``Scene`` of a scene directory (its hidden region and walls: what an IEN trained
    with them reads, ``lighting.learned.ien_logits``); None for a bare mesh."""

    def __post_init__(self):
        if self.engine is None:
            self.engine = RayEngine(self.mesh.vertices, self.mesh.faces)


def _camera(position, look_at, up=(0.0, 0.0, 1.0), fov: float = DEFAULT_FOV_DEG,
            width: int = VISIBILITY_WIDTH, height: int = VISIBILITY_WIDTH * 3 // 4) -> Camera:
    """A validated camera (the scene format's checks: look_at != position, up not along the view)."""
    return Camera.from_dict({"position": [float(v) for v in position], "look_at": [float(v) for v in look_at],
                             "up": [float(v) for v in up], "fov_deg": float(fov), "width": int(width),
                             "height": int(height)})


def wall_yaw(mesh: TriMesh) -> float:
    """Heading (radians, modulo 90 degrees) of the walls of a z-up mesh: the area-weighted circular
    mean of 4 x the heading of the near-vertical faces' normals (walls meet at right angles)."""
    n, a = mesh.face_normals(), mesh.face_areas()
    wall = np.abs(n[:, 2]) < 0.3
    if not wall.any():
        return 0.0
    theta = np.arctan2(n[wall, 1], n[wall, 0])
    return float(np.arctan2((a[wall] * np.sin(4 * theta)).sum(), (a[wall] * np.cos(4 * theta)).sum()) / 4)


def default_camera(mesh: TriMesh, engine: RayEngine) -> Camera:
    """A camera pose for a z-up room mesh, derived from its bounds.

    The bounds are taken along the walls (turned by :func:`wall_yaw`), so a room that is not
    axis aligned in the file still gets its camera inside it. Candidates: for each horizontal wall
    axis and each end of it, the camera at eye height
    (:data:`EYE_HEIGHT_M`, at most 60% of the room height above the floor), centered across the
    room, max(90% of the room's extent, 2 m) from the opposite end, looking at that end's center
    at :data:`LOOK_HEIGHT_M`. Each candidate is scored by
    ``fraction of view rays that hit * median hit distance * min(clearance / CLEARANCE_M, 1)``
    (clearance: distance to the nearest surface in any direction), which prefers a long view down
    the room from a free spot; the best one wins (ties: first in x-, x+, y-, y+ order).
    Robust bounds (0.5% / 99.5% vertex quantiles) ignore stray scan fragments.
    """
    yaw = wall_yaw(mesh)
    turn = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    v = mesh.vertices @ turn  # wall-aligned coordinates; world = turn @ aligned
    lo, hi = np.quantile(v, 0.005, axis=0), np.quantile(v, 0.995, axis=0)
    height = max(hi[2] - lo[2], 1e-3)
    center = (lo + hi) / 2
    eye, look_z = lo[2] + min(EYE_HEIGHT_M, 0.6 * height), lo[2] + min(LOOK_HEIGHT_M, 0.4 * height)
    sphere = fibonacci_sphere(256)
    best, best_score = None, -1.0
    for axis in (0, 1):
        extent = hi[axis] - lo[axis]
        for side in (-1, 1):
            far = hi[axis] if side < 0 else lo[axis]
            pos, look = center.copy(), center.copy()
            pos[axis] = far + side * max(0.9 * extent, 2.0)
            pos[2], look[axis], look[2] = eye, far, look_z
            pos, look = turn @ pos, turn @ look
            cam = _camera(pos, look, width=64, height=48)
            dirs, origin = pixel_rays(cam, 1)
            flat = dirs.reshape(-1, 3)
            h = engine.first_hit(np.broadcast_to(origin, flat.shape), flat)
            if not h.hit.any():
                continue
            around = engine.first_hit(np.broadcast_to(pos, sphere.shape), sphere)
            clearance = float(around.t.min()) if around.hit.any() else np.inf
            score = h.hit.mean() * float(np.median(h.t[h.hit])) * min(clearance / CLEARANCE_M, 1.0)
            if score > best_score:
                best, best_score = (pos, look), score
    if best is None:
        raise NlosError("no default camera pose sees the mesh; give --camera-position and --camera-look-at")
    return _camera(*best)


def _projector_beside(camera: Camera) -> np.ndarray:
    _, right, _ = camera_frame(camera)
    return camera.position + PROJECTOR_OFFSET_M[0] * right + np.array([0.0, 0.0, PROJECTOR_OFFSET_M[1]])


ROOM_SPAN_M = 200.0
"""Largest extent a room is taken to have in meters: a scan over it is in other units."""


def check_room_units(mesh, path: Path) -> None:
    """Refuse a room whose extent says it is not in meters (a scan in millimetres or centimetres)."""
    span = float(np.ptp(mesh.vertices, axis=0).max())
    if span > ROOM_SPAN_M:
        mm = abs(np.log(span * 1e-3 / 6.0)) < abs(np.log(span * 1e-2 / 6.0))  # the unit that makes a ~6 m room
        hint = "millimetres? scale it by 0.001" if mm else "centimetres? scale it by 0.01"
        raise NlosError(f"{path}: the room spans {span:.0f} units; expected meters (a scan in {hint})")


def load_setup(path: str | Path, camera_position=None, camera_look_at=None, projector_position=None,
               up: str | None = None) -> RoomSetup:
    """Geometry, camera and projector from a scene directory or a bare mesh (module docstring).

    Args:
        path: an ``nlos-scene/1`` directory or a PLY/OBJ mesh (meters).
        camera_position, camera_look_at: (3,) override the camera pose (both or neither).
        projector_position: (3,) overrides the projector position.
        up: the bare mesh's up axis ('x', '-y', ...); None detects it.
    """
    path = Path(path)
    if (camera_position is None) != (camera_look_at is None):
        raise NlosError("--camera-position and --camera-look-at go together (give both or neither)")
    scene = None
    if path.is_dir():
        scene = load_scene(path)
        mesh, camera, cam_src = scene.static_mesh()[0], scene.camera, "scene"
        projector, proj_src, kind = scene.projector.position.copy(), "scene", "scene"
        file_to_world = np.eye(4)
        if up is not None:
            raise NlosError("--up applies to a bare mesh, not to a scene directory (scenes are z up)")
    elif path.is_file():
        if path.suffix.lower() not in SUFFIXES:
            raise NlosError(f"{path}: expected a scene directory or a .ply/.obj mesh")
        (mesh, file_to_world), kind = load_scan_z_up(path, up), "mesh"
        camera, cam_src, projector, proj_src = None, "default", None, "default"
    else:
        raise NlosError(f"{path}: no such scene directory or mesh file")
    check_room_units(mesh, path)
    engine = RayEngine(mesh.vertices, mesh.faces)
    if camera_position is not None:
        fov, cam_up = (camera.fov_deg, camera.up) if camera is not None else (DEFAULT_FOV_DEG, (0, 0, 1))
        camera, cam_src = _camera(camera_position, camera_look_at, cam_up, fov), "flags"
    elif camera is None:
        camera = default_camera(mesh, engine)
    if projector_position is not None:
        projector, proj_src = np.asarray(projector_position, dtype=np.float64), "flags"
    elif projector is None:
        projector = _projector_beside(camera)
    return RoomSetup(path, kind, mesh, camera, cam_src, projector, proj_src, file_to_world, engine, scene)
