"""Sensor model: closed-form statistics, saturation, quantization, auto-exposure, calibration."""

import math

import numpy as np
import pytest
import torch

from nlos_spotlight.render.sensor import (
    SensorConfig,
    auto_exposure,
    expected_dn,
    noise_variance_dn,
    sensor_capture,
    sensor_capture_native,
)

CFG = SensorConfig()
BATCH = 16  # 16 x 64 x 64 x 3 = 196608 independent samples per image
N = BATCH * CFG.height * CFG.width * 3
EXPOSURE = 1e-3


def constant_image(mean_e: float, cfg: SensorConfig = CFG, exposure: float = EXPOSURE) -> torch.Tensor:
    """Radiance image whose every value yields ``mean_e`` expected electrons."""
    level = mean_e / (exposure * cfg.electrons_per_radiance)
    return torch.full((BATCH, cfg.height, cfg.width, 3), level, dtype=torch.float64)


def gen(seed: int) -> torch.Generator:
    g = torch.Generator()
    g.manual_seed(seed)
    return g


def test_default_derivation_numbers():
    h, c = 6.62607015e-34, 299792458.0
    n = 4000.0**2 / 64**2  # square output: central 4000 x 4000 crop
    area = n * (3.9e-6) ** 2
    k = math.pi / (4 * 2.0**2) * area * 0.5 * 550e-9 / (h * c)
    assert CFG.binned_pixels == pytest.approx(3906.25, rel=1e-12)
    assert CFG.electrons_per_radiance == pytest.approx(k, rel=1e-12)
    assert CFG.electrons_per_radiance == pytest.approx(1.61501e10, rel=1e-5)
    assert CFG.full_well_binned_e == pytest.approx(26000 * 3906.25, rel=1e-12)
    assert CFG.read_noise_binned_e == pytest.approx(2.5 * 62.5, rel=1e-12)
    assert CFG.gain == pytest.approx((16383 - 512) / 26000, rel=1e-12)
    assert CFG.full_scale_dn == pytest.approx(3906.25 * (16383 - 512), rel=1e-12)
    assert CFG.quantization_variance_dn2 == pytest.approx(3906.25 / 12, rel=1e-12)


def test_binning_uses_full_sensor_for_3_to_2_output():
    cfg = SensorConfig(width=96, height=64)
    assert cfg.binned_pixels == pytest.approx(6000 * 4000 / (96 * 64), rel=1e-12)


# read-noise dominated (shot var 4 % of total), balanced, shot-noise dominated (read var 2.4 %)
@pytest.mark.parametrize("mean_e", [1e3, 2.5e4, 1e6])
def test_unquantized_mean_and_variance_match_closed_form(mean_e):
    out = sensor_capture(constant_image(mean_e), EXPOSURE, CFG, generator=gen(1), quantize=False)
    assert out.saturated_fraction == 0.0
    dn = out.dn.double().flatten()
    g = CFG.gain
    var_true = g**2 * (mean_e + CFG.read_noise_binned_e**2)
    torch.testing.assert_close(noise_variance_dn(torch.tensor(g * mean_e, dtype=torch.float64), CFG),
                               torch.tensor(var_true + CFG.quantization_variance_dn2, dtype=torch.float64))
    # 4 standard errors of the mean
    assert abs(dn.mean().item() - g * mean_e) < 4 * math.sqrt(var_true / N)
    # sample variance: std ~ sqrt(2 / (n - 1)) * var (chi-square; excess kurtosis mu/var^2 ~ 0)
    assert abs(dn.var().item() - var_true) < 4 * math.sqrt(2 / (N - 1)) * var_true


def test_read_noise_regime_is_distinguished():
    """The variance at low light must include the shot term, not read noise alone."""
    mean_e = 1e3
    out = sensor_capture(constant_image(mean_e), EXPOSURE, CFG, generator=gen(2), quantize=False)
    read_only = CFG.gain**2 * CFG.read_noise_binned_e**2
    # shot term is 4.1 % of read variance; the tolerance is 1.3 %
    assert out.dn.double().var().item() > read_only * (1 + 4 * math.sqrt(2 / (N - 1)))


def test_radiance_estimate_is_dn_over_gain_exposure():
    levels = torch.linspace(0, 1.5, CFG.height * CFG.width * 3, dtype=torch.float64)
    rad = (levels * CFG.full_scale_dn / (EXPOSURE * CFG.electrons_per_radiance * CFG.gain)).reshape(
        CFG.height, CFG.width, 3)
    out = sensor_capture(rad, EXPOSURE, CFG, generator=gen(3))
    assert out.dn.max().item() <= CFG.full_scale_dn
    expect = out.dn / (CFG.gain * EXPOSURE * CFG.electrons_per_radiance)
    torch.testing.assert_close(out.radiance, expect)
    # a value clips where its mean exceeds full scale (1.5 x at the top of the ramp)
    assert out.clipped.shape == (CFG.height, CFG.width)
    assert bool(out.clipped[-1, -1]) and not bool(out.clipped[0, 0])


