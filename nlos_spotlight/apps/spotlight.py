"""``nlos spotlight``: which triangle of a room's mesh to spotlight, and how to aim the projector.

Pipeline (the inference half of DESIGN section 8, on a user's room):

1. **Geometry.** A scene directory gives its static shapes, camera and projector. A bare mesh
   (PLY/OBJ scan, meters) is cleaned (``scene.clean``) and turned z up by the smallest rotation
   that takes its up axis (``--up``, else ``scene.orient.detect_up_axis``) to +z: no translation
   and no turn about the vertical, so a scan that is already z up keeps its file's coordinates.
   All coordinates in and out (flags, printout, JSON) are in that z-up frame; the JSON gives
   ``file_to_world`` and the spot in the file's frame too. The camera and projector come from
   flags or from :func:`default_camera` (derived from the mesh bounds, printed so the user can
   reproduce or override it).
2. **LOS mesh.** As in dataset generation (one function, ``scene.los.los_mesh``): the faces the camera
   sees (2 x 2 rays per pixel, at least :data:`VISIBILITY_WIDTH` pixels across so small faces of a
   fine scan are found), cleaned, quadric-decimated to the target vertex count (``--target-vertices``,
   else the run's training dataset's ``los_vertices`` when its config is found, else
   :data:`DEFAULT_TARGET_VERTICES`): the IEN sees meshes as dense as those it was trained on. Its
   faces are the spot candidates.
3. **IEN.** The graph of the LOS mesh in the camera frame (normalized coordinates, plus normals if
   the run used them: ``data.tensors.graph_inputs``), one logit per face.
4. **Reachability.** A face is a candidate only if the projector's beam toward its centroid lands
   on it: the first surface of the *full* mesh along the beam lies within
   ``REACH_TOLERANCE_M + REACH_TOLERANCE_REL * range`` of the centroid (decimation moves surfaces
   by centimeters), on the side of the face the camera sees. Probabilities are the softmax of the
   logits over those faces (0 elsewhere); the spot is the most probable face.
5. **Aim.** The unit direction from the projector to the face centroid, and as angles
   (:class:`Aim`): tilt = elevation above the horizontal (positive up); azimuth = world heading
   counterclockwise from +x toward +y seen from above; pan = azimuth minus the camera's horizontal
   viewing heading, in (-180, 180], positive to the left of the camera's view (the same
   "along the view, to its left" frame that ``nlos predict`` reports positions in). The direction
   is ``(cos tilt cos azimuth, cos tilt sin azimuth, sin tilt)``.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from ..errors import NlosError
from ..lighting.learned import require_learned
from ..scene.scan import load_scan_z_up
from ..render.camera import camera_frame, pixel_rays
from ..render.rays import RayEngine
from ..scene.format import Camera, Scene, TriMesh
from ..scene.orient import fibonacci_sphere
from ..train.checkpoint import TrainedModels
from ..data.tensors import graph_inputs

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
REACH_TOLERANCE_M = 0.10
"""Fixed part of how far (m) the beam may land from a face centroid and still count as on it."""
REACH_TOLERANCE_REL = 0.02
"""Part of that tolerance proportional to the projector's range."""
CLEARANCE_M = 0.3
"""A default camera position closer than this to any surface is penalized (inside furniture)."""


# ---------------------------------------------------------------- geometry in

