"""DL-NLOS (He et al. 2022): five convolution layers and three fully connected layers.

Source: J. He, S. Wu, R. Wei, Y. Zhang, "Non-line-of-sight imaging and tracking of moving
objects based on deep learning", Optics Express 30(10), 2022. Its localization network is five
convolution layers followed by three fully connected layers regressing the hidden object's
position from a camera image of the relay surface. Here the five convolution layers are shared
and each task gets its own three fully connected layers (the posture head is this project's
addition, sized like the position head). Kernel sizes and widths are this project's choice
(docs/baselines.md):

    input: image / mean(image)                                   (B, 3, H, W)
    5 x [conv 3x3 -> BN -> ReLU -> max-pool 2], channels 16, 32, 64, 128, 256
                                                                 (B, 256, ceil(H/32), ceil(W/32))
    adaptive average pool 2 x 2, flatten                         (B, 1024)
    position head: FC 1024 -> 256 -> ReLU -> FC 256 -> 64 -> ReLU -> FC 64 -> 2
    posture head:  FC 1024 -> 256 -> ReLU -> FC 256 -> 64 -> ReLU -> FC 64 -> 6

Shapes:
    images (B, H, W, 3) or (B, 3, H, W), linear radiance -> position (B, 2) m, posture logits (B, 6).
"""

from __future__ import annotations

from torch import nn

from ..nlos_net import NLOSNetConfig
from .common import BaselineNet, conv_block, fc_stack


class DLNLOS(BaselineNet):
    """Five convolution layers, three fully connected layers per head (module docstring)."""

    widths = (16, 32, 64, 128, 256)
    """Channels of the five convolution layers."""
    pooled = 2
    """Side of the adaptive pool before the fully connected layers."""

    def __init__(self, cfg: NLOSNetConfig | None = None):
        super().__init__()
        cfg = cfg or NLOSNetConfig()
        self.check_config(cfg, "dlnlos")
        convs, cin = [], 3
        for w in self.widths:
            convs.append(conv_block(cin, w, 3))
            cin = w
        self.features = nn.Sequential(*convs, nn.AdaptiveAvgPool2d(self.pooled), nn.Flatten())
        width = cin * self.pooled**2
        self.position_head = fc_stack([width, 256, 64, 2])
        self.posture_head = fc_stack([width, 256, 64, cfg.postures])
        self.reset_parameters()
