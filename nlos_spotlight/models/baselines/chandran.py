"""Chandran & Jayasuriya's CNN (BMVC 2019), with a position head and a posture head.

Source: S. Chandran, S. Jayasuriya, "Adaptive Lighting for Data-Driven Non-Line-of-Sight 3D
Localization and Object Identification", BMVC 2019 (arXiv:1905.11595). The paper feeds the
projector-lit photograph of the LOS scene to a compact convolutional network (convolution and
pooling stages, then fully connected layers) that identifies the hidden object and regresses its
position. Layer sizes here are this project's choice (docs/baselines.md):

    input: image / mean(image)                                   (B, 3, H, W)
    conv 5x5, 32  -> BN -> ReLU -> max-pool 2                    (B, 32, H/2, W/2)
    conv 5x5, 64  -> BN -> ReLU -> max-pool 2                    (B, 64, H/4, W/4)
    conv 3x3, 128 -> BN -> ReLU -> max-pool 2                    (B, 128, H/8, W/8)
    adaptive average pool 4 x 4, flatten                         (B, 2048)
    position head: FC 2048 -> 256 -> ReLU -> FC 256 -> 2         (B, 2)
    posture head:  FC 2048 -> 256 -> ReLU -> FC 256 -> 6         (B, 6)

The adaptive pool fixes the flattened size, so the network takes any image size (12-64 px).

Shapes:
    images (B, H, W, 3) or (B, 3, H, W), linear radiance -> position (B, 2) m, posture logits (B, 6).
"""

from __future__ import annotations

from torch import nn

from ..nlos_net import NLOSNetConfig
from .common import BaselineNet, conv_block, fc_stack


class ChandranCNN(BaselineNet):
    """Three convolution stages and two fully connected heads (module docstring)."""

    pooled = 4
    """Side of the adaptive pool before the heads."""

    def __init__(self, cfg: NLOSNetConfig | None = None):
        super().__init__()
        cfg = cfg or NLOSNetConfig()
        self.check_config(cfg, "chandran")
        self.features = nn.Sequential(conv_block(3, 32, 5), conv_block(32, 64, 5), conv_block(64, 128, 3),
                                      nn.AdaptiveAvgPool2d(self.pooled), nn.Flatten())
        width = 128 * self.pooled**2
        self.position_head = fc_stack([width, 256, 2])
        self.posture_head = fc_stack([width, 256, cfg.postures])
        self.reset_parameters()
