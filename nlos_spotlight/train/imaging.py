"""Image formation from the stored transport, differentiable in the spot vector, with sensor noise.

``image(y) = direct^T y + U^T y V + ambient + nlos_ambient`` (DESIGN section 5, light transport
matrix F), then the sensor (``render/sensor.py``): average metering on the person-free image (no gradient),
and shot, read and per-native-pixel quantization noise of a burst as a Gaussian with the exact
variance whose mean carries the gradient (reparameterization; at thousands of electrons per pixel
Poisson is Gaussian to high accuracy), clipped at full scale with a flag per pixel.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import torch

from ..errors import NlosError
from ..render.sensor import SensorConfig, auto_exposure, dn_per_radiance, noise_variance_dn
from ..data.tensors import SceneTensors


def form_images(s: SceneTensors, idx: torch.Tensor, y: torch.Tensor | None,
                mode: str = "spot", albedo: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Noise-free images (B, H, W, 3) of samples ``idx`` and the person-free image (H, W, 3).

    ``mode`` 'spot': projector on spot vector y (T,); 'flash': the stored flash illumination;
    'ambient': projector off (y unused). Image samples hold only the room's stored spots: a y with
    weight elsewhere, or with a gradient (which needs every candidate's image), raises NlosError.
    ``albedo`` (B, 3): the people dressed in these albedos instead (:func:`albedo_factors`).
    """
    lit, amb, static = form_parts(s, idx, y, mode, albedo)
    return static + lit + amb, static


