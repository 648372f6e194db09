"""Pinhole camera rays with stratified sub-pixel samples (DESIGN section 4).

Image row 0 is the top, column 0 the left, as a photograph from the camera
shows it; ``fov_deg`` is horizontal. A pixel is the mean radiance over its
footprint, estimated with ``n x n`` stratified sub-samples: at the cell centers, or jittered
(uniform within their cells), which makes the estimate of the footprint's mean unbiased.
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


def pixel_rays(cam: Camera, n: int = 1, jitter: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions of shape (H, W, n*n, 3) and the origin (3,).

    Sub-samples sit at the centers of an n x n grid inside each pixel, or with ``jitter``
    (H, W, n, n, 2) in [0, 1) (x right, y down within the cell) anywhere in their cells: the
    stratified estimator whose expectation is the footprint's exact mean.
    """
    fwd, right, up = camera_frame(cam)
    tan_x = np.tan(np.radians(cam.fov_deg) / 2)
    tan_y = tan_x * cam.height / cam.width
    shape = (cam.height, cam.width, n, n)
    if jitter is None:
        jitter = np.full((*shape, 2), 0.5)
    elif jitter.shape != (*shape, 2) or not (np.all(jitter >= 0) and np.all(jitter < 1)):
        raise ValueError(f"jitter: expected {(*shape, 2)} values in [0, 1), got shape {jitter.shape}")
    cell = np.arange(n)
    # film coordinates in [-1, 1]: x grows to the right, y grows upward; axes (row, col, sub-row, sub-col)
    fx = (np.arange(cam.width)[None, :, None, None] + (cell[None, None, None, :] + jitter[..., 0]) / n) / cam.width * 2 - 1
    fy = 1 - (np.arange(cam.height)[:, None, None, None] + (cell[None, None, :, None] + jitter[..., 1]) / n) / cam.height * 2
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