def test_saturation_clips_at_full_scale():
    out = sensor_capture(constant_image(3 * CFG.full_well_binned_e), EXPOSURE, CFG, generator=gen(4))
    assert out.saturated_fraction == 1.0
    assert torch.all(out.dn == CFG.full_scale_dn)
    assert bool(out.clipped.all())


def test_average_metering_places_the_mean_at_18_percent():
    torch.manual_seed(0)
    ref = torch.rand(CFG.height, CFG.width, 3, dtype=torch.float64) ** 3 * 1e-2
    t = auto_exposure(ref, CFG)
    assert CFG.min_exposure_s < t < CFG.max_exposure_s
    assert expected_dn(ref, t, CFG).mean().item() == pytest.approx(0.18 * CFG.full_scale_dn, rel=1e-9)


def test_a_lamp_in_view_does_not_set_the_average_exposure():
    """The revised metering: one bright pixel barely moves the exposure; highlight metering collapses."""
    wall = torch.full((CFG.height, CFG.width, 3), 1e-2, dtype=torch.float64)
    lamp = wall.clone()
    lamp[:8, :8] = 1.0  # a lamp 100x brighter than the wall on 1.6 % of the frame
    avg = auto_exposure(lamp, CFG) / auto_exposure(wall, CFG)
    high = SensorConfig(metering="highlight")
    assert avg == pytest.approx(1 / (1 + 99 * 64 / 4096), rel=1e-9)  # 0.39: the mean moves a little
    assert auto_exposure(lamp, high) / auto_exposure(wall, high) == pytest.approx(0.01, rel=1e-6)


def test_highlight_metering_places_percentile_at_target():
    cfg = SensorConfig(metering="highlight")
    torch.manual_seed(0)
    ref = torch.rand(CFG.height, CFG.width, 3, dtype=torch.float64) ** 3 * 0.05
    t = auto_exposure(ref, cfg)
    assert cfg.min_exposure_s < t < cfg.max_exposure_s
    p = np.percentile(expected_dn(ref, t, cfg).numpy(), 99.5)
    assert p == pytest.approx(0.8 * cfg.full_scale_dn, rel=1e-4)


def test_auto_exposure_clamps_dark_and_bright():
    dark = torch.full((CFG.height, CFG.width, 3), 1e-12)
    assert auto_exposure(dark, CFG) == CFG.max_exposure_s
    assert auto_exposure(torch.zeros(CFG.height, CFG.width, 3), CFG) == CFG.max_exposure_s
    bright = torch.full((CFG.height, CFG.width, 3), 1e6)
    assert auto_exposure(bright, CFG) == CFG.min_exposure_s
    assert CFG.for_tracking(5.0).max_exposure_s == 0.2


def test_auto_exposure_has_no_gradient():
    ref = torch.rand(CFG.height, CFG.width, 3, requires_grad=True) + 0.01
    assert isinstance(auto_exposure(ref, CFG), float)


@pytest.mark.parametrize("value", [-1.0, float("nan"), float("inf")])
def test_auto_exposure_rejects_negative_or_non_finite(value):
    ref = torch.ones(CFG.height, CFG.width, 3)
    ref[0, 0, 0] = value
    with pytest.raises(ValueError, match="^sensor: "):
        auto_exposure(ref, CFG)


def test_same_seed_same_capture_other_seed_differs():
    rad = constant_image(1e4)[:2]
    a = sensor_capture(rad, EXPOSURE, CFG, generator=gen(7), quantize=False)
    b = sensor_capture(rad, EXPOSURE, CFG, generator=gen(7), quantize=False)
    c = sensor_capture(rad, EXPOSURE, CFG, generator=gen(8), quantize=False)
    assert torch.equal(a.dn, b.dn)
    assert not torch.equal(a.dn, c.dn)


@pytest.mark.parametrize("value", [-1.0, float("nan"), float("inf")])
def test_capture_rejects_bad_radiance(value):
    rad = torch.ones(CFG.height, CFG.width, 3)
    rad[3, 4, 1] = value
    with pytest.raises(ValueError, match="^sensor: radiance has negative or non-finite values$"):
        sensor_capture(rad, EXPOSURE, CFG)


