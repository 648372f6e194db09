"""Image formation from the stored transport, differentiable in the spot vector, with sensor noise.

``image(y) = direct^T y + U^T y V + ambient + nlos_ambient`` (DESIGN section 5, light transport
matrix F), then the sensor: auto-exposure on the person-free image (no gradient), and shot, read
and quantization noise as a Gaussian with the exact variance whose mean carries the gradient
(reparameterization; at thousands of electrons per pixel Poisson is Gaussian to high accuracy).
"""

from __future__ import annotations

import torch

from ..errors import NlosError
from ..render.sensor import SensorConfig, auto_exposure
from .scenes import SceneTensors


def form_images(s: SceneTensors, idx: torch.Tensor, y: torch.Tensor | None,
                mode: str = "spot") -> tuple[torch.Tensor, torch.Tensor]:
    """Noise-free images (B, H, W, 3) of samples ``idx`` and the person-free image (H, W, 3).

    ``mode`` 'spot': projector on spot vector y (T,); 'flash': the stored flash illumination;
    'ambient': projector off (y unused).
    """
    if mode == "ambient":
        return s.ambient + s.nlos_ambient[idx], s.ambient
    if mode == "flash":
        if s.flash_direct is None or s.flash_nlos is None:
            raise NlosError(f"{s.scene_dir or 'scene'}: the dataset stores no flash images (regenerate it)")
        static = s.flash_direct + s.ambient
        return static + s.flash_nlos[idx] + s.nlos_ambient[idx], static
    static = torch.einsum("t,thwc->hwc", y, s.direct) + s.ambient
    nlos = torch.einsum("t,btr,brhwc->bhwc", y, s.u[idx], s.v[idx])
    return static + nlos + s.nlos_ambient[idx], static


def add_sensor_noise(images: torch.Tensor, person_free: torch.Tensor, cfg: SensorConfig,
                     generator: torch.Generator | None = None) -> torch.Tensor:
    """A photograph in radiance units: auto-exposed, noisy, differentiable in ``images``."""
    exposure = auto_exposure(person_free.clamp(min=0), cfg)
    k = exposure * cfg.electrons_per_radiance * cfg.gain  # DN per radiance unit
    mean = images.clamp(min=0) * k
    var = (cfg.gain * mean + (cfg.gain * cfg.read_noise_binned_e) ** 2 + 1.0 / 12).detach()
    eps = torch.randn(images.shape, generator=generator, device=images.device, dtype=images.dtype)
    return (mean + var.sqrt() * eps) / k


def photographs(images: torch.Tensor, person_free: torch.Tensor, cfg: SensorConfig, generator: torch.Generator | None,
                noise: bool = True, background: bool = False) -> tuple[torch.Tensor, torch.Tensor | None]:
    """The network's inputs for noise-free ``images`` (B, H, W, 3): the photographs and, when
    ``background``, an empty-room photograph per sample (B, H, W, 3) with its own noise, as a user
    captures it before the person walks in under the same illumination (else None)."""
    bg = person_free.expand_as(images) if background else None
    if noise:
        images = add_sensor_noise(images, person_free, cfg, generator)
        bg = add_sensor_noise(bg, person_free, cfg, generator) if background else None
    return images, bg
