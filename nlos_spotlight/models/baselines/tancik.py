"""Tancik et al.'s regression / identification network (2018), as one two-headed network.

Source: M. Tancik, G. Satat, R. Raskar, "Flash Photography for Data-Driven Hidden Scene
Recovery", arXiv:1810.11710, 2018. The paper lights the visible scene with a flash next to the
camera and trains convolutional networks on rendered flash photographs, with independent
operating modes: a regression output that localizes the hidden object in 2D and an
identification output that classifies its type or pose (a third, generative mode reconstructs
the hidden scene and is not a localization baseline). Here the two outputs share one
convolutional trunk; its VGG-style layer sizes are this project's choice (docs/baselines.md):

    input: image / mean(image)                                           (B, 3, H, W)
    4 stages (32, 64, 128, 256 channels), each:
        [conv 3x3 -> BN -> ReLU] x 2 -> max-pool 2                       (B, 256, H/16, W/16)
    adaptive average pool 2 x 2, flatten                                 (B, 1024)
    shared FC 1024 -> 512 -> ReLU -> dropout 0.3                         (B, 512)
    regression output:     FC 512 -> 2                                   (B, 2)
    identification output: FC 512 -> 6                                  (B, 6)

Shapes:
    images (B, H, W, 3) or (B, 3, H, W), linear radiance -> position (B, 2) m, posture logits (B, 6).
"""

from __future__ import annotations

from torch import nn

from ..nlos_net import NLOSNetConfig
from .common import BaselineNet, conv_block


class TancikNet(BaselineNet):
    """VGG-style trunk, a shared fully connected layer, regression and identification outputs."""

    widths = (32, 64, 128, 256)
    """Channels of the four stages."""
    pooled = 2
    """Side of the adaptive pool before the fully connected layers."""

    def __init__(self, cfg: NLOSNetConfig | None = None):
        super().__init__()
        cfg = cfg or NLOSNetConfig()
        self.check_config(cfg, "tancik")
        stages, cin = [], 3
        for w in self.widths:
            stages += [conv_block(cin, w, 3, pool=False), conv_block(w, w, 3)]
            cin = w
        width = cin * self.pooled**2
        self.features = nn.Sequential(*stages, nn.AdaptiveAvgPool2d(self.pooled), nn.Flatten(),
                                      nn.Linear(width, 512), nn.ReLU(), nn.Dropout(0.3))
        self.position_head = nn.Linear(512, 2)
        self.posture_head = nn.Linear(512, cfg.postures)
        self.reset_parameters()
