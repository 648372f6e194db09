"""Savitzky-Golay trajectory smoothing: exact on low-degree polynomials, lower error on noisy walks."""

from __future__ import annotations

import numpy as np
import pytest

from nlos_spotlight.errors import NlosError
from nlos_spotlight.evaluate.tracking import default_window, smooth_trajectory


def _poly_track(n: int, degree: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.linspace(-1.0, 2.0, n)
    coef = rng.normal(size=(2, degree + 1))
    return np.stack([np.polyval(coef[0], t), np.polyval(coef[1], t)], axis=1)


@pytest.mark.parametrize("order,window", [(0, 5), (1, 5), (2, 5), (2, 9), (3, 7), (4, 11)])
def test_polynomials_up_to_the_order_pass_unchanged(order, window):
    for degree in range(order + 1):
        xy = _poly_track(23, degree, seed=degree)
        # every frame, the two ends included: the end windows are fitted, not padded
        np.testing.assert_allclose(smooth_trajectory(xy, window, order), xy, rtol=0, atol=1e-10)


def test_a_higher_degree_is_changed():
    xy = _poly_track(23, 5, seed=1)
    assert np.abs(smooth_trajectory(xy, 9, 2) - xy).max() > 1e-3


def test_smoothing_reduces_error_on_a_noisy_walk():
    rng = np.random.default_rng(4)
    n = 60
    s = np.linspace(0.0, 1.0, n)
    true = np.stack([2.5 + 0.8 * np.cos(2.0 * s), 0.6 * np.sin(3.0 * s)], axis=1)  # a curving walk, m
    raw_err, smooth_err = [], []
    for _ in range(20):
        raw = true + rng.normal(scale=0.08, size=true.shape)  # 8 cm per-frame noise, like the paper's error
        raw_err.append(np.linalg.norm(raw - true, axis=1).mean())
        smooth_err.append(np.linalg.norm(smooth_trajectory(raw, default_window(n), 2) - true, axis=1).mean())
    # window 13, order 2: white-noise gain about 0.44 at the center frames, more at the ends
    assert np.mean(smooth_err) < 0.55 * np.mean(raw_err)
    assert max(s / r for s, r in zip(smooth_err, raw_err)) < 0.65


def test_default_window():
    assert [default_window(n) for n in (5, 6, 12, 30, 31, 60, 61)] == [5, 5, 5, 7, 7, 13, 13]
    assert default_window(7, order=5) == 7  # odd and above the order
    for n in (5, 8, 30, 100):
        w = default_window(n)
        assert w % 2 == 1 and 2 < w <= n
    with pytest.raises(NlosError, match="too few"):
        default_window(4)
    np.testing.assert_allclose(smooth_trajectory(_poly_track(30, 2)), _poly_track(30, 2), atol=1e-10)


@pytest.mark.parametrize("xy,window,order,match", [
    (np.zeros((10, 3)), 5, 2, "shape"),
    (np.zeros(10), 5, 2, "shape"),
    (np.array([[0.0, 0.0]] * 4 + [[np.nan, 0.0]] + [[0.0, 0.0]] * 5), 5, 2, "NaN"),
    (np.zeros((10, 2)), 6, 2, "odd"),
    (np.zeros((10, 2)), 11, 2, "longer"),
    (np.zeros((10, 2)), 3, 3, "exceed"),
    (np.zeros((10, 2)), 5, -1, "order"),
    (np.zeros((10, 2)), 5.0, 2, "integer"),
])
def test_bad_input(xy, window, order, match):
    with pytest.raises(NlosError, match=match):
        smooth_trajectory(xy, window, order)
