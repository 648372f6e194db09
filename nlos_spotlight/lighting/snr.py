"""NLOS signal-to-noise ratio of each candidate spot, from a scene's stored light transport.

A spot is good when the person's light stands out of the sensor noise of the whole photograph.
Under the sensor model (``render/sensor.py``) with its metering, candidate t of a scene gets
exposure ``e_t = auto_exposure(direct_t + ambient)`` (the person-free image, as a camera meters it),
and a pixel's mean and variance in digital numbers are

    s_p   = k e_t nlos_tp                                   (the person's signal, DN)
    mu_p  = k e_t (direct_tp + ambient_p + nlos_tp + nlos_ambient_p)
    var_p = (g mu_p + g^2 n sigma_read^2 + n/12) / N        (shot + read + per-native quantization,
                                                             a burst of N frames: noise_variance_dn)

with ``k = electrons_per_radiance * gain``, g the gain (DN per electron) and n native pixels per
output pixel. The SNR is the matched-filter detectability of the person, summed over the pixels and
channels that do not clip (mu_p below full scale),

    SNR_t = sqrt( sum_p s_p^2 / var_p ),

averaged over the scene's static samples (walking-trajectory frames are left out, so every
sample counts once). Projector off ("ambient only"): signal ``nlos_ambient``, exposure on
``ambient``. Flash (datasets that store it): signal ``flash_nlos``, exposure on
``flash_direct + ambient``.

Shapes: images (..., H, W, 3); :func:`candidate_snr` returns (T,), 0 for spots that land nowhere.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..errors import NlosError
from ..render.sensor import SensorConfig, auto_exposure, dn_per_radiance, expected_dn, noise_variance_dn


def _information(s: torch.Tensor, mu: torch.Tensor, cfg: SensorConfig, dims) -> torch.Tensor:
    """sum s^2 / var over unclipped values (a saturated pixel carries no signal)."""
    var = noise_variance_dn(mu, cfg)
    return (s * s / var * (mu < cfg.full_scale_dn)).sum(dim=dims)


def snr(signal: torch.Tensor, total: torch.Tensor, exposure: float, cfg: SensorConfig) -> float:
    """SNR of one signal image (H, W, 3) inside the photograph ``total`` at ``exposure`` seconds."""
    s = expected_dn(signal, exposure, cfg)
    mu = expected_dn(total.clamp(min=0), exposure, cfg)
    return float(torch.sqrt(_information(s, mu, cfg, None)))


def snr_batch(signal: torch.Tensor, total: torch.Tensor, exposures: torch.Tensor, cfg: SensorConfig) -> torch.Tensor:
    """:func:`snr` for a stack: signal, total (B, H, W, 3), exposures (B,) seconds -> (B,)."""
    k = dn_per_radiance(exposures, cfg).reshape(-1, 1, 1, 1)
    return torch.sqrt(_information(signal * k, total.clamp(min=0) * k, cfg, (1, 2, 3)))


@dataclass
class SceneSNR:
    """Mean NLOS SNR of a scene's static samples under each illumination."""

    candidates: np.ndarray
    """(T,) per candidate spot; 0 where the spot lands nowhere."""
    ambient: float
    """Projector off."""
    flash: float | None
    """The flash at the camera, or None when the dataset stores no flash images."""
    samples: int
    """Static samples averaged."""


def scene_snr(scene_dir: str | Path, skip_every: int = 0, sensor: dict | None = None) -> SceneSNR:
    """SNR of every candidate spot, ambient only and the flash, from ``static.npz`` and ``samples/``.

    ``sensor`` overrides capture settings (a run's ``TrainConfig.sensor``). ``skip_every`` n > 0
    leaves out the samples k with k % n == n - 1, the people a training run
    holds out of its rooms (``data.tensors.holdout_mask``), so training never reads them.
    """
    from ..data.static import read_static
    from ..scene import load_scene

    scene_dir = Path(scene_dir)
    st = read_static(scene_dir)
    direct, ambient = torch.as_tensor(st["direct"]).double(), torch.as_tensor(st["ambient"]).double()
    landed = np.asarray(st["spot_landed"], bool)
    cfg = SensorConfig.for_scene(load_scene(scene_dir), sensor)
    lit = np.flatnonzero(landed)
    static_t = direct[lit] + ambient  # (L, H, W, 3) person-free photographs of the landed spots
    exposures = torch.tensor([auto_exposure(img, cfg) for img in static_t], dtype=torch.float64)
    amb_exposure = auto_exposure(ambient, cfg)
    flash_direct = torch.as_tensor(st["flash_direct"]).double() if "flash_direct" in st else None
    flash_exposure = auto_exposure(flash_direct + ambient, cfg) if flash_direct is not None else None
    per_t, amb, flash = [], [], []
    for k, path in enumerate(sorted((scene_dir / "samples").glob("*.npz"))):
        if skip_every > 0 and k % skip_every == skip_every - 1:
            continue
        z = np.load(path)
        if int(z["trajectory"]) >= 0:
            continue
        f = torch.einsum("tr,rhwc->thwc", torch.as_tensor(z["transport_u"]).double()[lit],
                         torch.as_tensor(z["transport_v"]).double())
        na = torch.as_tensor(z["nlos_ambient"]).double()
        row = np.zeros(len(landed))
        row[lit] = snr_batch(f, static_t + f + na, exposures, cfg).numpy()
        per_t.append(row)
        amb.append(snr(na, ambient + na, amb_exposure, cfg))
        if flash_direct is not None and "flash_nlos" in z.files:
            fn = torch.as_tensor(z["flash_nlos"]).double()
            flash.append(snr(fn, flash_direct + ambient + fn + na, flash_exposure, cfg))
    if not per_t:
        raise NlosError(f"{scene_dir}: no static samples to measure the NLOS SNR on")
    return SceneSNR(np.mean(per_t, axis=0), float(np.mean(amb)), float(np.mean(flash)) if flash else None,
                    len(per_t))


def candidate_snr(scene_dir: str | Path, skip_every: int = 0, sensor: dict | None = None) -> np.ndarray:
    """(T,) mean NLOS SNR of each candidate spot of a stored scene (0 for spots that land nowhere);
    ``sensor``: capture settings over the scene's sensor (e.g. a run's ``burst_frames``)."""
    return scene_snr(scene_dir, skip_every, sensor).candidates
