"""The NLOS network: ResNet-18 features -> two MLP heads, (x, y) position and six postures.

Each head is three fully connected layers with ReLU, then a last linear layer (DESIGN section 8).
Input: the camera image in radiance units, normalized per image by its mean (exposure-invariant),
optionally with the empty-room frame under the same spot subtracted first (a capture a user can
make): ``background_subtract``.

Shapes:
    images (B, H, W, 3) or (B, 3, H, W) -> position (B, 2) in meters, posture logits (B, 6).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from .ien import mlp
from .resnet import ResNet18


@dataclass
class NLOSNetConfig:
    """Architecture of :class:`NLOSNet`."""

    head_hidden: int = 256
    """Width of the heads' hidden layers."""
    postures: int = 6
    """Posture classes."""
    stem: str = "cifar"
    """ResNet stem: 'cifar' for small images, 'imagenet' for large ones."""
    background_subtract: bool = False
    """Feed (image - empty-room image) with the image as a second 3-channel group."""


class NLOSNet(nn.Module):
    """ResNet-18 + position and posture heads (see module docstring)."""

    def __init__(self, cfg: NLOSNetConfig | None = None):
        super().__init__()
        self.cfg = cfg = cfg or NLOSNetConfig()
        self.backbone = ResNet18(6 if cfg.background_subtract else 3, cfg.stem)
        h = cfg.head_hidden
        self.position_head = mlp([ResNet18.out_features, h, h, h, 2])
        self.posture_head = mlp([ResNet18.out_features, h, h, h, cfg.postures])

    def reset_parameters(self) -> None:
        for m in self.modules():
            if m is not self and hasattr(m, "reset_parameters"):
                m.reset_parameters()

    @staticmethod
    def channels_first(images: torch.Tensor) -> torch.Tensor:
        """(B, H, W, 3) -> (B, 3, H, W); channels-first input passes through."""
        return images.permute(0, 3, 1, 2) if images.shape[-1] == 3 and images.shape[1] != 3 else images

    def forward(self, images: torch.Tensor, background: torch.Tensor | None = None):
        x = self.channels_first(images)
        scale = x.mean(dim=(1, 2, 3), keepdim=True).clamp(min=1e-12)  # exposure-free input
        x = x / scale
        if self.cfg.background_subtract:
            if background is None:
                raise ValueError("background_subtract needs the empty-room image")
            x = torch.cat([x, x - self.channels_first(background) / scale], dim=1)
        f = self.backbone(x)
        return self.position_head(f), self.posture_head(f)
