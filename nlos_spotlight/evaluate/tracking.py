"""Savitzky-Golay smoothing of a tracked floor trajectory (the paper's Fig. 5).

A Savitzky-Golay filter fits a polynomial of degree ``order`` by least squares to every
``window`` consecutive frames and keeps its value at the middle frame; at both ends the
polynomial fitted to the first / last window is evaluated (``scipy.signal.savgol_filter``'s
``mode='interp'``), so no frame is padded with invented positions. Two consequences the tests
check: a trajectory that is itself a polynomial of degree <= ``order`` comes out unchanged, and
zero-mean per-frame noise is averaged down (the filter's gain on white noise is below one).

``nlos predict`` smooths the positions of a frame sequence with it and ``nlos evaluate`` its
walking trajectories.
"""

from __future__ import annotations

import numpy as np

from ..errors import NlosError

DEFAULT_ORDER = 2
"""Polynomial degree: a walking person turns smoothly, so a quadratic per window follows curves
without chasing frame-to-frame noise (the order the evaluation report uses)."""


def default_window(num_frames: int, order: int = DEFAULT_ORDER) -> int:
    """A window length for ``num_frames`` frames: about a fifth of the sequence, odd, at least 5
    (and more than ``order``), at most the longest odd length that fits.

    A fifth keeps a 30-frame walk (6 s at 5 Hz) smoothed over 7 frames, long enough to halve the
    noise of a quadratic fit yet short enough to follow a turn.

    Raises:
        NlosError: fewer frames than the shortest valid window.
    """
    longest = num_frames if num_frames % 2 else num_frames - 1
    shortest = max(5, order + 1 if order % 2 == 0 else order + 2)  # odd and > order
    if longest < shortest:
        raise NlosError(f"smoothing: {num_frames} frames are too few for order {order} "
                        f"(need at least {shortest})")
    fifth = int(round(num_frames / 5))
    fifth += 1 - fifth % 2
    return int(min(longest, max(shortest, fifth)))


def smooth_trajectory(xy: np.ndarray, window: int | None = None, order: int = DEFAULT_ORDER) -> np.ndarray:
    """Savitzky-Golay smoothing of each coordinate of a trajectory over time.

    Args:
        xy: (N, 2) positions (m), one row per frame in time order; finite.
        window: odd number of frames per local fit, ``order < window <= N``; None picks
            :func:`default_window` of N.
        order: polynomial degree of the local fits, >= 0.

    Returns:
        (N, 2) float64 smoothed positions.

    Raises:
        NlosError: wrong shape, non-finite values, or a window/order that does not fit.
    """
    from scipy.signal import savgol_filter

    a = np.asarray(xy, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 2:
        raise NlosError(f"smoothing: expected positions of shape (N, 2), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise NlosError("smoothing: positions contain NaN or infinity")
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 0:
        raise NlosError(f"smoothing: order must be a non-negative integer, got {order!r}")
    if window is None:
        window = default_window(len(a), int(order))
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)):
        raise NlosError(f"smoothing: window must be an integer, got {window!r}")
    if window % 2 == 0:
        raise NlosError(f"smoothing: window must be odd (the fit is centered on a frame), got {window}")
    if window <= order:
        raise NlosError(f"smoothing: window {window} must exceed the order {order}")
    if window > len(a):
        raise NlosError(f"smoothing: window {window} is longer than the {len(a)} frames")
    return savgol_filter(a, int(window), int(order), axis=0, mode="interp")