def form_parts(s: SceneTensors, idx: torch.Tensor, y: torch.Tensor | None, mode: str = "spot",
               albedo: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """:func:`form_images` in parts: the person's light from the projector (B, H, W, 3) (0 when
    'ambient'), its light under the hidden region's own light (B, H, W, 3), the person-free image
    (H, W, 3): the capture variation scales the first with the projector, the second with the room."""
    if mode == "spot":
        _check_stored(s, idx, y)
    lit, amb = albedo_factors(s, idx, albedo) if albedo is not None else (1.0, 1.0)
    person_ambient = amb * s.nlos_ambient[idx]
    if mode == "ambient":
        return torch.zeros_like(person_ambient), person_ambient, s.ambient
    if mode == "flash":
        if s.flash_direct is None or s.flash_nlos is None:
            raise NlosError(f"{s.scene_dir or 'scene'}: the dataset stores no flash images (regenerate it)")
        return lit * s.flash_nlos[idx], person_ambient, s.flash_direct + s.ambient
    static = torch.einsum("t,thwc->hwc", y, s.direct) + s.ambient
    nlos = lit * torch.einsum("t,btr,brhwc->bhwc", y, s.u[idx], s.v[idx])
    if s.shadow is not None:  # blocked spot light: scales with the spot, not with the clothing
        _check_shadow(s, y)
        nlos = nlos + y[s.shadow_spot] * s.shadow[idx].to(nlos.dtype)
    if s.bounce is not None:  # the body's light over one more bounce: scales with both
        _check_shadow(s, y)
        nlos = nlos + lit * y[s.shadow_spot] * s.bounce[idx].to(nlos.dtype)
    return nlos, person_ambient, static


def _check_shadow(s: SceneTensors, y: torch.Tensor) -> None:
    """NlosError when y lights a spot other than the one whose blocked light ``s.shadow`` holds."""
    off = torch.nonzero(y.detach() != 0).flatten().tolist()
    if any(t != s.shadow_spot for t in off):
        raise NlosError(f"{s.scene_dir or 'scene'}: the people's shadow term is stored for spot {s.shadow_spot} "
                        f"only, not for spot {[t for t in off if t != s.shadow_spot][0]}")


def drifted_images(s: SceneTensors, idx: torch.Tensor, y: torch.Tensor, albedo: torch.Tensor | None,
                   variation, burst_frames: int, generator: torch.Generator | None, draws: tuple | None = None
                   ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Noise-free person captures (B, H, W, 3), their empty-room captures (B, H, W, 3) and the
    nominal person-free image (H, W, 3) under ``variation`` (``render.variation``): each capture
    draws its own camera motion, gains and spot aim; the room's light is the room's static layers
    (``s.layers``, 64 samples a pixel: more converged than the dataset's own static image) and
    moves with them, the person's light takes the projector's and the room's gains.
    ``draws``: (person, empty) ``CaptureDraw`` to use instead of drawing."""
    from ..render.variation import draw_captures

    if s.layers is None:
        raise NlosError(f"{s.scene_dir or 'scene'}: capture variation needs the room's static layers "
                        "(a room model's layers.npz)")
    lit, amb, _ = form_parts(s, idx, y, "spot", albedo)
    L, n = s.layers, len(idx)
    static = sum(L.nominal()).to(lit.dtype)  # the room's light as the layers render it (the drift's origin)
    draw = lambda: draw_captures(variation, n, burst_frames, L.f_px, L.depth_m, generator, static.device, static.dtype)
    person, empty = draws if draws is not None else (draw(), draw())
    b4 = lambda t: t[:, None, None, None]
    images = static + L.change(person) + b4(person.exposure) * (b4(person.projector) * lit + b4(person.ambient) * amb)
    return images, static + L.change(empty), static


def relit_hidden_region(s: SceneTensors, scale: float) -> SceneTensors:
    """The same people with the hidden region's own light (DESIGN section 5, ``nlos_ambient``) times
    ``scale``: a darker (``scale`` < 1; 0 for no light but the projector's) or brighter hidden room.

    Exact, with no rendering: ``nlos_ambient`` is linear in the hidden region's radiance, and
    nothing else depends on it (the person-free image, hence the exposure, holds no hidden light).
    ``tests/train/test_hidden_light.py`` checks it against renders at two radiances."""
    if not scale >= 0 or scale == float("inf"):
        raise NlosError(f"hidden light scale must be a finite number >= 0, got {scale}")
    return dataclasses.replace(s, nlos_ambient=s.nlos_ambient * scale)


def albedo_factors(s: SceneTensors, idx: torch.Tensor, albedo: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(B, 1, 1, 3) factors that turn samples ``idx``' person light into that of the same body with
    ``albedo`` (B, 3): the projector's (``nlos``, ``flash_nlos``) scales as albedo, one diffuse
    bounce on the body, and ``nlos_ambient`` as (albedo - 1), the body's own light minus the
    background it hides (DESIGN section 5). Exact: the renderer has no light bouncing twice on the
    body (``tests/train/test_albedo_augment.py`` checks it against renders)."""
    if s.albedo is None:
        raise NlosError(f"{s.scene_dir or 'scene'}: the samples' albedos are not stored (regenerate the dataset)")
    a0 = s.albedo[idx]
    shape = (len(idx), 1, 1, 3)
    return (albedo / a0).reshape(shape), ((1 - albedo) / (1 - a0)).reshape(shape)


def _check_stored(s: SceneTensors, idx: torch.Tensor, y: torch.Tensor) -> None:
    """NlosError when y asks image samples among ``idx`` for light they do not store (instead of
    silently rendering none)."""
    if s.stored is None or s.transport is None or bool(s.stored.all()) or bool(s.transport[idx].all()):
        return
    where = s.scene_dir or "scene"
    k = int(s.stored.sum())
    if y.requires_grad:
        raise NlosError(f"{where}: image samples store {k} of {len(s.stored)} spots, and a spot vector with a "
                        "gradient needs them all (train the spot policy on data.tensors.transport_samples)")
    off = torch.nonzero((y.detach() != 0) & ~s.stored).flatten()
    if len(off):
        raise NlosError(f"{where}: spot {int(off[0])} is not among the {k} spots stored for image samples "
                        "(spots.json); use full-transport samples (data.tensors.transport_samples)")


def capture(s: SceneTensors, idx: torch.Tensor, y: torch.Tensor | None, mode: str, sensor: SensorConfig,
            generator: torch.Generator | None, noise: bool, net_cfg, albedo: torch.Tensor | None = None,
            variation=None) -> Photographs:
    """What the network ``net_cfg`` (``NLOSNetConfig``) reads for samples ``idx`` of room ``s`` under
    the illumination (y, mode): photographs (``form_images`` + ``photographs``) and, for a
    geometry-aware network, the room's geometry channels under that light. ``albedo`` (B, 3):
    the people dressed in these albedos (``form_images``). ``variation``
    (``render.variation.CaptureVariation``): person and empty-room captures of the room's converged
    static light (its layers) that differ as real ones do (``drifted_images``; spot light only; the
    ideal preset: they match exactly); None: the dataset's own photographs."""
    if variation is not None:
        if mode != "spot":
            raise NlosError(f"capture variation: modelled for the spot light, not {mode!r}")
        images, empty, person_free = drifted_images(s, idx, y, albedo, variation, sensor.burst_frames, generator)
        ph = photographs(images, empty, sensor, generator, noise, net_cfg.background_subtract, metered=person_free)
    else:
        images, person_free = form_images(s, idx, y, mode, albedo)
        ph = photographs(images, person_free, sensor, generator, noise, net_cfg.background_subtract)
    if getattr(net_cfg, "geometry", False):
        from ..data.geometry import geometry_input

        ph.geometry = geometry_input(s, person_free - s.ambient, len(idx), projector_on=mode != "ambient")
    return ph


def radiance_variance(frame: torch.Tensor, reference: torch.Tensor, cfg: SensorConfig) -> torch.Tensor:
    """Noise variance per pixel (radiance units squared) of a photograph whose noise-free value is
    ``frame``, exposed as the camera meters the person-free ``reference``; a difference of
    photographs (one with the person, the empty room) has the sum of theirs."""
    k = dn_per_radiance(auto_exposure(reference.clamp(min=0), cfg), cfg)
    return noise_variance_dn(frame.clamp(min=0) * k, cfg) / k ** 2


def add_sensor_noise(images: torch.Tensor, exposure: float, cfg: SensorConfig,
                     generator: torch.Generator | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """A photograph in radiance units and its clip flag (B, H, W): noisy, differentiable in ``images``.

    Gaussian with the exact mean and variance of :func:`~nlos_spotlight.render.sensor.noise_variance_dn`
    (a burst of ``cfg.burst_frames`` frames averaged), clipped at full scale like the camera.
    """
    k = dn_per_radiance(exposure, cfg)  # DN per radiance unit
    mean = images * k
    var = noise_variance_dn(mean.detach(), cfg)
    eps = torch.randn(images.shape, generator=generator, device=images.device, dtype=images.dtype)
    dn = mean + var.sqrt() * eps
    over = dn.detach() >= cfg.full_scale_dn
    return dn.clamp(max=cfg.full_scale_dn) / k, over.any(dim=-1)


@dataclass
class Photographs:
    """What a network reads for one batch (DESIGN section 6): photographs, empty-room photographs, flags."""

    images: torch.Tensor
    """(B, H, W, 3) photographs with the person, radiance units."""
    background: torch.Tensor | None
    """(B, H, W, 3) empty-room photographs under the same illumination and settings, or None."""
    clipped: torch.Tensor | None
    """(B, H, W) bool: the pixel clipped in the photograph or the background (None without noise)."""
    geometry: torch.Tensor | None = None
    """(B, 10, H, W) what each pixel shows (``data.geometry``), for networks that read it; else None."""


def photographs(images: torch.Tensor, person_free: torch.Tensor, cfg: SensorConfig, generator: torch.Generator | None,
                noise: bool = True, background: bool = False, metered: torch.Tensor | None = None) -> Photographs:
    """The network's inputs for noise-free ``images`` (B, H, W, 3).

    The exposure is metered on the person-free frame (as the camera does before the person walks
    in; ``metered`` (H, W, 3) when ``person_free`` holds one empty-room capture per sample) and then
    locked; with ``background`` an empty-room photograph per sample (B, H, W, 3) is captured with the
    same settings and its own noise. Without ``noise`` the images pass through unchanged.
    """
    bg = person_free.expand_as(images) if background else None
    if not noise:
        return Photographs(images, bg, None)
    exposure = auto_exposure((person_free if metered is None else metered).clamp(min=0), cfg)
    images, clipped = add_sensor_noise(images.clamp(min=0), exposure, cfg, generator)
    if background:
        bg, bg_clipped = add_sensor_noise(bg.clamp(min=0), exposure, cfg, generator)
        clipped = clipped | bg_clipped
    return Photographs(images, bg, clipped)
