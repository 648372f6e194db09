"""Render a room's :class:`~.variation.StaticLayers`: its static light under one spot at ``factor`` x
``factor`` cells per output pixel, the light's derivative in the spot's aim, and the ambient light.

The camera keeps its pose and field of view with ``factor`` times the pixels; each cell is sampled
``pixel_samples``^2 times (the renderer's per-scene terms). The aim derivatives are central
differences of the direct image over ``aim_step_rad`` of pan (about the world's z axis) and tilt
(about the axis right of the beam): the spot profile is linear across its edge (DESIGN section 4),
so a difference over a step well inside that edge is the derivative.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from ..scene.format import Scene
from .camera import camera_frame
from .settings import RenderSettings
from .variation import StaticLayers


def aim_offsets(projector_position: np.ndarray, aim: np.ndarray, step_rad: float) -> np.ndarray:
    """(5, 3) aim points: ``aim``, then turned by +-step of pan, then +-step of tilt (same distance)."""
    axis = aim - projector_position
    dist = np.linalg.norm(axis)
    a = axis / dist
    right = np.cross(a, [0.0, 0.0, 1.0])
    right = right / np.linalg.norm(right) if np.linalg.norm(right) > 1e-9 else np.array([1.0, 0.0, 0.0])
    up = np.cross(right, a)
    turn = lambda v, t: projector_position + dist * (np.cos(t) * a + np.sin(t) * v)
    return np.stack([aim, turn(right, step_rad), turn(right, -step_rad), turn(up, step_rad), turn(up, -step_rad)])


def median_depth(scene: Scene) -> float:
    """Median distance along the optical axis of what the camera's pixel centres see, m."""
    from .camera import pixel_rays
    from .surface import StaticSurfaces

    dirs, origin = pixel_rays(scene.camera, 1)
    flat = dirs.reshape(-1, 3)
    hit, surf = StaticSurfaces(scene).trace(np.broadcast_to(origin, flat.shape), flat)
    fwd = camera_frame(scene.camera)[0]
    return float(np.median((surf.pos - origin) @ fwd)) if hit.any() else 1.0


def static_layers(scene: Scene, aim: np.ndarray, factor: int = 8, pixel_samples: int = 1,
                  aim_step_rad: float = 2e-3, interreflection: bool = True) -> StaticLayers:
    """The layers of ``scene`` lit by the spot aimed at ``aim`` (3,) (module docstring)."""
    from .transport import Renderer

    cam = scene.camera
    fine = dataclasses.replace(scene, camera=dataclasses.replace(cam, width=cam.width * factor,
                                                                 height=cam.height * factor))
    settings = RenderSettings(pixel_samples=pixel_samples, transport_pixel_samples=pixel_samples, device="cpu",
                              dtype="float64")
    r = Renderer(fine, settings, aim_points=aim_offsets(scene.projector.position, np.asarray(aim, float),
                                                        aim_step_rad))
    shape = (cam.height * factor, cam.width * factor, 3)
    d = r.D.reshape(*shape[:2], 5, 3).permute(2, 0, 1, 3)
    proj = d[0]
    if interreflection:
        proj = proj + r.render(r.spot_vector(0), components=("interreflection",))["interreflection"]
    deriv = torch.stack([(d[1] - d[2]), (d[3] - d[4])]) / (2 * aim_step_rad)
    f_px = cam.width / (2 * np.tan(np.radians(cam.fov_deg) / 2))
    return StaticLayers(proj.float(), deriv.float(), r.ambient_image.float(), factor, float(f_px),
                        median_depth(scene))


__all__ = ["aim_offsets", "median_depth", "static_layers"]