@dataclass
class SpotlightSetup:
    """The room, camera and projector the IEN is run for."""

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
    with them reads, :func:`ien_logits`); None for a bare mesh."""

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
               up: str | None = None) -> SpotlightSetup:
    """Geometry, camera and projector from a scene directory or a bare mesh (see module docstring).

    Args:
        path: an ``nlos-scene/1`` directory or a PLY/OBJ mesh (meters).
        camera_position, camera_look_at: (3,) override the camera pose (both or neither).
        projector_position: (3,) overrides the projector position.
        up: the bare mesh's up axis ('x', '-y', ...); None detects it.
    """
    from ..scene.io import load_scene
    from ..scene.meshio import SUFFIXES
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
    return SpotlightSetup(path, kind, mesh, camera, cam_src, projector, proj_src, file_to_world, engine, scene)


def visible_mesh(setup: SpotlightSetup, target_vertices: int) -> TriMesh:
    """The LOS mesh (``scene.los.los_mesh``), visible faces found at least :data:`VISIBILITY_WIDTH` rays across."""
    from ..scene.los import los_mesh

    return los_mesh(setup.mesh, setup.engine, setup.camera, target_vertices, min_width=VISIBILITY_WIDTH)


def training_los_vertices(models: TrainedModels) -> int | None:
    """The LOS vertex count of the run's training dataset (RUN/config.json -> DATA/config.json),
    or None when either file is not there."""
    try:
        data = Path(json.loads((models.path.parent / "config.json").read_text())["data"])
        n = json.loads((data / "config.json").read_text())["los_vertices"]
        return int(n) if isinstance(n, int) and n >= 8 else None
    except (OSError, KeyError, TypeError, ValueError):
        return None


# ---------------------------------------------------------------- IEN and aim

def camera_to_world(camera: Camera) -> np.ndarray:
    """(4, 4) pose, columns right, up, backward, position (OpenGL; as stored in datasets)."""
    fwd, right, up = camera_frame(camera)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, up, -fwd, camera.position
    return pose


def ien_logits(models: TrainedModels, los: TriMesh, camera: Camera, scene=None) -> torch.Tensor:
    """(F,) IEN logits of the LOS mesh's faces, read in the camera frame with every input its
    training read (``load_scene_tensors``): for an IEN trained with ``ien_features`` 'region' the
    mesh in the hidden region's frame, for 'adaptive' or a ``prior_weight`` the Adaptive Lighting
    score of each face aimed at its centroid (as a room stores its candidates). Those need
    ``scene`` with a hidden region; a bare mesh gives one line saying so. The one path from a mesh
    to the IEN's choice (``nlos spotlight``, ``nlos fit --policy ien``)."""
    from ..data.tensors import face_log_prior, region_frame

    feats = list(models.config.ien_features)
    weight = float(models.ien.cfg.prior_weight)
    needs = [f for f in feats if f in ("region", "adaptive")] + (["a face prior"] if weight else [])
    if needs and (scene is None or scene.hidden_region is None):
        raise NlosError(f"{models.path}: this IEN reads {', '.join(needs)} of the hidden region; give a scene "
                        "with a hidden_region (an nlos-scene/1 directory), not a bare mesh")
    pose = camera_to_world(camera)
    region = region_frame(scene.hidden_region, pose) if "region" in feats else None
    scores = None
    if "adaptive" in feats or weight:
        from ..lighting.adaptive import adaptive_scores

        scores = adaptive_scores(scene, los.centroids())
    x, edges = graph_inputs(los, pose, feats, region, scores)
    if x.shape[1] != models.ien.cfg.in_features:
        raise NlosError(f"{models.path}: the IEN expects {models.ien.cfg.in_features} input features per vertex, "
                        f"features {models.config.ien_features} give {x.shape[1]}")
    device = next(models.ien.parameters()).device
    prior = face_log_prior(scores).to(device) if weight else None
    with torch.no_grad():
        return models.ien(x.to(device), edges.to(device),
                          torch.as_tensor(los.faces, dtype=torch.long, device=device), prior).cpu()


def oriented_normals(los: TriMesh, camera: Camera) -> np.ndarray:
    """(F, 3) unit face normals flipped toward the camera (materials are two-sided)."""
    n = los.face_normals()
    toward = camera.position - los.centroids()
    return np.where((np.einsum("ij,ij->i", n, toward) < 0)[:, None], -n, n)


