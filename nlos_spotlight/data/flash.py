"""The flash of Tancik et al. 2018: a wide-beam emitter at the camera lighting its whole view.

"Flash Photography for Data-Driven Hidden Scene Recovery" (Tancik, Satat, Raskar, 2018) lights
the visible scene with a flash next to the lens. We model it with the projector's own emitter
type (DESIGN section 4, Mitsuba 3 ``spot``), so the same renderer draws it:

* position: the camera's center of projection; axis: toward the camera's ``look_at``;
* beam: full intensity out to half the diagonal field of view (the image corners),
  ``beam_width = atan(sqrt(tan^2(fov_x / 2) + tan^2(fov_y / 2)))``, falling off linearly to
  zero at ``cutoff = beam_width + FLASH_MARGIN_DEG``;
* intensity: chosen so the flash emits the projector spot's total radiant flux, a fair
  comparison at equal power (the paper compares illuminations; the source power is the
  hardware's, and a spot concentrates what a flash spreads).

Total flux of a spot emitter (per channel), with b = beam width and c = cutoff in radians:

    Phi = I * integral_0^{2 pi} integral_0^c f(theta) sin(theta) dtheta dphi = I * Omega(b, c)

    Omega(b, c) = 2 pi [ (1 - cos b) + integral_b^c (c - theta) / (c - b) sin(theta) dtheta ]
                = 2 pi [ 1 - (sin c - sin b) / (c - b) ]

(integrating (c - theta) sin(theta) by parts gives (c - b) cos b - (sin c - sin b)); as c -> b
it tends to the cone's 2 pi (1 - cos b). Equal flux: ``I_flash = I_proj Omega_proj / Omega_flash``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..scene.format import Camera, Projector, Scene

FLASH_MARGIN_DEG = 5.0
"""Cutoff of the flash beyond the image corners, degrees (a soft edge just outside the view)."""
FLASH_SPOT_SAMPLES = 16
"""The flash's cone is far wider than a spot: it gets this many times the spot's projector rays."""


def effective_solid_angle(beam_width_deg: float, cutoff_deg: float) -> float:
    """Omega(b, c) = integral of the spot profile f over the sphere, sr (module docstring)."""
    b, c = math.radians(beam_width_deg), math.radians(cutoff_deg)
    return 2 * math.pi * (1 - (math.sin(c) - math.sin(b)) / (c - b))


def total_flux(projector: Projector) -> np.ndarray:
    """(3,) radiant flux of a spot emitter per channel, W: intensity * Omega(beam width, cutoff)."""
    return np.asarray(projector.intensity, np.float64) * effective_solid_angle(projector.beam_width_deg,
                                                                              projector.cutoff_deg)


def half_diagonal_fov_deg(camera: Camera) -> float:
    """Angle from the optical axis to an image corner, degrees."""
    tan_x = math.tan(math.radians(camera.fov_deg) / 2)
    tan_y = tan_x * camera.height / camera.width
    return math.degrees(math.atan(math.hypot(tan_x, tan_y)))


def flash_projector(camera: Camera, projector: Projector) -> Projector:
    """The flash emitter at the camera with the projector's total flux (module docstring)."""
    beam = half_diagonal_fov_deg(camera)
    cutoff = beam + FLASH_MARGIN_DEG
    scale = effective_solid_angle(projector.beam_width_deg, projector.cutoff_deg) / effective_solid_angle(beam, cutoff)
    return Projector(np.asarray(camera.position, np.float64).copy(),
                     np.asarray(projector.intensity, np.float64) * scale, beam, cutoff)


def flash_scene(scene: Scene) -> Scene:
    """A shallow copy of ``scene`` whose projector is the flash; its aim point is the camera's look_at."""
    return dataclasses.replace(scene, projector=flash_projector(scene.camera, scene.projector))
