"""Camera sensor model: linear radiance images -> digital numbers (DN).

Physics chain, per output pixel and per RGB channel (image tensors are
``(..., H, W, 3)``, radiance in W sr^-1 m^-2, each channel carrying the
radiance of its own band):

1. expected electrons  mu = L * t * k, with ``k = cfg.electrons_per_radiance``
   (e- per W sr^-1 m^-2 per second, derived in :class:`SensorConfig`);
2. shot noise          n ~ Poisson(mu);
3. read noise          n += Normal(0, sigma_r), sigma_r = ``cfg.read_noise_binned_e``;
4. conversion          DN = g * n, g = ``cfg.gain`` (DN per e-), black level 0;
5. saturation          DN = clip(DN, 0, full scale), full scale =
                       min(binned full well * g, 2^bits - 1);
6. quantization        DN = round(DN) (integer ADC codes, ``bit_depth`` bits).

The network downstream gets ``DN / (g * t * k)``, a noisy radiance estimate in
the same units as the input. :func:`auto_exposure` picks ``t`` from a
noise-free reference image (the person-free scene) so that its 99.5th
percentile lands at 80 % of full scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import torch

from ..errors import NlosError

PLANCK_J_S = 6.62607015e-34
"""Planck constant h (exact, SI 2019)."""
LIGHT_SPEED_M_S = 299792458.0
"""Speed of light c (exact)."""


@dataclass
class SensorConfig:
    """APS-C mirrorless camera (Sony a6000 class) behind a 35 mm f/2 lens, binned to ``width x height``.

    Native sensor: 23.5 x 15.6 mm, 6000 x 4000 pixels at 3.9 um pitch
    (6000 * 3.9 um = 23.4 mm), ~26k e- full well, ~2.5 e- read noise,
    QE ~0.5, 14-bit ADC. The focal length only sets the field of view, which
    the render camera owns; the photometry below needs just the f-number.

    Binning. The output image takes the largest centered crop of the native
    sensor with the output's aspect ratio: a square 64 x 64 output uses the
    central 4000 x 4000 pixels (1000-pixel margins left and right); a 3:2
    output uses all 6000 x 4000. Each output pixel then sums

        n = crop_w * crop_h / (W * H) = 4000^2 / 64^2 = 3906.25 native pixels

    (62.5 x 62.5; a non-integer count means bin edges cut native pixels, and
    we treat the bin as a continuous area). Summing n pixels multiplies the
    collecting area and the full well by n, and read noise adds in quadrature:

        A_pix     = n * (3.9e-6 m)^2        = 5.9414e-8 m^2  (243.75 um pitch)
        full well = 26000 e- * 3906.25     = 1.015625e8 e-
        read noise= 2.5 e- * sqrt(3906.25) = 156.25 e-

    Electrons per radiance. A lossless lens at f-number N imaging a distant,
    on-axis Lambertian patch of radiance L gives image-plane irradiance
    E = L * pi / (4 N^2) (cos^4 falloff and lens transmission ignored).
    Photons per joule at wavelength lambda are lambda / (h c); each RGB
    channel is treated as carrying its band's radiance, all converted at
    lambda = 550 nm. So the electrons collected in time t are

        e = L * (pi / (4 N^2)) * A_pix * t * QE * lambda / (h c)

        pi / (4 * 2^2)             = 0.196350 (sr)
        h c / 550 nm               = 3.61172e-19 J  -> 2.76876e18 photons/J
        k = 0.196350 * 5.9414e-8 * 0.5 * 2.76876e18
          = 1.61501e10 e- per (W sr^-1 m^-2) per second.

    Sanity: an indoor white wall near 100 cd/m^2 is ~0.15 W sr^-1 m^-2
    (at 683 lm/W), ~0.05 per channel; it fills the binned well in
    1.015625e8 / (0.05 * 1.61501e10) = 0.13 s.

    Gain. Binning happens in the digital domain with renormalization: the
    output keeps the 14-bit code range and the gain maps the *binned* full
    well onto it, g = (2^14 - 1) / 1.015625e8 = 1.61310e-4 DN/e-
    (6199.3 e- per DN). One DN is then far above the binned read noise
    (156 e- = 0.025 DN), so in the dark the ADC step (1/sqrt(12) DN rms)
    dominates the read noise.
    """

    width: int = 64
    """Output image width in (binned) pixels."""
    height: int = 64
    """Output image height in (binned) pixels."""
    f_number: float = 2.0
    """Lens f-number N; image irradiance is L * pi / (4 N^2)."""
    native_pixel_pitch_m: float = 3.9e-6
    """Native photosite pitch in meters (a6000: 23.5 mm / 6000 px)."""
    native_width: int = 6000
    """Native sensor width in pixels."""
    native_height: int = 4000
    """Native sensor height in pixels."""
    quantum_efficiency: float = 0.5
    """Electrons per incident photon, averaged over a channel's band."""
    full_well_e: float = 26000.0
    """Full-well capacity of one native pixel in electrons."""
    read_noise_e: float = 2.5
    """Read noise (Gaussian std) of one native pixel in electrons."""
    bit_depth: int = 14
    """ADC bit depth; codes run 0 .. 2^bit_depth - 1."""
    wavelength_m: float = 550e-9
    """Wavelength used to turn joules into photons for every channel."""
    min_exposure_s: float = 1e-4
    """Shortest exposure auto-exposure may choose, seconds."""
    max_exposure_s: float = 1.0
    """Longest exposure auto-exposure may choose, seconds."""
    target_percentile: float = 99.5
    """Percentile of the reference image that auto-exposure places at target_fraction of full scale."""
    target_fraction: float = 0.8
    """Fraction of full scale (DN) the reference percentile is exposed to."""

    def __post_init__(self) -> None:
        for f in fields(self):
            _check_positive(f.name, getattr(self, f.name), int_only=f.type in ("int", int))
        # 24 bits is the largest code range float32 holds exactly
        if self.bit_depth > 24:
            raise NlosError(f"sensor: bit_depth must be at most 24, got {self.bit_depth}")
        for name in ("quantum_efficiency", "target_fraction"):
            if getattr(self, name) > 1:
                raise NlosError(f"sensor: {name} must be at most 1, got {getattr(self, name)}")
        if self.target_percentile > 100:
            raise NlosError(f"sensor: target_percentile must be at most 100, got {self.target_percentile}")
        if self.min_exposure_s > self.max_exposure_s:
            raise NlosError(
                f"sensor: min_exposure_s ({self.min_exposure_s}) exceeds max_exposure_s ({self.max_exposure_s})"
            )
        if self.binned_pixels < 1:
            raise NlosError(
                f"sensor: output {self.width}x{self.height} has more pixels than the native crop "
                f"{self.crop_size[0]}x{self.crop_size[1]}"
            )

    @classmethod
    def from_dict(cls, d: dict) -> "SensorConfig":
        """Build from a config mapping; unknown keys and bad values raise a one-line ValueError."""
        known = {f.name for f in fields(cls)}
        for key in d:
            if key not in known:
                raise NlosError(f"sensor: unknown key '{key}'")
        return cls(**d)

    @property
    def crop_size(self) -> tuple[float, float]:
        """(width, height) in native pixels of the centered crop with the output's aspect ratio."""
        if self.width * self.native_height >= self.height * self.native_width:
            # output is at least as wide as the sensor: keep full width
            return float(self.native_width), self.native_width * self.height / self.width
        return self.native_height * self.width / self.height, float(self.native_height)

    @property
    def binned_pixels(self) -> float:
        """Native pixels summed into one output pixel (3906.25 for 64x64)."""
        cw, ch = self.crop_size
        return cw * ch / (self.width * self.height)

    @property
    def pixel_area_m2(self) -> float:
        """Collecting area of one binned output pixel in m^2."""
        return self.binned_pixels * self.native_pixel_pitch_m**2

    @property
    def electrons_per_radiance(self) -> float:
        """Expected e- per second per W sr^-1 m^-2: (pi / (4 N^2)) * A_pix * QE * lambda / (h c)."""
        solid_angle_factor = math.pi / (4 * self.f_number**2)
        photons_per_joule = self.wavelength_m / (PLANCK_J_S * LIGHT_SPEED_M_S)
        return solid_angle_factor * self.pixel_area_m2 * self.quantum_efficiency * photons_per_joule

    @property
    def full_well_binned_e(self) -> float:
        """Full well of one binned pixel: the native wells add."""
        return self.full_well_e * self.binned_pixels

    @property
    def read_noise_binned_e(self) -> float:
        """Read noise std of one binned pixel: independent native read noises add in quadrature."""
        return self.read_noise_e * math.sqrt(self.binned_pixels)

    @property
    def max_code(self) -> int:
        """Largest ADC code, 2^bit_depth - 1."""
        return 2**self.bit_depth - 1

    @property
    def gain(self) -> float:
        """DN per electron; maps the binned full well onto the full code range (digital renormalization)."""
        return self.max_code / self.full_well_binned_e

    @property
    def full_scale_dn(self) -> float:
        """Saturation level in DN: min(binned full well * gain, max code), as an integer code."""
        # with the renormalizing gain both bounds coincide; the 1e-6 absorbs the
        # last-bit rounding of full_well * gain so the level stays an exact code
        return float(min(math.floor(self.full_well_binned_e * self.gain + 1e-6), self.max_code))


