"""Center policy: spotlight the middle of the camera view.

The naive choice a user makes without a model of the hidden region: aim where the camera looks.
Among the candidates whose spot lands, the one whose aim point projects nearest the image center
(H/2, W/2) in pixel coordinates (DESIGN section 4: row 0 at the top).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import NlosError
from ..render.camera import project
from .base import Illumination


def center_candidate(camera, aim_points: np.ndarray, landed: np.ndarray) -> int:
    """Index of the landed candidate whose aim point (T, 3) projects nearest the image center.

    Aim points behind the camera (no projection) are never chosen; ties go to the lowest index.
    """
    pix = project(camera, np.asarray(aim_points, np.float64))  # (T, 2) row, col; NaN behind the camera
    dist = np.hypot(pix[:, 0] - camera.height / 2, pix[:, 1] - camera.width / 2)
    dist = np.where(np.asarray(landed, bool) & np.isfinite(dist), dist, np.inf)
    if not np.isfinite(dist).any():
        raise NlosError("center policy: no landed candidate in front of the camera")
    return int(np.argmin(dist))


def center_spot(scene, scene_dir: Path, rng: np.random.Generator) -> Illumination:
    """The landed candidate nearest the center of the camera image (``rng`` unused)."""
    from ..scene import load_scene

    from ..data.static import read_static

    aims = read_static(scene_dir, "aim_points")["aim_points"]
    return Illumination("spot", center_candidate(load_scene(scene_dir).camera, aims, scene.landed.cpu().numpy()))
