"""The world as it differs from the scan a room model believes (issue 35, scan versus world).

A room model is fitted in the user's scan: the camera pose the user measured, the projector aimed
by the pan and tilt the fit printed, the scan's colours as albedo and its triangles as the walls.
The real room differs from each by a calibration error. :func:`mismatched_world` draws one such
world from the scan's scene under the scan-versus-world fields of a
:class:`~nlos_spotlight.render.variation.CaptureVariation` (1-sigma magnitudes, the ``tripod``
preset's sources in ``render/variation.py``):

* ``pose_deg`` / ``position_m``: the camera turned about its own pan, tilt and roll axes and moved,
  each axis an independent normal draw;
* ``projector_aim_deg``: the beam turned in pan and tilt about the projector; the spot lands where
  the turned beam first meets the scan;
* ``albedo_log``: every surface's colour times exp(N(0, sigma^2)) per channel, one draw for the
  room (a scan's colour calibration is off as a whole: exposure and white balance), clipped to 1;
* ``geometry_m``: every vertex moved by an isotropic normal draw (the fused mesh's local noise);
* ``warp_m``: every vertex moved by one smooth random field over the room (:func:`warped`: the
  scan's tracking drift and bowed walls), correlated over ``render.variation.WARP_LENGTH_M``.

The capture fields of the variation are ignored here (they act between photographs,
``render.variation``).
"""

from __future__ import annotations

import copy
import math

import numpy as np

from ..scene.format import Scene, TriMesh


