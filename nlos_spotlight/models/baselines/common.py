"""Plumbing shared by the baseline networks: exposure-free input, conv blocks, heads.

Every baseline sees what :class:`~nlos_spotlight.models.nlos_net.NLOSNet` sees, the camera image
in radiance units divided by its own mean, ``x / mean(x)``, so the exposure (a global scale)
carries no information and the comparison is between architectures only.

Shapes:
    images (B, H, W, 3) or (B, 3, H, W) -> position (B, 2), posture logits (B, postures).
"""

from __future__ import annotations

import torch
from torch import nn


from ..nlos_net import NLOSNet, exposure_normalized  # noqa: E402  (shared by every network)


def conv_block(cin: int, cout: int, kernel: int, pool: bool = True) -> nn.Sequential:
    """conv (same padding) -> batch norm -> ReLU [-> 2x2 max-pool].

    The pool rounds up (``ceil_mode``) so that five of them still leave a pixel of a 12 x 12 image.
    """
    mods = [nn.Conv2d(cin, cout, kernel, padding=kernel // 2, bias=False), nn.BatchNorm2d(cout), nn.ReLU()]
    if pool:
        mods.append(nn.MaxPool2d(2, ceil_mode=True))
    return nn.Sequential(*mods)


def fc_stack(sizes: list[int], dropout: float = 0.0) -> nn.Sequential:
    """Linear layers of ``sizes`` with ReLU (and dropout) between them, none after the last."""
    mods: list[nn.Module] = []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        mods.append(nn.Linear(a, b))
        if i < len(sizes) - 2:
            mods.append(nn.ReLU())
            if dropout > 0:
                mods.append(nn.Dropout(dropout))
    return nn.Sequential(*mods)


class BaselineNet(nn.Module):
    """A feature extractor and two heads on exposure-normalized images.

    Subclasses set ``features`` ((B, 3, H, W) -> (B, F)), ``position_head`` ((B, F) -> (B, 2)) and
    ``posture_head`` ((B, F) -> (B, postures)), then call :meth:`reset_parameters`.
    """

    features: nn.Module
    position_head: nn.Module
    posture_head: nn.Module

    @staticmethod
    def check_config(cfg, name: str) -> None:
        """Every NLOSNetConfig option applies (background subtraction happens in the registry's wrapper)."""

    def reset_parameters(self) -> None:
        """He (Kaiming) initialization for convolutions, PyTorch defaults for the rest."""
        for m in self.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
            elif m is not self and hasattr(m, "reset_parameters"):
                m.reset_parameters()

    per_image_norm = True
    """Divide each image by its RMS (off when the registry's wrapper scales by the background)."""

    def forward(self, images: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = exposure_normalized(images) if self.per_image_norm else NLOSNet.channels_first(images)
        f = self.features(x)
        return self.position_head(f), self.posture_head(f)
