"""Smooth walking trajectories inside the region where people may stand (test split, tracking)."""

from __future__ import annotations

import numpy as np


def walking_trajectory(rng: np.random.Generator, valid: np.ndarray, frames: int, frame_rate_hz: float,
                       speed_range=(0.5, 1.2), turn_std_deg: float = 25.0,
                       bounds: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """(frames, 3): x, y and heading (deg) of a person walking among the ``valid`` floor points (M, 2).

    Heading follows a random walk whose increments are smoothed (an Ornstein-Uhlenbeck turn rate), at a
    constant speed drawn from ``speed_range`` m/s; a step that would leave the valid area (farther than
    0.25 m from every valid point, or outside ``bounds`` (min, max)) turns the walker toward the valid
    area's centroid; if that step is no better, the walker pauses for the frame (it never leaves).
    """
    from scipy.spatial import cKDTree

    tree = cKDTree(valid)
    dt = 1.0 / frame_rate_hz
    speed = rng.uniform(*speed_range)
    pos = valid[rng.integers(len(valid))].astype(np.float64)
    heading = rng.uniform(0, 2 * np.pi)
    rate = 0.0
    center = valid.mean(axis=0)

    def ok(p: np.ndarray) -> bool:
        inside = bounds is None or bool(np.all(p >= bounds[0]) and np.all(p <= bounds[1]))
        return inside and tree.query(p)[0] <= 0.25

    out = np.zeros((frames, 3))
    for k in range(frames):
        out[k] = pos[0], pos[1], np.degrees(heading) % 360
        rate = 0.7 * rate + rng.normal(0, np.radians(turn_std_deg))
        heading += rate * dt
        step = speed * dt * np.array([np.cos(heading), np.sin(heading)])
        if not ok(pos + step):
            to_c = center - pos
            heading = np.arctan2(to_c[1], to_c[0]) + rng.normal(0, 0.3)
            rate = 0.0
            step = speed * dt * np.array([np.cos(heading), np.sin(heading)])
        if ok(pos + step):
            pos = pos + step
    return out
