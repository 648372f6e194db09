"""Capture variation (DESIGN section 6): what changes between the empty-room burst and the person
burst, and from frame to frame within one, on top of the sensor's noise (``render/sensor.py``).

The person's light is about 1e-4 of the room's, so a reading that subtracts two photographs sees
every change of the room's light between them. Each capture (a burst of N frames averaged) draws

* camera pointing: pan, tilt (image shift ``f_px * theta``), roll about the principal point, and a
  translation (a shift ``f_px * t / z`` at the view's median depth ``z``; parallax across depths
  is below 1e-3 of the shift at millimetres and metres, and is left out);
* projector gain (light output), spot aim (pan, tilt of the beam on its mount);
* ambient gain (the room's lamps, apart from the projector);
* exposure gain (shutter time, aperture and sensor gain repeatability: scales everything).

Between bursts each value is drawn once per capture; within a burst each frame adds its own
jitter/flicker, and the burst's average holds the mean of the N frame draws: exact for the gains
(the image is linear in them), first order for the pointing (microradians on a tripod; the blur
this drops is second order).

Camera motion acts on the static light at sub-pixel resolution before binning
(:class:`StaticLayers`, ``factor`` x ``factor`` cells per output pixel, DESIGN: "applied at native
resolution before binning"): the layers are resampled (bilinear) at the moved pixel positions and
block-averaged. Within a cell, bilinear resampling adds to the first-order change a part even in
the motion (a shift left and right differ by it) that a real lens does not have: the motion's
first order is the odd part, ``(resample(+m) - resample(-m)) / 2``, exactly linear while no cell
moves by more than a cell, and that is what :meth:`StaticLayers.change` applies. The spot's aim moves the direct light to first order, through the layers' aim
derivatives (the beam is degrees wide; the drift is hundredths of a degree). The person's own light
takes the gains; its shift with the camera (1e-4 of the room's light times a 1e-3 pixel shift) is
left out.

Magnitudes (1-sigma; ``docs/your-room.md``, "Stability budget", gives the sources):

* ``tripod`` (a careful user: remote trigger, projector warmed up, exposure and white balance
  locked, lens wide open, a sturdy tripod, captures a minute apart):
  - pointing 5 urad per axis between bursts (0.05 native pixel of a 3.9 um, 35 mm camera):
    warm-camera thermal image drift, about 0.1 px per degree C (Pan, Shi & Lubineau, Appl. Opt.
    54(34), 2015), with under 0.5 degree C between captures; 3 urad per frame within a burst
    (electronic first curtain: no shutter shock);
  - projector gain 0.3 % between bursts, 0.1 % per frame (an engineering estimate: no published
    repeatability of consumer projectors was found; lamp projectors regulate output on a minutes
    scale, Barco CLO);
  - spot aim 0.01 degree per axis (engineering estimate);
  - ambient gain 0.3 % between bursts, 0.1 % per frame: LED room lights on regulated drivers,
    no daylight (mains within +-10 % over 10 minutes, EN 50160; an incandescent lamp's flux goes as
    V^3.4, so a 0.1 % mains step is 0.34 %);
  - exposure gain 0.05 % (electronic shutter timing; the lens wide open, no aperture actuation).
* ``rough``: every magnitude 3x ``tripod`` (the issue's 2-4x: a bumped tripod, a cool projector,
  a lens stopped down, whose aperture repeats to 1/10-1/4 stop).

The scan-versus-world fields (``pose_deg`` ...) describe how the world differs from the scan the
room model believes; they change what is rendered, not the capture, and are drawn by the
robustness benchmark (``experiments/camera-photographs/robustness.py``) once per world. A scan's geometry error has
two parts (``tripod``):

  - ``warp_m`` 1 cm: a smooth deformation, correlated over :data:`WARP_LENGTH_M` (tracking drift,
    walls bowed or shifted as a whole): the absolute accuracy of phone LiDAR room scans, about
    +-1 cm (Luetzenburg, Kroon & Bjork, Sci. Rep. 11, 22221, 2021);
  - ``geometry_m`` 2 mm: independent noise per vertex of the fused mesh: one depth frame's noise
    is about 1.5 mm at 1 m and 6 mm at 2 m (Nguyen, Izadi & Lovell, 3DIMPVT 2012,
    sigma_z = 1.2 mm + 1.9 mm (z - 0.4 m)^2), and a fused mesh averages many frames.

  Before session 7 ``tripod`` had 1 cm of independent noise per vertex and no warp: on a scan's
  6 cm triangles that tilts every facet by about 13 degrees, a surface no fused scan has (its
  rows are kept in docs/results.md as ``geometry`` at 5x).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields

import torch
import torch.nn.functional as F

from ..errors import NlosError

URAD = 1e-6
WARP_LENGTH_M = 0.5
"""Correlation length of a scan's smooth deformation (``warp_m``): a wall's error is one bow or
shift over a metre or so, not a rough surface."""


@dataclass(frozen=True)
class CaptureVariation:
    """1-sigma magnitudes of what varies between captures (module docstring; all zero: ``ideal``)."""

    pointing_rad: float = 0.0
    """Camera pan and tilt between bursts, radians per axis."""
    roll_rad: float = 0.0
    """Camera roll about the optical axis between bursts, radians."""
    translation_m: float = 0.0
    """Camera translation across the view between bursts, metres per axis."""
    jitter_rad: float = 0.0
    """Camera pan and tilt per frame within a burst, radians per axis."""
    projector_gain: float = 0.0
    """Projector light output between bursts, relative."""
    projector_flicker: float = 0.0
    """Projector light output per frame, relative."""
    spot_aim_rad: float = 0.0
    """Spot aim on the projector's mount between bursts, radians per axis."""
    ambient_gain: float = 0.0
    """Room light apart from the projector between bursts, relative."""
    ambient_flicker: float = 0.0
    """Room light per frame, relative."""
    exposure_gain: float = 0.0
    """Exposure (shutter, aperture, sensor gain) repeatability between bursts, relative."""
    pose_deg: float = 0.0
    """Scan vs world: camera orientation error of the calibration, degrees per axis."""
    position_m: float = 0.0
    """Scan vs world: camera position error, metres per axis."""
    projector_aim_deg: float = 0.0
    """Scan vs world: projector aim error (the user aims by pan and tilt), degrees per axis."""
    albedo_log: float = 0.0
    """Scan vs world: albedo error of the scan's colours, standard deviation of log albedo."""
    geometry_m: float = 0.0
    """Scan vs world: scan geometry noise, independent per vertex, metres per axis."""
    warp_m: float = 0.0
    """Scan vs world: smooth deformation of the scan, metres per axis, correlated over
    :data:`WARP_LENGTH_M` (``world.mismatch.warped``)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 <= v < 100:
                raise NlosError(f"capture variation: {f.name} must be a number in [0, 100), got {v!r}")

    def scaled(self, k: float) -> "CaptureVariation":
        """Every magnitude times ``k`` (the robustness benchmark's multiples of ``tripod``)."""
        if not 0 <= k < 1e3:
            raise NlosError(f"capture variation: scale must be in [0, 1000), got {k!r}")
        return CaptureVariation(**{f.name: getattr(self, f.name) * k for f in fields(self)})

    def only(self, *names: str) -> "CaptureVariation":
        """Only the named fields (or :data:`EFFECTS` groups) kept; the rest zero."""
        keep = set()
        for n in names:
            keep.update(EFFECTS.get(n, (n,)))
        unknown = keep - {f.name for f in fields(self)}
        if unknown:
            raise NlosError(f"capture variation: unknown effect(s) {', '.join(sorted(unknown))} "
                            f"(choose from {', '.join(EFFECTS)})")
        return CaptureVariation(**{n: getattr(self, n) for n in keep})

    @property
    def capture_effects(self) -> CaptureVariation:
        """The capture part alone (the scan-versus-world fields zero)."""
        return self.only(*CAPTURE_EFFECTS)

    @property
    def world_effects(self) -> CaptureVariation:
        """The scan-versus-world part alone (the capture fields zero)."""
        return self.only(*WORLD_EFFECTS)

    @property
    def is_ideal(self) -> bool:
        return all(getattr(self, n) == 0 for g in CAPTURE_EFFECTS for n in EFFECTS[g])

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


EFFECTS = {
    "camera-shift": ("pointing_rad", "translation_m", "jitter_rad"),
    "camera-roll": ("roll_rad",),
    "projector-gain": ("projector_gain", "projector_flicker"),
    "spot-drift": ("spot_aim_rad",),
    "ambient-gain": ("ambient_gain", "ambient_flicker"),
    "exposure": ("exposure_gain",),
    "camera-pose": ("pose_deg", "position_m"),
    "projector-aim": ("projector_aim_deg",),
    "albedo": ("albedo_log",),
    "geometry": ("geometry_m",),
    "warp": ("warp_m",),
}
"""Named effects (the robustness benchmark's conditions) and the fields each one sets."""
CAPTURE_EFFECTS = ("camera-shift", "camera-roll", "projector-gain", "spot-drift", "ambient-gain", "exposure")
"""Effects acting between and within captures (image formation); the others change the world."""
WORLD_EFFECTS = ("camera-pose", "projector-aim", "albedo", "geometry", "warp")
"""Effects by which the world differs from the scan (``world.mismatch``)."""

PRESETS = {
    "ideal": CaptureVariation(),
    "tripod": CaptureVariation(pointing_rad=5 * URAD, roll_rad=5 * URAD, translation_m=5e-6, jitter_rad=3 * URAD,
                               projector_gain=3e-3, projector_flicker=1e-3, spot_aim_rad=math.radians(0.01),
                               ambient_gain=3e-3, ambient_flicker=1e-3, exposure_gain=5e-4,
                               pose_deg=0.3, position_m=0.01, projector_aim_deg=0.3, albedo_log=0.1,
                               geometry_m=0.002, warp_m=0.01),
}
PRESETS["rough"] = PRESETS["tripod"].scaled(3.0)


def preset(name: str) -> CaptureVariation:
    """The named preset (``ideal``, ``tripod``, ``rough``); a one-line error for others."""
    if name not in PRESETS:
        raise NlosError(f"capture variation: unknown preset {name!r} (choose from {', '.join(PRESETS)})")
    return PRESETS[name]


@dataclass
class CaptureDraw:
    """The drawn state of B captures (each a burst averaged), relative to the scan's nominal one.

    Shapes: ``shift`` (B, 2) output pixels (x right, y down: pixel (r, c) of the capture shows what
    the nominal view shows at (r + shift_y, c + shift_x)), ``roll`` (B,) radians, ``aim`` (B, 2)
    radians (pan, tilt of the beam), gains (B,) multiplicative (1: nominal).
    """

    shift: torch.Tensor
    roll: torch.Tensor
    aim: torch.Tensor
    projector: torch.Tensor
    ambient: torch.Tensor
    exposure: torch.Tensor

    @classmethod
    def nominal(cls, n: int, device="cpu", dtype=torch.float32) -> "CaptureDraw":
        z = lambda *s: torch.zeros(*s, device=device, dtype=dtype)
        o = lambda: torch.ones(n, device=device, dtype=dtype)
        return cls(z(n, 2), z(n), z(n, 2), o(), o(), o())


def draw_captures(v: CaptureVariation, n: int, burst_frames: int, f_px: float, depth_m: float,
                  generator: torch.Generator | None = None, device="cpu", dtype=torch.float32) -> CaptureDraw:
    """``n`` captures of ``burst_frames`` frames each under ``v``'s capture effects.

    ``f_px``: focal length in output pixels; ``depth_m``: the view's median depth (translation ->
    shift). A burst's within-burst terms average over its frames: their standard deviation over
    sqrt(N) is added to the between-burst draw (exact for gains, module docstring for pointing).
    """
    g = lambda *s: torch.randn(*s, generator=generator, device=device, dtype=torch.float64)
    root_n = math.sqrt(burst_frames)
    pointing = v.pointing_rad * g(n, 2) + v.jitter_rad / root_n * g(n, 2) + v.translation_m / depth_m * g(n, 2)
    return CaptureDraw(
        shift=(f_px * pointing).to(dtype),
        roll=(v.roll_rad * g(n)).to(dtype),
        aim=(v.spot_aim_rad * g(n, 2)).to(dtype),
        projector=(1 + v.projector_gain * g(n) + v.projector_flicker / root_n * g(n)).to(dtype),
        ambient=(1 + v.ambient_gain * g(n) + v.ambient_flicker / root_n * g(n)).to(dtype),
        exposure=(1 + v.exposure_gain * g(n)).to(dtype))


@dataclass
class StaticLayers:
    """The room's static light under the fixed spot at ``factor`` x ``factor`` cells per output pixel
    (``render/layers.py`` renders them): what camera motion resamples before binning.

    Shapes: ``projector`` (H f, W f, 3) direct + interreflection of the nominal spot,
    ``aim`` (2, H f, W f, 3) its derivative per radian of beam pan and tilt, ``ambient`` (H f, W f, 3)
    the room's light with the projector off. ``f_px``: focal length in output pixels;
    ``depth_m``: the view's median depth.
    """

    projector: torch.Tensor
    aim: torch.Tensor
    ambient: torch.Tensor
    factor: int
    f_px: float
    depth_m: float

    def __post_init__(self) -> None:
        hf, wf, c = self.projector.shape
        if c != 3 or hf % self.factor or wf % self.factor or self.ambient.shape != self.projector.shape \
                or self.aim.shape != (2, hf, wf, 3):
            raise NlosError(f"static layers: inconsistent shapes {tuple(self.projector.shape)}, "
                            f"{tuple(self.aim.shape)}, {tuple(self.ambient.shape)} at factor {self.factor}")
        for name in ("projector", "aim", "ambient"):
            if not bool(torch.isfinite(getattr(self, name)).all()):
                raise NlosError(f"static layers: {name} has non-finite values")

    @property
    def shape(self) -> tuple[int, int]:
        """Output (H, W)."""
        return self.projector.shape[0] // self.factor, self.projector.shape[1] // self.factor

    def to(self, device=None, dtype=None) -> "StaticLayers":
        m = lambda t: t.to(device=device, dtype=dtype)
        return StaticLayers(m(self.projector), m(self.aim), m(self.ambient), self.factor, self.f_px, self.depth_m)

    def bin(self, fine: torch.Tensor) -> torch.Tensor:
        """(..., H f, W f, 3) -> (..., H, W, 3): each output pixel the mean of its cells."""
        f = self.factor
        *lead, hf, wf, c = fine.shape
        return fine.reshape(*lead, hf // f, f, wf // f, f, c).mean(dim=(-4, -2))

    def nominal(self) -> tuple[torch.Tensor, torch.Tensor]:
        """The binned projector and ambient images (H, W, 3) of the nominal capture (binned once)."""
        return self._derivs()["nominal"]

    def static_image(self, d: CaptureDraw) -> torch.Tensor:
        """(B, H, W, 3): the static light of captures ``d`` (exposure gain included), binned.

        Resampled at the moved positions (:meth:`_warp`), the slow reference of :meth:`change`."""
        aim = torch.einsum("bk,khwc->bhwc", d.aim.to(self.aim.dtype), self.aim)
        fine = d.projector[:, None, None, None] * (self.projector + aim) \
            + d.ambient[:, None, None, None] * self.ambient
        fine = self._warp(fine, d.shift, d.roll)
        return d.exposure[:, None, None, None] * self.bin(fine)

    @property
    def roll_step(self) -> float:
        """Largest roll (rad) that moves no cell by more than one cell: the linear range of the warp."""
        h, w = self.shape
        return 1.0 / (self.factor * 0.5 * math.hypot(h, w))

    def change(self, d: CaptureDraw) -> torch.Tensor:
        """(B, H, W, 3): captures ``d``'s static light minus the nominal capture's.

        To first order in the motion (a tripod's is thousandths of a pixel): the gains' exact part
        plus the motion times the binned derivatives (:meth:`motion_derivatives`), dropping gain x
        motion products (1e-3 x 1e-3); a motion of more than a cell is resampled
        (:meth:`static_image`, whose odd part in the motion is the slow reference of this one)."""
        big = (d.shift.abs() > 1.0 / self.factor).any() or (d.roll.abs() > self.roll_step).any()
        p, a = self.nominal()
        if bool(big):
            return self.static_image(d) - (p + a)
        b4 = lambda t: t[:, None, None, None]
        dt = p.dtype
        aim = torch.einsum("bk,khwc->bhwc", d.aim.to(dt), self._derivs()["aim"])
        motion = torch.einsum("bk,khwc->bhwc", torch.cat([d.shift, d.roll[:, None]], 1).to(dt), self.motion_derivatives())
        return b4(d.exposure) * (b4(d.projector) * (p + aim) + b4(d.ambient) * a) - (p + a) + motion

    def motion_derivatives(self) -> torch.Tensor:
        """(3, H, W, 3): d(binned static light) / d(shift x, shift y in output pixels, roll in rad):
        the odd part of resampling over one cell (over :attr:`roll_step`), exact in that range."""
        return self._derivs()["motion"]

    def _derivs(self) -> dict:
        if getattr(self, "_cache", None) is None:
            fine = (self.projector + self.ambient)[None]
            one = torch.ones(1, dtype=fine.dtype, device=fine.device)
            zero2 = torch.zeros(1, 2, dtype=fine.dtype, device=fine.device)
            steps = ((1, 0, 0), (0, 1, 0), (0, 0, 1))
            units = (1 / self.factor, 1 / self.factor, self.roll_step)
            out = []
            for (sx, sy, sr), u in zip(steps, units):
                move = lambda sign: self.bin(self._warp(fine, zero2 + sign * u * torch.tensor(
                    [sx, sy], dtype=fine.dtype, device=fine.device), sign * u * sr * one))[0]
                out.append((move(1) - move(-1)) / (2 * u))
            object.__setattr__(self, "_cache", {"motion": torch.stack(out), "aim": self.bin(self.aim),
                                                "nominal": (self.bin(self.projector), self.bin(self.ambient))})
        return self._cache

    def _warp(self, fine: torch.Tensor, shift: torch.Tensor, roll: torch.Tensor) -> torch.Tensor:
        """Resample (B, Hf, Wf, 3) at the moved pixel positions (bilinear; edges clamped)."""
        if not bool((shift != 0).any() or (roll != 0).any()):
            return fine
        b, hf, wf, _ = fine.shape
        f = self.factor
        dev, dt = fine.device, fine.dtype
        # cell centres in output-pixel units about the principal point (image centre)
        xs = (torch.arange(wf, device=dev, dtype=dt) + 0.5) / f - wf / (2 * f)
        ys = (torch.arange(hf, device=dev, dtype=dt) + 0.5) / f - hf / (2 * f)
        yy, xx = torch.meshgrid(ys, xs, indexing="ij")
        c, s = torch.cos(roll)[:, None, None], torch.sin(roll)[:, None, None]
        sx = c * xx - s * yy + shift[:, 0, None, None].to(dt)
        sy = s * xx + c * yy + shift[:, 1, None, None].to(dt)
        # grid_sample's normalized coordinates (align_corners=False): -1 and 1 are the outer edges
        grid = torch.stack([sx / (wf / (2 * f)), sy / (hf / (2 * f))], dim=-1)
        out = F.grid_sample(fine.permute(0, 3, 1, 2), grid, mode="bilinear", padding_mode="border",
                            align_corners=False)
        return out.permute(0, 2, 3, 1)


def difference_sigmas(v: CaptureVariation, burst_frames: int, f_px: float, depth_m: float) -> list[float]:
    """1-sigma of what two captures under ``v`` differ by, along each of ``models.nuisance.DIRECTIONS``
    (projector and ambient gain with the exposure, relative; shift x, y in output pixels; roll, aim
    pan, tilt in radians): sqrt(2) times one capture's spread (each capture draws its own)."""
    n, r2 = burst_frames, math.sqrt(2.0)
    gain = lambda drift, flicker: r2 * math.sqrt(drift ** 2 + flicker ** 2 / n + v.exposure_gain ** 2)
    shift = r2 * f_px * math.sqrt(v.pointing_rad ** 2 + v.jitter_rad ** 2 / n + (v.translation_m / depth_m) ** 2)
    return [gain(v.projector_gain, v.projector_flicker), gain(v.ambient_gain, v.ambient_flicker), shift, shift,
            r2 * v.roll_rad, r2 * v.spot_aim_rad, r2 * v.spot_aim_rad]


def layers_arrays(layers: StaticLayers, prefix: str = "") -> dict:
    """``layers`` as plain arrays and numbers, each key after ``prefix`` (:func:`layers_from` reads them)."""
    import numpy as np

    return {f"{prefix}projector": layers.projector.cpu().numpy(), f"{prefix}aim": layers.aim.cpu().numpy(),
            f"{prefix}ambient": layers.ambient.cpu().numpy(), f"{prefix}factor": np.int64(layers.factor),
            f"{prefix}f_px": np.float64(layers.f_px), f"{prefix}depth_m": np.float64(layers.depth_m)}


def layers_from(arrays, prefix: str = "") -> StaticLayers:
    """The :class:`StaticLayers` of :func:`layers_arrays`' mapping (an open npz or a dict)."""
    import numpy as np

    t = lambda k: torch.as_tensor(np.asarray(arrays[prefix + k], np.float32))
    return StaticLayers(t("projector"), t("aim"), t("ambient"), int(arrays[prefix + "factor"]),
                        float(arrays[prefix + "f_px"]), float(arrays[prefix + "depth_m"]))


def save_layers(path, layers: StaticLayers) -> None:
    """Write ``layers`` as a plain npz (arrays and numbers only: loading runs no code)."""
    from ..data.store import atomic_npz

    atomic_npz(path, **layers_arrays(layers))


def load_layers(path) -> StaticLayers:
    """Read :func:`save_layers`' file (``allow_pickle=False``); one line naming a broken file."""
    import numpy as np

    try:
        with np.load(path, allow_pickle=False) as z:
            return layers_from(z)
    except FileNotFoundError:
        raise NlosError(f"{path}: missing (the room model's static layers)") from None
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise NlosError(f"{path}: corrupted static layers ({str(exc).splitlines()[0][:80]})") from None


__all__ = ["CAPTURE_EFFECTS", "EFFECTS", "WORLD_EFFECTS", "PRESETS", "CaptureDraw", "CaptureVariation", "StaticLayers", "difference_sigmas",
           "draw_captures",
           "load_layers", "preset", "save_layers"]