@dataclass
class SensorOutput:
    """One simulated capture."""

    dn: torch.Tensor
    """(..., H, W, 3) digital numbers (float tensor; integer values when quantized)."""
    radiance: torch.Tensor
    """(..., H, W, 3) DN converted back to radiance units, DN / (gain * t * k)."""
    exposure_s: float
    """Exposure time used, seconds."""
    saturated_fraction: float
    """Fraction of values (pixels x channels) clipped at full scale."""


def _check_positive(name: str, value: object, int_only: bool) -> None:
    """Config values must be positive finite numbers (integers for integer fields)."""
    ok_type = isinstance(value, int) if int_only else isinstance(value, (int, float))
    if isinstance(value, bool) or not ok_type:
        kind = "an integer" if int_only else "a number"
        raise NlosError(f"sensor: {name} must be {kind}, got {value!r}")
    if not math.isfinite(value) or value <= 0:
        raise NlosError(f"sensor: {name} must be positive and finite, got {value!r}")


def _as_image(x: torch.Tensor, cfg: SensorConfig, what: str) -> torch.Tensor:
    """Check the (..., H, W, 3) shape and promote to at least float32 (half precision loses electrons)."""
    if not isinstance(x, torch.Tensor):
        raise NlosError(f"sensor: {what} must be a torch.Tensor, got {type(x).__name__}")
    want = (cfg.height, cfg.width, 3)
    if x.dim() < 3 or tuple(x.shape[-3:]) != want:
        raise NlosError(f"sensor: {what} must have shape (..., {want[0]}, {want[1]}, 3), got {tuple(x.shape)}")
    return x.to(torch.promote_types(x.dtype, torch.float32))