def test_expected_dn_is_differentiable():
    rad = torch.rand(CFG.height, CFG.width, 3, requires_grad=True)
    expected_dn(rad, EXPOSURE, CFG).sum().backward()
    k = EXPOSURE * CFG.electrons_per_radiance * CFG.gain
    torch.testing.assert_close(rad.grad, torch.full_like(rad, k))


def test_from_dict_roundtrip_and_errors():
    cfg = SensorConfig.from_dict({"width": 32, "height": 32, "f_number": 2.8})
    assert (cfg.width, cfg.f_number) == (32, 2.8)
    with pytest.raises(ValueError, match="^sensor: unknown key 'foo'$"):
        SensorConfig.from_dict({"foo": 1})
    for key, bad in [("f_number", -2.0), ("read_noise_e", float("nan")), ("full_well_e", 0.0), ("width", 0),
                     ("metering", "spot"), ("burst_frames", 0), ("black_level_dn", -1)]:
        with pytest.raises(ValueError, match=f"^sensor: {key} "):
            SensorConfig.from_dict({key: bad})


# A small native crop simulated photosite by photosite: 8 x 8 native pixels binned to 2 x 2 (n = 16).
SMALL = SensorConfig(width=2, height=2, native_width=8, native_height=8)


@pytest.mark.parametrize("mean_native_e,frames", [(0.3, 1), (4.0, 1), (400.0, 1), (4.0, 4), (20000.0, 2)])
def test_binned_noise_matches_brute_force_native_simulation(mean_native_e, frames):
    """Variance of the binned sum of quantized native codes: brute force vs the closed form and the fast path.

    At 0.3 e- per native pixel quantization (n/12 = 1.33 DN^2) is 14 % of the variance and the
    shot term 5 %; a binned-then-quantized camera would get 1/12 instead of n/12.
    """
    cfg = SensorConfig(width=2, height=2, native_width=8, native_height=8, burst_frames=frames)
    n = cfg.binned_pixels
    assert n == 16
    level = mean_native_e * n / (EXPOSURE * cfg.electrons_per_radiance)
    rad = torch.full((4096, 2, 2, 3), level, dtype=torch.float64)  # 49152 values
    m = rad.numel()
    native = sensor_capture_native(rad, EXPOSURE, cfg, generator=gen(11)).dn.double().flatten()
    fast = sensor_capture(rad, EXPOSURE, cfg, generator=gen(12)).dn.double().flatten()
    mean = cfg.gain * n * mean_native_e
    var = float(noise_variance_dn(torch.tensor(mean, dtype=torch.float64), cfg))
    for dn in (native, fast):
        assert abs(dn.mean().item() - mean) < 5 * math.sqrt(var / m) + 1e-9
        # chi-square: std of the sample variance ~ sqrt(2 / (m - 1)) var (plus kurtosis slack)
        assert abs(dn.var().item() - var) < 6 * math.sqrt(2 / (m - 1)) * var
    # the old model (quantizing the binned sum once) is rejected at the lowest light
    if mean_native_e < 1:
        old = (cfg.gain**2 * (n * mean_native_e + n * cfg.read_noise_e**2) + 1 / 12) / frames
        assert abs(native.var().item() - old) > 6 * math.sqrt(2 / (m - 1)) * var


def test_native_reference_clips_each_photosite():
    cfg = SMALL
    level = 3 * cfg.full_well_e * cfg.binned_pixels / (EXPOSURE * cfg.electrons_per_radiance)
    out = sensor_capture_native(torch.full((2, 2, 3), level, dtype=torch.float64), EXPOSURE, cfg, generator=gen(5))
    assert torch.all(out.dn == cfg.full_scale_dn)
    assert bool(out.clipped.all())


def test_one_way_to_a_sensor():
    """``SensorConfig.at``: defaults, then each overrides mapping in order (later wins), at (H, W);
    ``for_scene`` is it at the camera's resolution with the scene's block first."""
    from types import SimpleNamespace

    from nlos_spotlight.render.sensor import SensorConfig

    d = SensorConfig()
    s = SensorConfig.at((24, 32), {"burst_frames": 4, "f_number": 2.8}, None, {"burst_frames": 16})
    assert (s.height, s.width, s.burst_frames, s.f_number) == (24, 32, 16, 2.8)
    assert s.read_noise_e == d.read_noise_e
    cam = SimpleNamespace(width=32, height=24)
    scene = SimpleNamespace(camera=cam, sensor={"burst_frames": 4, "f_number": 2.8})
    assert SensorConfig.for_scene(scene, {"burst_frames": 16}) == s
