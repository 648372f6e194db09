"""Sensor model: closed-form statistics, saturation, quantization, auto-exposure, calibration."""

import math

import numpy as np
import pytest
import torch

from nlos_spotlight.render.sensor import (
    SensorConfig,
    auto_exposure,
    expected_dn,
    sensor_capture,
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
    assert CFG.gain == pytest.approx(16383 / (26000 * 3906.25), rel=1e-12)
    assert CFG.full_scale_dn == 16383.0


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


def test_quantized_values_are_integer_codes_in_range():
    levels = torch.linspace(0, 1.5, CFG.height * CFG.width * 3, dtype=torch.float64)
    full_e = CFG.full_well_binned_e
    rad = (levels * full_e / (EXPOSURE * CFG.electrons_per_radiance)).reshape(CFG.height, CFG.width, 3)
    out = sensor_capture(rad, EXPOSURE, CFG, generator=gen(3))
    assert torch.equal(out.dn, torch.round(out.dn))
    assert out.dn.min().item() >= 0
    assert out.dn.max().item() <= CFG.full_scale_dn
    expect = out.dn / (CFG.gain * EXPOSURE * CFG.electrons_per_radiance)
    torch.testing.assert_close(out.radiance, expect)


def test_saturation_clips_at_full_scale():
    out = sensor_capture(constant_image(3 * CFG.full_well_binned_e), EXPOSURE, CFG, generator=gen(4))
    assert out.saturated_fraction == 1.0
    assert torch.all(out.dn == CFG.full_scale_dn)


def test_auto_exposure_places_percentile_at_target():
    torch.manual_seed(0)
    ref = torch.rand(CFG.height, CFG.width, 3, dtype=torch.float64) ** 3 * 0.05
    t = auto_exposure(ref, CFG)
    assert CFG.min_exposure_s < t < CFG.max_exposure_s
    p = np.percentile(expected_dn(ref, t, CFG).numpy(), 99.5)
    assert p == pytest.approx(0.8 * CFG.full_scale_dn, rel=1e-4)


def test_auto_exposure_clamps_dark_and_bright():
    dark = torch.full((CFG.height, CFG.width, 3), 1e-12)
    assert auto_exposure(dark, CFG) == CFG.max_exposure_s
    bright = torch.full((CFG.height, CFG.width, 3), 1e6)
    assert auto_exposure(bright, CFG) == CFG.min_exposure_s


def test_auto_exposure_has_no_gradient():
    ref = torch.rand(CFG.height, CFG.width, 3, requires_grad=True) + 0.01
    assert isinstance(auto_exposure(ref, CFG), float)


@pytest.mark.parametrize("value", [0.0, float("nan"), float("inf")])
def test_auto_exposure_rejects_zero_or_non_finite(value):
    ref = torch.zeros(CFG.height, CFG.width, 3)
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
    for key, bad in [("f_number", -2.0), ("read_noise_e", float("nan")), ("full_well_e", 0.0), ("width", 0)]:
        with pytest.raises(ValueError, match=f"^sensor: {key} "):
            SensorConfig.from_dict({key: bad})
