"""What the camera sees at each pixel: the first surface along the pixel-center ray (a G-buffer).

The geometry-aware NLOS network (``models.nlos_net``, ``geometry``) reads, per pixel, the visible
surface's position, normal and albedo: the scan a user has of the visible walls, rendered into the
camera once per room. Normals are turned toward the camera (materials are two-sided); pixels
whose ray leaves the scene get zeros and ``hit`` False.

Shapes:
    scene with an (H, W) camera -> position (H, W, 3) m, normal (H, W, 3), albedo (H, W, 3),
    hit (H, W) bool, all in the world frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene.format import Scene
from .camera import pixel_rays
from .surface import StaticSurfaces


@dataclass
class GBuffer:
    """Per-pixel first hits of the camera's pixel-center rays (world frame, float64)."""

    position: np.ndarray
    """(H, W, 3) hit point, m (0 where nothing is hit)."""
    normal: np.ndarray
    """(H, W, 3) unit geometric normal facing the camera (0 where nothing is hit)."""
    albedo: np.ndarray
    """(H, W, 3) diffuse albedo with vertex colors (0 where nothing is hit)."""
    hit: np.ndarray
    """(H, W) bool: the ray hits the static scene."""


def render_gbuffer(scene: Scene, surfaces: StaticSurfaces | None = None) -> GBuffer:
    """The G-buffer of ``scene``'s camera (one ray through each pixel center)."""
    surfaces = surfaces or StaticSurfaces(scene)
    dirs, origin = pixel_rays(scene.camera, 1)
    h, w = dirs.shape[:2]
    d = dirs.reshape(-1, 3)
    hit, pts = surfaces.trace(np.broadcast_to(origin, d.shape).copy(), d)
    out = {k: np.zeros((h * w, 3)) for k in ("position", "normal", "albedo")}
    out["position"][hit] = pts.pos
    # two-sided materials: the side the camera sees is the one facing back along the ray
    out["normal"][hit] = pts.normal * -np.sign((pts.normal * d[hit]).sum(1, keepdims=True) + 1e-300)
    out["albedo"][hit] = pts.kd
    return GBuffer(**{k: v.reshape(h, w, 3) for k, v in out.items()}, hit=hit.reshape(h, w))


__all__ = ["GBuffer", "render_gbuffer"]
