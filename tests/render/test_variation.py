"""Capture variation (render/variation.py, render/layers.py) against closed forms: a pure shift and
a pure roll of a ramp, pure gains, the draws' statistics, the fast change against its resampling
reference, and the layers against the renderer."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from nlos_spotlight.errors import NlosError
from nlos_spotlight.render.variation import (CaptureDraw, CaptureVariation, StaticLayers, difference_sigmas,
                                             draw_captures, load_layers, preset, save_layers)

F, H, W = 8, 6, 8


def ramp_layers(slope: float = 2.0, offset: float = 5.0, ambient: float = 0.0, dtype=torch.float64) -> StaticLayers:
    """Projector light a * x + b over the cells (x in output pixels from the left edge)."""
    x = (torch.arange(W * F, dtype=dtype) + 0.5) / F
    proj = (slope * x + offset).view(1, -1, 1).expand(H * F, W * F, 3).clone()
    return StaticLayers(proj, torch.zeros(2, H * F, W * F, 3, dtype=dtype), torch.full_like(proj, ambient), F, 20.0, 2.0)


def draw(n: int = 1, **kw) -> CaptureDraw:
    d = CaptureDraw.nominal(n, dtype=torch.float64)
    for k, v in kw.items():
        setattr(d, k, torch.as_tensor(v, dtype=torch.float64).reshape(getattr(d, k).shape))
    return d


@pytest.mark.parametrize("dx", [0.01, -0.1, 0.4])
def test_pure_shift_of_a_ramp(dx):
    """Pixel (r, c) of a capture shifted by dx shows the nominal view at c + dx: a ramp of slope a
    changes by a * dx away from the clamped border (small shifts: the first-order path; 0.4:
    resampled)."""
    L = ramp_layers()
    d = draw(shift=[dx, 0.0])
    for change in (L.change(d), L.static_image(d) - sum(L.nominal())):
        inner = change[0, :, 1:-1]
        assert torch.allclose(inner, torch.full_like(inner, 2.0 * dx), atol=1e-7)


def test_pure_roll_of_a_ramp():
    """Rolling by theta samples the nominal view at (cos t x - sin t y, sin t x + cos t y) about the
    centre: a ramp a x changes by a ((cos t - 1) x - sin t y) in every cell, hence in every pixel.
    Resampling is exact; the fast path is first order (its error (1 - cos t) / sin t ~ t / 2)."""
    L = ramp_layers()
    theta = 1e-3
    ys = torch.arange(H, dtype=torch.float64) + 0.5 - H / 2
    xs = torch.arange(W, dtype=torch.float64) + 0.5 - W / 2
    want = 2.0 * ((math.cos(theta) - 1) * xs[None, :] - math.sin(theta) * ys[:, None])[1:-1, 1:-1]
    d = draw(roll=[theta])
    exact = (L.static_image(d) - sum(L.nominal()))[0, 1:-1, 1:-1, 0]
    assert torch.allclose(exact, want, rtol=1e-9, atol=1e-12)
    assert torch.allclose(L.change(d)[0, 1:-1, 1:-1, 0], want, rtol=0, atol=1e-3 * float(want.abs().max()))


def test_pure_gains():
    """Projector gain g scales the projector light alone, room gain its ambient, exposure both."""
    L = ramp_layers(ambient=3.0)
    p, a = L.nominal()
    assert torch.allclose(L.change(draw(projector=[1.004]))[0], 0.004 * p, rtol=1e-9)
    assert torch.allclose(L.change(draw(ambient=[0.99]))[0], -0.01 * a, rtol=1e-9)
    assert torch.allclose(L.change(draw(exposure=[1.002]))[0], 0.002 * (p + a), rtol=1e-9)


def test_fast_change_matches_resampling():
    """The first-order change is the odd part of resampling in the motion, (r(+m) - r(-m)) / 2:
    exactly for a shift along one axis moving no cell by more than a cell; roll and shifts together
    add bilinear weights' x * y terms, and drawn gains their cross terms with the motion."""
    g = torch.Generator().manual_seed(1)
    fine = torch.rand(H * F, W * F, 3, generator=g, dtype=torch.float64)
    fine = torch.nn.functional.avg_pool2d(fine.permute(2, 0, 1)[None], 5, 1, 2)[0].permute(1, 2, 0)  # smooth
    L = StaticLayers(fine, 0.1 * fine.expand(2, -1, -1, -1).clone(), 0.3 * fine, F, 30.0, 2.5)
    base = sum(L.nominal())

    def odd(d):
        back = CaptureDraw(-d.shift, -d.roll, -d.aim, 2 - d.projector, 2 - d.ambient, 2 - d.exposure)
        return (L.static_image(d) - L.static_image(back)) / 2

    motion = draw_captures(preset("rough").only("camera-shift", "camera-roll").scaled(20), 32, 16, L.f_px,
                           L.depth_m, g, dtype=torch.float64)
    for axis in range(2):
        one = draw(32, shift=motion.shift * torch.eye(2, dtype=torch.float64)[axis])
        assert torch.allclose(L.change(one), odd(one), atol=1e-12, rtol=1e-9)
    assert float((L.change(motion) - odd(motion)).norm() / odd(motion).norm()) < 2e-2
    d = draw_captures(preset("rough"), 32, 16, L.f_px, L.depth_m, g, dtype=torch.float64)
    assert float((L.change(d) - odd(d)).norm() / (L.static_image(d) - base).norm()) < 3e-3