def projector_reach(setup: SpotlightSetup, los: TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """Which LOS faces the projector's beam lands on (module docstring, step 4).

    Returns:
        reachable (F,) bool and landing (F, 3): where the beam toward each centroid first meets
        the full mesh (NaN on a miss).
    """
    c = los.centroids()
    d = c - setup.projector
    dist = np.linalg.norm(d, axis=1)
    if np.any(dist < 1e-6):
        raise NlosError("the projector sits on a face of the mesh")
    d = d / dist[:, None]
    h = setup.engine.first_hit(np.broadcast_to(setup.projector, c.shape), d)
    landing = np.where(h.hit[:, None], setup.projector + np.where(h.hit, h.t, 0.0)[:, None] * d, np.nan)
    near = np.linalg.norm(np.nan_to_num(landing - c, nan=np.inf), axis=1) \
        <= REACH_TOLERANCE_M + REACH_TOLERANCE_REL * dist
    n = oriented_normals(los, setup.camera)  # toward the camera: the projector must light that side
    same_side = np.einsum("ij,ij->i", n, setup.projector - c) > 0
    return h.hit & near & same_side, landing


@dataclass
class Aim:
    """Where to point the projector (angle conventions in the module docstring)."""

    projector: np.ndarray
    """(3,) projector position, m."""
    target: np.ndarray
    """(3,) the aim point (the chosen face's centroid), m."""
    direction: np.ndarray
    """(3,) unit vector from the projector to the target, world frame."""
    distance_m: float
    """Projector to target, m."""
    azimuth_deg: float
    """World heading of ``direction``, counterclockwise from +x toward +y."""
    pan_deg: float
    """Heading relative to the camera's horizontal view direction, (-180, 180], positive left."""
    tilt_deg: float
    """Elevation above the horizontal plane, positive up."""
    camera_heading_deg: float
    """World heading of the camera's horizontal view direction."""
    landing: np.ndarray
    """(3,) first surface point along the beam's axis (NaN if the beam meets nothing)."""

    @property
    def landing_offset_m(self) -> float:
        return float(np.linalg.norm(self.landing - self.target))

    def to_dict(self) -> dict:
        return {"projector": self.projector.tolist(), "target": self.target.tolist(),
                "direction": self.direction.tolist(), "distance_m": self.distance_m,
                "azimuth_deg": self.azimuth_deg, "pan_deg": self.pan_deg, "tilt_deg": self.tilt_deg,
                "camera_heading_deg": self.camera_heading_deg,
                "landing_point": None if np.isnan(self.landing).any() else self.landing.tolist(),
                "landing_offset_m": None if np.isnan(self.landing).any() else self.landing_offset_m,
                "convention": "direction = (cos tilt cos azimuth, cos tilt sin azimuth, sin tilt); azimuth "
                              "counterclockwise from +x toward +y seen from above; pan = azimuth - "
                              "camera_heading wrapped to (-180, 180], positive to the left of the camera's "
                              "view; tilt positive above the horizontal"}


def aim_projector(projector: np.ndarray, target: np.ndarray, camera: Camera,
                  landing: np.ndarray | None = None) -> Aim:
    """Direction and pan/tilt angles from ``projector`` (3,) to ``target`` (3,)."""
    d = np.asarray(target, np.float64) - np.asarray(projector, np.float64)
    dist = float(np.linalg.norm(d))
    if dist < 1e-9:
        raise NlosError("the projector sits on the aim point")
    d = d / dist
    azimuth = float(np.degrees(np.arctan2(d[1], d[0])))
    tilt = float(np.degrees(np.arcsin(np.clip(d[2], -1.0, 1.0))))
    fwd = camera_frame(camera)[0]
    heading = float(np.degrees(np.arctan2(fwd[1], fwd[0]))) if np.linalg.norm(fwd[:2]) > 1e-9 else 0.0
    pan = -((heading - azimuth + 180.0) % 360.0 - 180.0)  # wrapped to (-180, 180]
    land = np.full(3, np.nan) if landing is None else np.asarray(landing, np.float64)
    return Aim(np.asarray(projector, np.float64), np.asarray(target, np.float64), d, dist, azimuth, pan, tilt,
               heading, land)


# ---------------------------------------------------------------- the result

@dataclass
class Candidate:
    """One of the top-k faces."""

    face: int
    """Face index in the LOS mesh."""
    probability: float
    """IEN probability among the reachable faces."""
    centroid: np.ndarray
    """(3,) world position, m."""


@dataclass
class SpotlightResult:
    """Everything ``nlos spotlight`` reports (and writes with ``--json``)."""

    setup: SpotlightSetup
    """Input geometry, camera and projector."""
    los: TriMesh
    """The LOS mesh (world frame); face indices refer to it."""
    target_vertices: int
    """Decimation target of the LOS mesh."""
    target_source: str
    """Where the target came from: 'flag', 'training dataset' or 'default'."""
    logits: np.ndarray
    """(F,) IEN logits."""
    reachable: np.ndarray
    """(F,) bool, the projector's beam lands on the face (module docstring, step 4)."""
    probabilities: np.ndarray
    """(F,) softmax of the logits over the reachable faces, 0 elsewhere; sums to 1."""
    face: int
    """The chosen face: argmax of ``probabilities``."""
    normal: np.ndarray
    """(3,) unit normal of the chosen face, toward the camera."""
    top: list[Candidate]
    """The k most probable faces, best first."""
    aim: Aim
    """How to point the projector at the chosen face."""
    checkpoint: str = ""
    """The checkpoint file."""

    @property
    def centroid(self) -> np.ndarray:
        return self.los.centroids()[self.face]

    def to_dict(self) -> dict:
        s, cam = self.setup, self.setup.camera
        return {
            "source": str(s.source), "kind": s.kind, "checkpoint": self.checkpoint,
            "camera": {**{k: v for k, v in cam.to_dict().items() if k not in ("width", "height")},
                       "source": s.camera_source},
            "projector": {"position": s.projector.tolist(), "source": s.projector_source},
            "los_mesh": {"target_vertices": self.target_vertices, "target_source": self.target_source,
                         "vertices": self.los.vertices.tolist(), "faces": self.los.faces.tolist()},
            "file_to_world": s.file_to_world.tolist(),
            "chosen": {"face": self.face, "probability": float(self.probabilities[self.face]),
                       "centroid": self.centroid.tolist(), "normal": self.normal.tolist(),
                       "centroid_in_file": (np.linalg.inv(s.file_to_world) @ [*self.centroid, 1.0])[:3].tolist()},
            "top_k": [{"rank": i + 1, "face": c.face, "probability": c.probability, "centroid": c.centroid.tolist()}
                      for i, c in enumerate(self.top)],
            "aim": self.aim.to_dict(),
            "reachable_faces": int(self.reachable.sum()),
            "probabilities": self.probabilities.tolist(),
            "logits": self.logits.tolist(),
        }


def spotlight(models: TrainedModels, setup: SpotlightSetup, target_vertices: int | None = None,
              top_k: int = 5) -> SpotlightResult:
    """Run the IEN on ``setup`` and aim the projector at its most probable reachable face."""
    require_learned(models)
    if top_k < 1:
        raise NlosError(f"--top-k: expected a positive count, got {top_k}")
    if target_vertices is not None:
        source = "flag"
    elif (target_vertices := training_los_vertices(models)) is not None:
        source = "training dataset"
    else:
        target_vertices, source = DEFAULT_TARGET_VERTICES, "default"
    if target_vertices < 8:
        raise NlosError(f"--target-vertices: expected at least 8, got {target_vertices}")
    los = visible_mesh(setup, target_vertices)
    logits = ien_logits(models, los, setup.camera, setup.scene)
    reachable, landing = projector_reach(setup, los)
    if not reachable.any():
        raise NlosError(f"the projector at {np.round(setup.projector, 3).tolist()} reaches none of the "
                        f"{len(los.faces)} faces the camera sees (is it inside an object or behind a wall?)")
    masked = logits.double().masked_fill(~torch.as_tensor(reachable), float("-inf"))
    probs = torch.softmax(masked, dim=0).numpy()
    face = int(np.argmax(probs))
    order = np.argsort(-probs, kind="stable")[:min(top_k, int(reachable.sum()))]
    cents = los.centroids()
    top = [Candidate(int(f), float(probs[f]), cents[f]) for f in order]
    aim = aim_projector(setup.projector, cents[face], setup.camera, landing[face])
    return SpotlightResult(setup, los, int(target_vertices), source, logits.double().numpy(), reachable, probs,
                           face, oriented_normals(los, setup.camera)[face], top, aim, str(models.path))


# ---------------------------------------------------------------- output

def write_json(result: SpotlightResult, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(result.to_dict(), indent=1))
    os.replace(tmp, path)


def _v(a) -> str:
    return "(" + ", ".join(f"{float(x):+.3f}" for x in a) + ")"


def print_result(r: SpotlightResult, console) -> None:
    """The chosen face, the aim and the top-k table on the console."""
    from rich.table import Table

    s, cam, a = r.setup, r.setup.camera, r.aim
    if s.kind == "scene":
        console.print(f"[bold]{s.source}[/bold]: scene directory")
    else:
        turned = "" if np.allclose(s.file_to_world, np.eye(4)) else \
            ", turned z up (coordinates below are in that frame; --json has file_to_world)"
        console.print(f"[bold]{s.source}[/bold]: mesh, {len(s.mesh.vertices)} vertices after cleaning{turned}")
    cam_note = {"scene": "from scene.json", "flags": "from flags",
                "default": "default derived from the mesh bounds; set --camera-position/--camera-look-at"}
    console.print(f"camera ({cam_note[s.camera_source]}): position {_v(cam.position)} look_at {_v(cam.look_at)} "
                  f"fov {cam.fov_deg:g} deg")
    proj_note = {"scene": "from scene.json", "flags": "from flags",
                 "default": f"default {PROJECTOR_OFFSET_M[0]} m right of and {-PROJECTOR_OFFSET_M[1]} m below the "
                            "camera; set --projector-position"}
    console.print(f"projector ({proj_note[s.projector_source]}): position {_v(s.projector)}")
    console.print(f"LOS mesh: {len(r.los.vertices)} vertices, {len(r.los.faces)} faces seen by the camera "
                  f"(target {r.target_vertices}, {r.target_source}); "
                  f"{int(r.reachable.sum())} reachable by the projector")
    console.print(f"[bold]spot: face {r.face}[/bold], p = {r.probabilities[r.face]:.3f}, centroid {_v(r.centroid)} m, "
                  f"normal {_v(r.normal)}")
    console.print(f"aim the projector: direction {_v(a.direction)} (unit, from the projector), "
                  f"{a.distance_m:.2f} m away; pan {a.pan_deg:+.1f} deg (+ = left of the camera's view), tilt {a.tilt_deg:+.1f} deg "
                  f"(+ = up); world azimuth {a.azimuth_deg:+.1f} deg (from +x toward +y)")
    if not np.isnan(a.landing).any() and a.landing_offset_m > 0.01:
        console.print(f"the beam's axis meets the scan {100 * a.landing_offset_m:.0f} cm from the face centroid "
                      "(decimation moves surfaces)")
    t = Table(title=f"top {len(r.top)} faces")
    for col, just in (("rank", "right"), ("face", "right"), ("probability", "right"), ("centroid (m)", "left")):
        t.add_column(col, justify=just)
    for i, c in enumerate(r.top):
        t.add_row(str(i + 1), str(c.face), f"{c.probability:.4f}", _v(c.centroid))
    console.print(t)
