"""The NLOS network: ResNet-18 features -> two MLP heads, (x, y) position and six postures.

Each head is three fully connected layers with ReLU, then a last linear layer (DESIGN section 8).
Input: the camera image in radiance units, or with ``background_subtract`` the photograph minus an
empty-room photograph under the same illumination (a capture a user can make; the subtraction is
done by the wrapper of ``models.registry`` for every network alike), divided per image by its root
mean square (:func:`exposure_normalized`: exposure-invariant, and safe for signed differences).

With ``clip_flag`` the sensor's clip flag (B, H, W) is a fourth input channel. With ``geometry``
(the geometry-aware network of rooms it never saw) ten more channels say what each pixel shows:
the visible surface's position, normal and albedo in the region frame and how strongly the
current illumination lights it (``data.geometry``); the photograph alone leaves the network to
infer the room's layout from its light, which a network trained on a few hundred rooms cannot.

Shapes:
    images (B, H, W, 3) or (B, 3, H, W), clipped (B, H, W) bool or None,
    geometry (B, 10, H, W) or None -> position (B, 2) in meters, posture logits (B, 6)
    [, with ``with_aux`` the nuisances (B, 3)].
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from ..data.geometry import GEOMETRY_CHANNELS
from .ien import mlp
from .resnet import backbone


@dataclass
class NLOSNetConfig:
    """Architecture of :class:`NLOSNet`."""

    head_hidden: int = 256
    """Width of the heads' hidden layers."""
    postures: int = 6
    """Posture classes."""
    stem: str = "cifar"
    """ResNet stem: 'cifar' (stride 1) for small images, 'half' (stride 2), 'imagenet' (stride 4) for large ones."""
    pool_grid: int = 1
    """Last feature map averaged to g x g cells and flattened (1: global average pooling, the paper's)."""
    background_subtract: bool = False
    """Feed (photograph - empty-room photograph) instead of the photograph (``registry.PositionScaled``)."""
    coord_channels: bool = False
    """Append the pixel's (x, y) in [-1, 1] as two input channels (CoordConv, Liu et al. NeurIPS 2018)."""
    backbone: str = "resnet18"
    """Feature extractor (``models.resnet.BACKBONES``): 'resnet18' (the paper's) or 'resnet10-narrow'."""
    normalize: str = "image"
    """Input scale: 'image' (each input over its own RMS) or 'background' (the difference over the RMS of
    its empty-room photograph: exposure- and spot-invariant, but keeps how bright the person is)."""
    clip_flag: bool = True
    """Append the camera's clip flag (1 where the pixel saturated) as an input channel."""
    geometry: bool = False
    """Append the room's per-pixel geometry and the spot's lit fraction (``data.geometry``, 10 channels)."""
    project_nuisance: bool = False
    """Remove the capture variation's directions from the difference before reading it
    (``models.nuisance``; needs ``background_subtract`` and the room's prior)."""
    aux_head: bool = False
    """A third head for the nuisances (cos, sin of the facing; height, m): auxiliary targets (``aux_weight``)."""


def with_coordinates(x: torch.Tensor) -> torch.Tensor:
    """(B, C, H, W) -> (B, C + 2, H, W): x then y pixel-center coordinates in [-1, 1] appended.

    Global average pooling makes a CNN blind to where the person's light falls in the frame, and
    where it falls is what encodes the position; coordinate channels give it back (Liu et al. 2018).
    """
    b, _, h, w = x.shape
    ys = torch.linspace(-1, 1, h, device=x.device, dtype=x.dtype).view(1, 1, h, 1).expand(b, 1, h, w)
    xs = torch.linspace(-1, 1, w, device=x.device, dtype=x.dtype).view(1, 1, 1, w).expand(b, 1, h, w)
    return torch.cat([x, xs, ys], dim=1)


def exposure_normalized(images: torch.Tensor) -> torch.Tensor:
    """(B, H, W, 3) or (B, 3, H, W) -> (B, 3, H, W) divided per image by its root mean square."""
    x = NLOSNet.channels_first(images)
    return x / x.pow(2).mean(dim=(1, 2, 3), keepdim=True).sqrt().clamp(min=1e-20)


class NLOSNet(nn.Module):
    """ResNet-18 + position and posture heads (see module docstring)."""

    def __init__(self, cfg: NLOSNetConfig | None = None):
        super().__init__()
        self.cfg = cfg = cfg or NLOSNetConfig()
        channels = 3 + 2 * cfg.coord_channels + cfg.clip_flag + GEOMETRY_CHANNELS * cfg.geometry
        self.backbone = backbone(cfg.backbone, channels, cfg.stem, cfg.pool_grid)
        h, f = cfg.head_hidden, self.backbone.out_features
        self.position_head = mlp([f, h, h, h, 2])
        self.posture_head = mlp([f, h, h, h, cfg.postures])
        self.aux_head = mlp([f, h, h, h, 3]) if cfg.aux_head else None

    def reset_parameters(self) -> None:
        for m in self.modules():
            if m is not self and hasattr(m, "reset_parameters"):
                m.reset_parameters()

    @staticmethod
    def channels_first(images: torch.Tensor) -> torch.Tensor:
        """(B, H, W, 3) -> (B, 3, H, W); channels-first input passes through."""
        return images.permute(0, 3, 1, 2) if images.shape[-1] == 3 and images.shape[1] != 3 else images

    @property
    def reads_clip_flag(self) -> bool:
        return self.cfg.clip_flag

    @property
    def reads_geometry(self) -> bool:
        return self.cfg.geometry

    per_image_norm = True
    """Divide each image by its RMS (off when the registry's wrapper scales by the background)."""

    def forward(self, images: torch.Tensor, clipped: torch.Tensor | None = None,
                geometry: torch.Tensor | None = None, with_aux: bool = False):
        x = exposure_normalized(images) if self.per_image_norm else self.channels_first(images)
        if self.cfg.clip_flag:  # no flag given: nothing clipped (noise-free images)
            flag = torch.zeros_like(x[:, :1]) if clipped is None else clipped.unsqueeze(1).to(x.dtype)
            x = torch.cat([x, flag], dim=1)
        if self.cfg.geometry:
            if geometry is None or geometry.shape != (x.shape[0], GEOMETRY_CHANNELS, *x.shape[2:]):
                raise ValueError(f"geometry-aware network: expected geometry ({x.shape[0]}, {GEOMETRY_CHANNELS}, "
                                 f"{x.shape[2]}, {x.shape[3]}), got {None if geometry is None else tuple(geometry.shape)}")
            x = torch.cat([x, geometry.to(x.dtype)], dim=1)
        f = self.backbone(with_coordinates(x) if self.cfg.coord_channels else x)
        if with_aux:  # (B, 3) nuisances besides position and posture
            if self.aux_head is None:
                raise ValueError("this network has no auxiliary head (net.aux_head)")
            return self.position_head(f), self.posture_head(f), self.aux_head(f)
        return self.position_head(f), self.posture_head(f)
