"""Pinhole camera rays with stratified sub-pixel samples (DESIGN section 4).

Image row 0 is the top, column 0 the left, as a photograph from the camera
shows it; ``fov_deg`` is horizontal. A pixel is the mean radiance over its
footprint, estimated with ``n x n`` stratified sub-samples (cell centers).
"""

from __future__ import annotations

import numpy as np

from ..scene.format import Camera


def camera_frame(cam: Camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(forward, right, up) orthonormal world vectors."""
    fwd = cam.look_at - cam.position
    fwd = fwd / np.linalg.norm(fwd)
    right = np.cross(fwd, cam.up)
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    return fwd, right, up


def pixel_rays(cam: Camera, n: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions of shape (H, W, n*n, 3) and the origin (3,).

    Sub-samples sit at the centers of an n x n grid inside each pixel.
    """
    fwd, right, up = camera_frame(cam)
    tan_x = np.tan(np.radians(cam.fov_deg) / 2)
    tan_y = tan_x * cam.height / cam.width
    sub = (np.arange(n) + 0.5) / n
    # film coordinates in [-1, 1]: x grows to the right, y grows upward
    cols = (np.arange(cam.width)[:, None] + sub[None, :]) / cam.width * 2 - 1  # (W, n)
    rows = 1 - (np.arange(cam.height)[:, None] + sub[None, :]) / cam.height * 2  # (H, n)
    fx = np.broadcast_to(cols[None, :, None, :], (cam.height, cam.width, n, n))
    fy = np.broadcast_to(rows[:, None, :, None], (cam.height, cam.width, n, n))
    d = fwd + fx[..., None] * tan_x * right + fy[..., None] * tan_y * up
    d = d.reshape(cam.height, cam.width, n * n, 3)
    return d / np.linalg.norm(d, axis=-1, keepdims=True), cam.position.copy()


def project(cam: Camera, points: np.ndarray) -> np.ndarray:
    """World points (N, 3) -> continuous (row, col) pixel coordinates (N, 2); NaN behind the camera."""
    fwd, right, up = camera_frame(cam)
    rel = points - cam.position
    z = rel @ fwd
    tan_x = np.tan(np.radians(cam.fov_deg) / 2)
    tan_y = tan_x * cam.height / cam.width
    with np.errstate(divide="ignore", invalid="ignore"):
        fx = (rel @ right) / (z * tan_x)
        fy = (rel @ up) / (z * tan_y)
    col = (fx + 1) / 2 * cam.width
    row = (1 - fy) / 2 * cam.height
    out = np.stack([row, col], axis=1)
    out[z <= 0] = np.nan
    return out


def camera_to_world(camera: Camera) -> np.ndarray:
    """(4, 4) pose, columns right, up, backward, position (OpenGL; as stored in datasets)."""
    fwd, right, up = camera_frame(camera)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, up, -fwd, camera.position
    return pose
