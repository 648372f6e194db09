"""NLOS networks by name, so configs, checkpoints and the evaluation can pick an architecture.

Every network maps images (B, H, W, 3) in radiance units to (position (B, 2) in meters,
posture logits (B, 6)), so the trainer, ``nlos predict`` and ``nlos evaluate`` treat them alike.
"""

from __future__ import annotations

from typing import Callable

import torch
from torch import nn

from ..errors import NlosError
from .nlos_net import NLOSNet, NLOSNetConfig
from .nuisance import NuisanceProjection

NETWORKS: dict[str, Callable[[NLOSNetConfig], nn.Module]] = {"resnet18": NLOSNet}
"""Architecture name -> constructor taking an :class:`NLOSNetConfig` (baselines register below)."""

try:  # the baselines of docs/baselines.md
    from .baselines import BASELINES

    NETWORKS.update(BASELINES)
except ImportError:  # pragma: no cover - while the baselines package is being written
    pass


class PositionScaled(nn.Module):
    """Wraps a network so that its position head predicts standardized coordinates.

    ``position = mean + std * head`` with the training set's target mean and std as buffers (saved
    in every checkpoint): the head starts near the middle of the hidden region, not meters off.
    With ``subtract`` the network reads ``images - background`` (an empty-room photograph under
    the same illumination), for every architecture alike.

    Pixels the camera clipped (``clipped``, from the sensor) are zeroed in the difference, and a
    network with ``reads_clip_flag`` also gets the flag as an input channel.

    Shapes:
        images (B, H, W, 3), background (B, H, W, 3) or (H, W, 3), clipped (B, H, W) bool,
        geometry (B, 10, H, W) (networks with ``reads_geometry``) -> position (B, 2) m, logits (B, 6).
    """

    def __init__(self, net: nn.Module, subtract: bool = False, normalize: str = "image", nuisance: bool = False):
        super().__init__()
        if normalize not in ("image", "background") or (normalize == "background" and not subtract):
            raise NlosError(f"network: normalize must be 'image' or 'background' (with background_subtract), "
                            f"got {normalize!r}")
        if nuisance and not subtract:
            raise NlosError("network: project_nuisance needs background_subtract")
        self.net, self.subtract, self.by_background = net, subtract, normalize == "background"
        self.nuisance = NuisanceProjection() if nuisance else None
        self.net.per_image_norm = not self.by_background
        self.register_buffer("position_mean", torch.zeros(2))
        self.register_buffer("position_std", torch.ones(2))

    def set_targets(self, targets: torch.Tensor) -> None:
        """Standardize with the mean and std of the training targets (N, 2)."""
        self.position_mean.copy_(targets.mean(0))
        self.position_std.copy_(targets.std(0).clamp(min=0.05) if len(targets) > 1 else torch.ones(2))

    def forward(self, images: torch.Tensor, background: torch.Tensor | None = None,
                clipped: torch.Tensor | None = None, geometry: torch.Tensor | None = None, with_aux: bool = False):
        if self.subtract:
            if background is None:
                raise ValueError("this network reads photograph - empty-room photograph: pass the background")
            images = images - background
            if self.nuisance is not None:  # what the capture variation changed, estimated and removed
                images = self.nuisance(images, background, clipped)[0]
            if clipped is not None:  # a clipped pixel's difference is the clip, not the person
                images = images.masked_fill(clipped.unsqueeze(-1), 0.0)
            if self.by_background:  # 1e3: the person's light is ~1e-3 of the room's
                rms = background.pow(2).mean(dim=(-3, -2, -1), keepdim=True).sqrt().clamp(min=1e-20)
                images = 1e3 * images / rms
        extra = {"geometry": geometry} if getattr(self.net, "reads_geometry", False) else {}
        if with_aux:
            extra["with_aux"] = True
        if getattr(self.net, "reads_clip_flag", False):
            out = self.net(images, clipped, **extra)
        else:
            out = self.net(images, **extra)
        return (self.position_mean + self.position_std * out[0], *out[1:])


def build_network(arch: str, cfg: NLOSNetConfig | None = None) -> PositionScaled:
    """A freshly initialized network of architecture ``arch``, position output standardized."""
    if arch not in NETWORKS:
        raise NlosError(f"network: unknown architecture '{arch}' (choose from {', '.join(NETWORKS)})")
    cfg = cfg or NLOSNetConfig()
    if cfg.geometry and arch != "resnet18":
        raise NlosError(f"network: only resnet18 reads the room's geometry (net.geometry), not '{arch}'")
    return PositionScaled(NETWORKS[arch](cfg), subtract=cfg.background_subtract, normalize=cfg.normalize,
                          nuisance=cfg.project_nuisance)