def test_draw_statistics():
    """Gains: sigma^2 = drift^2 + flicker^2 / N; shift: f_px sqrt(pointing^2 + jitter^2 / N +
    (translation / depth)^2); and two captures differ by sqrt(2) of that (difference_sigmas)."""
    v = preset("tripod")
    n, burst, f_px, depth = 40000, 16, 25.0, 2.0
    g = torch.Generator().manual_seed(0)
    a, b = (draw_captures(v, n, burst, f_px, depth, g, dtype=torch.float64) for _ in range(2))
    sig = difference_sigmas(v, burst, f_px, depth)
    diffs = [a.projector * a.exposure - b.projector * b.exposure, a.ambient * a.exposure - b.ambient * b.exposure,
             a.shift[:, 0] - b.shift[:, 0], a.shift[:, 1] - b.shift[:, 1], a.roll - b.roll, a.aim[:, 0] - b.aim[:, 0],
             a.aim[:, 1] - b.aim[:, 1]]
    for d, s in zip(diffs, sig):
        assert float(d.std()) == pytest.approx(s, rel=0.03)
    one = math.sqrt(v.projector_gain ** 2 + v.projector_flicker ** 2 / burst)
    assert float(a.projector.std()) == pytest.approx(one, rel=0.03)


def test_presets_and_errors():
    assert preset("ideal").is_ideal and not preset("tripod").is_ideal
    assert preset("rough").pointing_rad == pytest.approx(3 * preset("tripod").pointing_rad)
    only = preset("tripod").only("projector-gain")
    assert only.projector_gain > 0 and only.pointing_rad == 0 and only.ambient_gain == 0
    with pytest.raises(NlosError, match="unknown preset"):
        preset("shaky")
    with pytest.raises(NlosError, match="unknown effect"):
        preset("tripod").only("earthquake")
    with pytest.raises(NlosError, match="projector_gain"):
        CaptureVariation(projector_gain=float("nan"))


def test_layers_file_round_trip_and_damage(tmp_path):
    L = ramp_layers(dtype=torch.float32)
    save_layers(tmp_path / "layers.npz", L)
    back = load_layers(tmp_path / "layers.npz")
    assert torch.equal(back.projector, L.projector) and back.factor == F and back.f_px == L.f_px
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(NlosError, match="corrupted static layers"):
        load_layers(tmp_path / "bad.npz")
    with pytest.raises(NlosError, match="missing"):
        load_layers(tmp_path / "none.npz")


def test_layers_match_the_renderer(small_corner):
    """Binned layers at factor f with one sample a cell trace exactly the rays of the renderer at
    f x f sub-samples a pixel; the aim derivative agrees with a difference over a smaller step."""
    from nlos_spotlight.render.layers import static_layers
    from nlos_spotlight.render.settings import RenderSettings
    from nlos_spotlight.render.transport import Renderer

    r = Renderer(small_corner, RenderSettings(pixel_samples=4, dtype="float64"))
    face = int(np.argmax(r.D.sum((0, 2))))
    L = static_layers(small_corner, r.aim_points[face], factor=4, interreflection=False)
    p, a = L.nominal()
    y = r.spot_vector(face)
    assert torch.allclose(p.double(), r.render(y, components=("direct",)).image, rtol=1e-4, atol=1e-9)
    assert torch.allclose(a.double(), r.ambient_image, rtol=1e-4, atol=1e-9)
    fine = static_layers(small_corner, r.aim_points[face], factor=4, interreflection=False, aim_step_rad=1e-3)
    assert float((fine.aim - L.aim).norm() / L.aim.norm()) < 0.1
    assert float(L.aim.abs().max()) > 0