def rotation(axis_angles: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """(3, 3) rotation by the small angles (rad) about ``frame``'s rows (right, up, forward),
    composed as one axis-angle (Rodrigues)."""
    w = frame.T @ np.asarray(axis_angles, np.float64)
    theta = float(np.linalg.norm(w))
    if theta == 0:
        return np.eye(3)
    k = w / theta
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(theta) * kx + (1 - math.cos(theta)) * kx @ kx


def _frame(forward: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Rows right, up, forward of a view along ``forward``."""
    f = forward / np.linalg.norm(forward)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    return np.stack([r, np.cross(r, f), f])


def turned_camera(scene: Scene, angles_rad: np.ndarray, shift_m: np.ndarray) -> None:
    """Turn ``scene``'s camera by (pan, tilt, roll) about its own axes and move it, in place."""
    cam = scene.camera
    fwd = cam.look_at - cam.position
    frame = _frame(fwd, cam.up)
    pan, tilt, roll = angles_rad
    rot = rotation(np.array([tilt, pan, roll]), frame)  # tilt about right, pan about up, roll about forward
    cam.position = cam.position + np.asarray(shift_m, np.float64)
    cam.look_at = cam.position + rot @ fwd
    cam.up = rot @ cam.up


def turned_aim(scene: Scene, aim: np.ndarray, angles_rad: np.ndarray) -> np.ndarray:
    """Where a beam from the projector toward ``aim``, turned by (pan, tilt), first meets the scene."""
    from ..render.rays import RayEngine

    proj = scene.projector.position
    d = np.asarray(aim, np.float64) - proj
    frame = _frame(d, np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.99 * np.linalg.norm(d) else np.array([1.0, 0, 0]))
    pan, tilt = angles_rad
    d2 = rotation(np.array([tilt, pan, 0.0]), frame) @ d
    mesh = scene.static_mesh()[0]
    engine = RayEngine(mesh.vertices, mesh.faces)
    hits = engine.first_hit(proj[None].copy(), (d2 / np.linalg.norm(d2))[None])
    if not bool(hits.hit[0]):
        return proj + d2  # the turned beam meets nothing: aim where it points, at the same distance
    return engine.surface_point(hits.face[:1], hits.bary[:1])[0]


def recoloured(scene: Scene, factor: np.ndarray) -> None:
    """Every surface's albedo (material diffuse x mesh colour) times ``factor`` (3,) per channel,
    capped at 1 as albedo is, in place: the material takes what keeps it at most 1 and the mesh
    colours the rest (a scan's material is white and its colours carry the albedo)."""
    factor = np.asarray(factor, np.float64)
    rest = {}
    for k, m in scene.materials.items():
        want = m.diffuse * factor
        m.diffuse = np.minimum(want, 1.0)
        rest[k] = np.where(m.diffuse > 0, want / np.maximum(m.diffuse, 1e-300), 1.0)  # >= 1 where capped
    for s in scene.shapes:
        g, m = rest[s.material], s.mesh
        if np.all(g == 1.0):
            continue
        if m.face_colors is not None:
            s.mesh = TriMesh(m.vertices, m.faces, m.vertex_colors, np.clip(m.face_colors * g, 0, 1))
        elif m.vertex_colors is not None:
            s.mesh = TriMesh(m.vertices, m.faces, np.clip(m.vertex_colors * g, 0, 1), None)


def jittered(scene: Scene, sigma_m: float, rng: np.random.Generator) -> None:
    """Every vertex moved by an isotropic normal draw of ``sigma_m`` per axis, in place."""
    for s in scene.shapes:
        m = s.mesh
        s.mesh = TriMesh(m.vertices + rng.normal(0.0, sigma_m, m.vertices.shape), m.faces, m.vertex_colors,
                         m.face_colors)


WARP_FEATURES = 256
"""Random Fourier features of the warp field (its covariance within a few % of the Gaussian kernel)."""


def warp_field(sigma_m: float, length_m: float, rng: np.random.Generator, features: int = WARP_FEATURES):
    """One draw of a smooth random field, a function (N, 3) points -> (N, 3) displacements: each
    axis an independent Gaussian process of standard deviation ``sigma_m`` and squared-exponential
    covariance ``sigma^2 exp(-|a - b|^2 / (2 length^2))``, as random Fourier features
    (Rahimi & Recht, NIPS 2007): ``sigma sqrt(2 / K) sum_k w_k cos(omega_k . p + phi_k)``."""
    omega = rng.normal(0.0, 1.0 / length_m, (features, 3))
    phase = rng.uniform(0.0, 2 * math.pi, features)
    weight = sigma_m * math.sqrt(2.0 / features) * rng.standard_normal((features, 3))
    return lambda points: np.cos(points @ omega.T + phase) @ weight


def warped(scene: Scene, sigma_m: float, rng: np.random.Generator, length_m: float | None = None) -> None:
    """Every vertex of every shape moved by one smooth field (:func:`warp_field`), in place: shapes
    that meet keep meeting, since the field is one function of position."""
    from ..render.variation import WARP_LENGTH_M

    field = warp_field(sigma_m, WARP_LENGTH_M if length_m is None else length_m, rng)
    for s in scene.shapes:
        m = s.mesh
        s.mesh = TriMesh(m.vertices + field(m.vertices), m.faces, m.vertex_colors, m.face_colors)


def mismatched_world(scene: Scene, aim: np.ndarray, v, seed: int) -> tuple[Scene, np.ndarray, dict]:
    """(the world, where the spot lands in it, what was drawn) for the scan's ``scene`` and spot
    ``aim`` under variation ``v``'s scan-versus-world fields; ``scene`` is not changed."""
    rng = np.random.default_rng(seed)
    world = copy.deepcopy(scene)
    drawn = {}
    if v.pose_deg > 0 or v.position_m > 0:
        ang, shift = np.radians(v.pose_deg) * rng.standard_normal(3), v.position_m * rng.standard_normal(3)
        turned_camera(world, ang, shift)
        drawn["camera_deg"], drawn["camera_m"] = np.degrees(ang).tolist(), shift.tolist()
    if v.albedo_log > 0:
        f = np.exp(v.albedo_log * rng.standard_normal(3))
        recoloured(world, f)
        drawn["albedo_factor"] = f.tolist()
    if v.geometry_m > 0:
        jittered(world, v.geometry_m, rng)
        drawn["geometry_m"] = v.geometry_m
    if getattr(v, "warp_m", 0) > 0:
        warped(world, v.warp_m, rng)
        drawn["warp_m"] = v.warp_m
    aim = np.asarray(aim, np.float64)
    if v.projector_aim_deg > 0:  # after the geometry: the beam lands on the world's walls
        ang = np.radians(v.projector_aim_deg) * rng.standard_normal(2)
        aim = turned_aim(world, aim, ang)
        drawn["projector_deg"] = np.degrees(ang).tolist()
    return world, aim, drawn


__all__ = ["mismatched_world", "recoloured", "rotation", "turned_aim", "turned_camera", "jittered", "warp_field",
           "warped"]
