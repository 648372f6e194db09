"""Camera sensor model: linear radiance images -> digital numbers (DN), captured as a photographer would.

Physics chain, per *native* photosite and per RGB channel (image tensors are ``(..., H, W, 3)``,
radiance in W sr^-1 m^-2, each channel carrying the radiance of its own band):

1. expected electrons  mu = L * t * k_n, ``k_n`` electrons per radiance per second of one photosite;
2. shot noise          e ~ Poisson(mu);
3. read noise          e += Normal(0, sigma_r), sigma_r = ``cfg.read_noise_e``;
4. conversion          code = g * e + black, g = ``cfg.gain`` (DN per e-), black = ``black_level_dn``;
5. saturation          code = clip(code, 0, 2^bits - 1);
6. quantization        code = round(code) (integer ADC codes, ``bit_depth`` bits).

**Binning happens after quantization** (DESIGN section 6, revised): an output pixel is the sum of
the n black-subtracted native codes of its footprint, so its noise variance in DN^2 is

    var = g^2 (mu_bin + n sigma_r^2) + n / 12,      mu_bin = n mu (binned electrons),

(:func:`noise_variance_dn`), not the 1/12 of a quantized binned code. Full scale of an output pixel
is n (2^bits - 1 - black). A still capture may average ``burst_frames`` frames (variance / N).

:func:`sensor_capture` samples that chain in closed form per output pixel (the sum of n Poisson
counts is Poisson; the read and quantization terms are Gaussian with their exact variance), and
:func:`sensor_capture_native` simulates every native photosite explicitly (the slow reference,
for small crops); the tests hold them to the same statistics.

**Metering** (:func:`auto_exposure`), from the person-free frame as a camera's average mode does:
the mean of the frame lands at ``target_mean_fraction`` (18 %) of full scale, the exposure capped
by ``max_exposure_s`` (tripod, still subject: 1 s; tracking: one frame period, see
:meth:`SensorConfig.for_tracking`). Highlights (the spot, lamps, monitors) may clip; clipped pixels
are flagged (:attr:`SensorOutput.clipped`). ``metering="highlight"`` keeps the first version's
rule (99.5th percentile at 80 % of full scale), which let a lamp or the spot set the exposure.

The network downstream gets ``DN / (g * t * k)``, a noisy radiance estimate in the input's units.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields

import torch

from ..errors import NlosError

PLANCK_J_S = 6.62607015e-34
"""Planck constant h (exact, SI 2019)."""
LIGHT_SPEED_M_S = 299792458.0
"""Speed of light c (exact)."""
METERING = ("average", "highlight")
"""Metering modes of :func:`auto_exposure`."""


@dataclass
class SensorConfig:
    """APS-C mirrorless camera (Sony a6000 class) behind a 35 mm f/2 lens, binned to ``width x height``.

    Native sensor: 23.5 x 15.6 mm, 6000 x 4000 pixels at 3.9 um pitch
    (6000 * 3.9 um = 23.4 mm), ~26k e- full well, ~2.5 e- read noise,
    QE ~0.5, 14-bit ADC with a black level of 512 codes. The focal length only
    sets the field of view, which the render camera owns; the photometry
    below needs just the f-number.

    Binning. The output image takes the largest centered crop of the native
    sensor with the output's aspect ratio: a square 64 x 64 output uses the
    central 4000 x 4000 pixels; a 3:2 output uses all 6000 x 4000. Each output
    pixel then sums

        n = crop_w * crop_h / (W * H) = 4000^2 / 64^2 = 3906.25 native pixels

    (a non-integer count means bin edges cut native pixels; we treat the bin
    as a continuous area). The native codes are summed after quantization
    (a RAW file binned in software), so the collecting area and the full
    scale grow n-fold and read and quantization noise add in quadrature:

        A_pix     = n * (3.9e-6 m)^2 = 5.9414e-8 m^2
        read var  = n * sigma_r^2 (e-^2),  quantization var = n / 12 (DN^2)

    Electrons per radiance. A lossless lens at f-number N imaging a distant,
    on-axis Lambertian patch of radiance L gives image-plane irradiance
    E = L * pi / (4 N^2) (cos^4 falloff and lens transmission ignored).
    Photons per joule at wavelength lambda are lambda / (h c); each RGB
    channel is treated as carrying its band's radiance, all converted at
    lambda = 550 nm. So the electrons a binned pixel collects in time t are

        e = L * (pi / (4 N^2)) * A_pix * t * QE * lambda / (h c)

        pi / (4 * 2^2)             = 0.196350 (sr)
        h c / 550 nm               = 3.61172e-19 J  -> 2.76876e18 photons/J
        k = 0.196350 * 5.9414e-8 * 0.5 * 2.76876e18
          = 1.61501e10 e- per (W sr^-1 m^-2) per second.

    Sanity: an indoor white wall near 100 cd/m^2 is ~0.15 W sr^-1 m^-2
    (at 683 lm/W), ~0.05 per channel; a native pixel fills its 26k e- well in
    26000 * 3906.25 / (0.05 * 1.61501e10) = 0.13 s.

    Gain (base ISO): the native full well maps onto the codes above the black
    level, g = (16383 - 512) / 26000 = 0.6104 DN/e-; read noise is then
    1.53 DN rms per native pixel, above the ADC step (0.29 DN rms).
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
    black_level_dn: int = 512
    """ADC code of zero signal (a6000 RAW: 512), so read noise below it is not clipped."""
    wavelength_m: float = 550e-9
    """Wavelength used to turn joules into photons for every channel."""
    min_exposure_s: float = 1e-4
    """Shortest exposure auto-exposure may choose, seconds."""
    max_exposure_s: float = 1.0
    """Longest exposure the setup allows: 1 s on a tripod with a still subject (tracking: one frame period)."""
    metering: str = "average"
    """'average': frame mean at target_mean_fraction of full scale; 'highlight': the old percentile rule."""
    target_mean_fraction: float = 0.18
    """Fraction of full scale the person-free frame's mean is exposed to (average metering)."""
    target_percentile: float = 99.5
    """Highlight metering: percentile of the reference placed at target_fraction of full scale."""
    target_fraction: float = 0.8
    """Highlight metering: fraction of full scale for that percentile."""
    burst_frames: int = 1
    """Frames averaged per still capture (the background capture uses the same number)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name == "metering":
                continue
            _check_positive(f.name, getattr(self, f.name), int_only=f.type in ("int", int),
                            allow_zero=f.name == "black_level_dn")
        if self.metering not in METERING:
            raise NlosError(f"sensor: metering must be one of {', '.join(METERING)}, got {self.metering!r}")
        if self.bit_depth > 24:
            raise NlosError(f"sensor: bit_depth must be at most 24, got {self.bit_depth}")
        if self.black_level_dn >= self.max_code:
            raise NlosError(f"sensor: black_level_dn must be below the largest code {self.max_code}, "
                            f"got {self.black_level_dn}")
        for name in ("quantum_efficiency", "target_fraction", "target_mean_fraction"):
            if getattr(self, name) > 1:
                raise NlosError(f"sensor: {name} must be at most 1, got {getattr(self, name)}")
        if self.target_percentile > 100:
            raise NlosError(f"sensor: target_percentile must be at most 100, got {self.target_percentile}")
        if self.burst_frames > 10000:
            raise NlosError(f"sensor: burst_frames must be at most 10000, got {self.burst_frames}")
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
        """Build from a config mapping; unknown keys and bad values raise a one-line error."""
        if not isinstance(d, dict):
            raise NlosError(f"sensor: expected a mapping of sensor settings, got {type(d).__name__}")
        known = {f.name for f in fields(cls)}
        for key in d:
            if key not in known:
                raise NlosError(f"sensor: unknown key '{key}'")
        return cls(**d)

    @classmethod
    def at(cls, image_shape: tuple[int, int], *overrides: dict | None) -> "SensorConfig":
        """The one way to a photograph's sensor: the defaults, then each mapping of ``overrides`` in
        order (a scene's ``sensor`` block, a run's capture settings such as ``burst_frames``), at
        image (H, W). Procedural scenes carry no overrides."""
        merged: dict = {}
        for o in overrides:
            merged.update(o or {})
        h, w = image_shape
        return cls.from_dict({**merged, "width": w, "height": h})

    @classmethod
    def for_scene(cls, scene, overrides: dict | None = None) -> "SensorConfig":
        """:meth:`at` the camera's resolution with the scene's ``sensor`` block, then ``overrides``."""
        return cls.at((scene.camera.height, scene.camera.width), getattr(scene, "sensor", None), overrides)

    def for_tracking(self, frame_rate_hz: float) -> "SensorConfig":
        """Settings for one video frame per time step: exposure at most one frame period, no burst."""
        longest = min(self.max_exposure_s, 1.0 / frame_rate_hz)
        return dataclasses.replace(self, max_exposure_s=longest, min_exposure_s=min(self.min_exposure_s, longest),
                                   burst_frames=1)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

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
        """Expected e- of one binned pixel per second per W sr^-1 m^-2: (pi / (4 N^2)) A_pix QE lambda / (h c)."""
        solid_angle_factor = math.pi / (4 * self.f_number**2)
        photons_per_joule = self.wavelength_m / (PLANCK_J_S * LIGHT_SPEED_M_S)
        return solid_angle_factor * self.pixel_area_m2 * self.quantum_efficiency * photons_per_joule

    @property
    def full_well_binned_e(self) -> float:
        """Full well of one binned pixel: the native wells add."""
        return self.full_well_e * self.binned_pixels

    @property
    def read_noise_binned_e(self) -> float:
        """Read noise std of one binned pixel in e-: independent native read noises add in quadrature."""
        return self.read_noise_e * math.sqrt(self.binned_pixels)

    @property
    def max_code(self) -> int:
        """Largest ADC code, 2^bit_depth - 1."""
        return 2**self.bit_depth - 1

    @property
    def native_full_scale_dn(self) -> int:
        """Largest black-subtracted code of one native pixel."""
        return self.max_code - self.black_level_dn

    @property
    def gain(self) -> float:
        """DN per electron at base ISO: the native full well maps onto the codes above black."""
        return self.native_full_scale_dn / self.full_well_e

    @property
    def full_scale_dn(self) -> float:
        """Saturation level of one binned pixel in DN (black-subtracted): n native full scales."""
        return self.binned_pixels * self.native_full_scale_dn

    @property
    def quantization_variance_dn2(self) -> float:
        """Variance of the rounding of n native codes, n / 12 DN^2 (one ADC step each)."""
        return self.binned_pixels / 12.0


@dataclass
class SensorOutput:
    """One simulated capture (a burst of ``burst_frames`` frames averaged)."""

    dn: torch.Tensor
    """(..., H, W, 3) binned digital numbers, black-subtracted, averaged over the burst."""
    radiance: torch.Tensor
    """(..., H, W, 3) DN converted back to radiance units, DN / (gain * t * k)."""
    exposure_s: float
    """Exposure time of each frame, seconds."""
    saturated_fraction: float
    """Fraction of values (pixels x channels) clipped at full scale."""
    clipped: torch.Tensor | None = None
    """(..., H, W) bool: the pixel clipped in some channel (the flag a network sees)."""


def _check_positive(name: str, value: object, int_only: bool, allow_zero: bool = False) -> None:
    """Config values must be positive finite numbers (integers for integer fields)."""
    ok_type = isinstance(value, int) if int_only else isinstance(value, (int, float))
    if isinstance(value, bool) or not ok_type:
        kind = "an integer" if int_only else "a number"
        raise NlosError(f"sensor: {name} must be {kind}, got {value!r}")
    if not math.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        raise NlosError(f"sensor: {name} must be {'non-negative' if allow_zero else 'positive'} and finite, "
                        f"got {value!r}")


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


def dn_per_radiance(exposure_s: float, cfg: SensorConfig):
    """DN of one binned pixel per radiance unit at ``exposure_s`` (a float or a tensor of exposures)."""
    return exposure_s * cfg.electrons_per_radiance * cfg.gain


def expected_dn(radiance: torch.Tensor, exposure_s: float, cfg: SensorConfig) -> torch.Tensor:
    """Noise-free mean DN, L * t * k * gain, before clipping and quantization (differentiable).

    Shape is checked but values are not, so a training loop pays no device sync.
    """
    rad = _as_image(radiance, cfg, "radiance")
    return rad * dn_per_radiance(_check_exposure(exposure_s), cfg)


def noise_variance_dn(mean_dn: torch.Tensor, cfg: SensorConfig) -> torch.Tensor:
    """Variance (DN^2) of one binned pixel of one burst capture whose mean is ``mean_dn``.

    Shot g * mean, read g^2 n sigma_r^2, quantization n / 12 (per native code), divided by the
    number of frames averaged. The one noise model image formation and the SNR share.
    """
    per_frame = cfg.gain * mean_dn.clamp(min=0) + (cfg.gain * cfg.read_noise_binned_e) ** 2 \
        + cfg.quantization_variance_dn2
    return per_frame / cfg.burst_frames


def auto_exposure(reference: torch.Tensor, cfg: SensorConfig) -> float:
    """Exposure (s) for the person-free ``reference`` frame under the config's metering mode.

    'average': mean(reference) * t * k * g = target_mean_fraction * full scale; 'highlight': the
    ``target_percentile`` at ``target_fraction`` of full scale. Clamped to [min_exposure_s,
    max_exposure_s]; an all-black reference gets the longest exposure. No gradient flows.
    """
    with torch.no_grad():
        ref = _as_image(reference.detach(), cfg, "reference")
        if not bool(torch.isfinite(ref).all()) or bool((ref < 0).any()):
            raise NlosError("sensor: auto-exposure reference has negative or non-finite values")
        if cfg.metering == "average":
            level, fraction = float(ref.double().mean()), cfg.target_mean_fraction
        else:
            level, fraction = _percentile(ref, cfg.target_percentile), cfg.target_fraction
    if level <= 0:
        return cfg.max_exposure_s  # nothing to meter on: expose as long as allowed
    t = fraction * cfg.full_scale_dn / (level * cfg.electrons_per_radiance * cfg.gain)
    return min(max(t, cfg.min_exposure_s), cfg.max_exposure_s)


def clip_radiance(exposure_s: float, cfg: SensorConfig) -> float:
    """Radiance at which a binned pixel saturates at ``exposure_s``."""
    return cfg.full_scale_dn / dn_per_radiance(_check_exposure(exposure_s), cfg)


def sensor_capture(
    radiance: torch.Tensor,
    exposure_s: float,
    cfg: SensorConfig,
    generator: torch.Generator | None = None,
    quantize: bool = True,
) -> SensorOutput:
    """Simulate one capture (a burst of ``cfg.burst_frames`` frames averaged) of a radiance image.

    Per output pixel in closed form: the burst's binned electrons are Poisson(N n mu) exactly; read
    and quantization noise of the N n native values are Gaussian with their exact variances; the
    average clips at full scale. ``quantize=False`` leaves the quantization term out. Sampling
    uses ``generator`` (on the tensor's device). The result carries no gradient; use
    :func:`expected_dn` for a differentiable path.
    """
    rad = _as_image(radiance, cfg, "radiance")
    t = _check_exposure(exposure_s)
    n_frames = cfg.burst_frames
    with torch.no_grad():
        rad = rad.detach()
        _check_values(rad, "radiance")
        mean_e = rad * (t * cfg.electrons_per_radiance * n_frames)
        electrons = torch.poisson(mean_e, generator=generator)
        var_dn = n_frames * ((cfg.gain * cfg.read_noise_binned_e) ** 2
                             + (cfg.quantization_variance_dn2 if quantize else 0.0))
        eps = torch.randn(mean_e.shape, generator=generator, device=mean_e.device, dtype=mean_e.dtype)
        dn = (electrons * cfg.gain + math.sqrt(var_dn) * eps) / n_frames
        return _clipped_output(dn, t, cfg)


def _clipped_output(dn: torch.Tensor, t: float, cfg: SensorConfig) -> SensorOutput:
    full = cfg.full_scale_dn
    over = dn >= full
    dn = dn.clamp(max=full)
    est = dn / dn_per_radiance(t, cfg)
    frac = float(over.double().mean()) if dn.numel() else 0.0
    return SensorOutput(dn=dn, radiance=est, exposure_s=t, saturated_fraction=frac, clipped=over.any(dim=-1))


def sensor_capture_native(radiance: torch.Tensor, exposure_s: float, cfg: SensorConfig,
                          generator: torch.Generator | None = None) -> SensorOutput:
    """Slow reference of :func:`sensor_capture`: every native photosite of every frame, explicitly.

    For small crops only (``binned_pixels`` must be a whole number, e.g. an 8 x 8 native sensor
    binned to 2 x 2): each native pixel gets Poisson electrons, Gaussian read noise, the gain and
    black level, clipping to the code range and rounding; the black-subtracted codes of a bin are
    summed, and the frames of the burst averaged.
    """
    rad = _as_image(radiance, cfg, "radiance")
    t = _check_exposure(exposure_s)
    n = cfg.binned_pixels
    if abs(n - round(n)) > 1e-9 or n > 4096:
        raise NlosError(f"sensor: the native reference needs a whole, small bin size, got {n} pixels")
    n = int(round(n))
    with torch.no_grad():
        rad = rad.detach().double()
        _check_values(rad, "radiance")
        mu = rad * (t * cfg.electrons_per_radiance / n)  # per native pixel
        shape = (*mu.shape, cfg.burst_frames, n)
        e = torch.poisson(mu[..., None, None].expand(shape).contiguous(), generator=generator)
        e = e + cfg.read_noise_e * torch.randn(shape, generator=generator, dtype=e.dtype, device=e.device)
        code = torch.round((cfg.gain * e + cfg.black_level_dn).clamp(0, cfg.max_code))
        dn = (code - cfg.black_level_dn).sum(-1).mean(-1)
        return _clipped_output(dn, t, cfg)