def _check_values(x: torch.Tensor, what: str) -> None:
    """Reject negative, NaN and infinite values (Poisson rates must be finite and >= 0)."""
    if not bool(torch.isfinite(x).all()) or bool((x < 0).any()):
        raise NlosError(f"sensor: {what} has negative or non-finite values")


def _check_exposure(exposure_s: float) -> float:
    t = float(exposure_s)
    if not math.isfinite(t) or t <= 0:
        raise NlosError(f"sensor: exposure_s must be positive and finite, got {exposure_s!r}")
    return t


def _percentile(x: torch.Tensor, q: float) -> float:
    """numpy-style 'linear' percentile of all values; sort-based, so no torch.quantile size limit."""
    v = x.detach().flatten().double().sort().values
    pos = q / 100.0 * (v.numel() - 1)
    lo = math.floor(pos)
    hi = min(lo + 1, v.numel() - 1)
    w = pos - lo
    return float(v[lo] * (1 - w) + v[hi] * w)


def expected_dn(radiance: torch.Tensor, exposure_s: float, cfg: SensorConfig) -> torch.Tensor:
    """Noise-free mean DN, L * t * k * gain, before clipping and quantization (differentiable).

    Shape is checked but values are not, so a training loop pays no device sync.
    """
    rad = _as_image(radiance, cfg, "radiance")
    t = _check_exposure(exposure_s)
    return rad * (t * cfg.electrons_per_radiance * cfg.gain)


def auto_exposure(reference: torch.Tensor, cfg: SensorConfig) -> float:
    """Exposure (s) putting the reference's ``target_percentile`` at ``target_fraction`` of full scale.

    Solves p * t * k * gain = fraction * full_scale for t, clamped to
    [min_exposure_s, max_exposure_s]. No gradient flows through the choice.
    """
    with torch.no_grad():
        ref = _as_image(reference.detach(), cfg, "reference")
        if not bool(torch.isfinite(ref).all()) or bool((ref < 0).any()):
            raise NlosError("sensor: auto-exposure reference has negative or non-finite values")
        if not bool((ref > 0).any()):
            raise NlosError("sensor: auto-exposure reference image is all zero")
        p = _percentile(ref, cfg.target_percentile)
    if p <= 0:
        # fewer than (100 - percentile) % of values are lit: expose as long as allowed
        return cfg.max_exposure_s
    t = cfg.target_fraction * cfg.full_scale_dn / (p * cfg.electrons_per_radiance * cfg.gain)
    return min(max(t, cfg.min_exposure_s), cfg.max_exposure_s)


def sensor_capture(
    radiance: torch.Tensor,
    exposure_s: float,
    cfg: SensorConfig,
    generator: torch.Generator | None = None,
    quantize: bool = True,
) -> SensorOutput:
    """Simulate one noisy exposure of a radiance image (see the module docstring for the chain).

    Sampling uses ``generator`` (on the tensor's device) for reproducibility.
    The result carries no gradient; use :func:`expected_dn` for a
    differentiable path.
    """
    rad = _as_image(radiance, cfg, "radiance")
    t = _check_exposure(exposure_s)
    with torch.no_grad():
        rad = rad.detach()
        _check_values(rad, "radiance")
        mean_e = rad * (t * cfg.electrons_per_radiance)
        electrons = torch.poisson(mean_e, generator=generator)
        read = torch.randn(mean_e.shape, generator=generator, device=mean_e.device, dtype=mean_e.dtype)
        raw_dn = (electrons + read * cfg.read_noise_binned_e) * cfg.gain
        full = cfg.full_scale_dn
        saturated = float((raw_dn >= full).double().mean()) if raw_dn.numel() else 0.0
        dn = raw_dn.clamp(0.0, full)
        if quantize:
            # full is an integer code, so rounding after the clip stays in range
            dn = torch.round(dn)
        est = dn / (cfg.gain * t * cfg.electrons_per_radiance)
    return SensorOutput(dn=dn, radiance=est, exposure_s=t, saturated_fraction=saturated)
