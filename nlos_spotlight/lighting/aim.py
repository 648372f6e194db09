"""Aiming the projector at a face: can its beam land there, and the pan/tilt that does it.

**Reachability.** A face is a candidate only if the projector's beam toward its centroid lands on
it: the first surface of the *full* mesh along the beam lies within ``REACH_TOLERANCE_M +
REACH_TOLERANCE_REL * range`` of the centroid (decimation moves surfaces by centimeters), on the
side of the face the camera sees.

**Aim.** The unit direction from the projector to the face centroid, and as angles
(:class:`Aim`): tilt = elevation above the horizontal (positive up); azimuth = world heading
counterclockwise from +x toward +y seen from above; pan = azimuth minus the camera's horizontal
viewing heading, in (-180, 180], positive to the left of the camera's view (the same "along the
view, to its left" frame that ``nlos predict`` reports positions in). The direction is
``(cos tilt cos azimuth, cos tilt sin azimuth, sin tilt)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import NlosError
from ..render.camera import camera_frame
from ..render.rays import RayEngine
from ..scene.format import Camera, TriMesh

REACH_TOLERANCE_M = 0.10
"""Fixed part of how far (m) the beam may land from a face centroid and still count as on it."""

REACH_TOLERANCE_REL = 0.02
"""Part of that tolerance proportional to the projector's range."""


def oriented_normals(los: TriMesh, camera: Camera) -> np.ndarray:
    """(F, 3) unit face normals flipped toward the camera (materials are two-sided)."""
    n = los.face_normals()
    toward = camera.position - los.centroids()
    return np.where((np.einsum("ij,ij->i", n, toward) < 0)[:, None], -n, n)


def projector_reach(engine: RayEngine, projector: np.ndarray, camera: Camera,
                    los: TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """Which LOS faces the beam of a projector at ``projector`` (3,) lands on, in the full mesh
    ``engine`` (module docstring).

    Returns:
        reachable (F,) bool and landing (F, 3): where the beam toward each centroid first meets
        the full mesh (NaN on a miss).
    """
    c = los.centroids()
    d = c - projector
    dist = np.linalg.norm(d, axis=1)
    if np.any(dist < 1e-6):
        raise NlosError("the projector sits on a face of the mesh")
    d = d / dist[:, None]
    h = engine.first_hit(np.broadcast_to(projector, c.shape), d)
    landing = np.where(h.hit[:, None], projector + np.where(h.hit, h.t, 0.0)[:, None] * d, np.nan)
    near = np.linalg.norm(np.nan_to_num(landing - c, nan=np.inf), axis=1) \
        <= REACH_TOLERANCE_M + REACH_TOLERANCE_REL * dist
    n = oriented_normals(los, camera)  # toward the camera: the projector must light that side
    same_side = np.einsum("ij,ij->i", n, projector - c) > 0
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
