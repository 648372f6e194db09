"""A fully convolutional network on the floor: it reads the backprojection, not the photograph.

The image networks must learn, from a few hundred rooms, how each room turns a position into light
on its walls; that mapping is what fails to carry over to a new room. The matched filter
(``data/backprojection.py``) applies the known mapping instead, and hands over a map in the
region frame whose meaning is the same in every room: "how much this floor cell explains the
photograph". This network refines that map. It is convolutional over the floor grid (the same
weights at every cell, so nothing about one room's layout is baked in) and answers with a
soft-argmax, so its position is an average of cells weighted by a learned score::

    x = [h_z / max h, log(1 + max(h, 0)) / 5, valid, log(||T_p|| / max ||T||)]   (Z + 3 channels)
    s = CNN(x) masked to valid cells,   p = sum_g softmax(s)_g cell_g,
    posture = MLP(sum_g softmax(s)_g features_g)

where h is the noise-weighted matched filter in units of the noise (its detection SNR per cell and
height), and ||T_p|| how strongly a person at p can light the walls at all. With ``templates`` 2
a second filter, the same kernel without the spot factor (a person lit evenly, as by the room's
ambient light), adds its own Z channels and peak.

Shapes:
    heat (B, M Z, G, G) for M templates, valid (B, G, G), strength (B, G, G), cells (G * G, 2) ->
    position (B, 2) m, posture logits (B, P), scores (B, G, G).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn


@dataclass
class FloorNetConfig:
    """Sizes of :class:`FloorNet`."""

    heights: int = 3
    """Z: heatmap channels per template (the backprojector's heights)."""
    templates: int = 1
    """Matched filters stacked on the channels, each Z heights (the spot's; + the person's ambient light)."""
    width: int = 48
    """Channels of the convolutional layers."""
    layers: int = 6
    """3x3 convolutions (dilations 1, 2, 4, 1, 2, 4, ...: a receptive field of most of the grid)."""
    postures: int = 6
    """Posture classes."""


class FloorNet(nn.Module):
    """Soft-argmax over floor cells of a CNN on the backprojection (module docstring)."""

    def __init__(self, cfg: FloorNetConfig = FloorNetConfig()):
        super().__init__()
        self.cfg = cfg
        cin = cfg.templates * (cfg.heights + 1) + 2
        dil = [(1, 2, 4)[i % 3] for i in range(cfg.layers)]
        convs = []
        for i, d in enumerate(dil):
            convs += [nn.Conv2d(cin if i == 0 else cfg.width, cfg.width, 3, padding=d, dilation=d),
                      nn.GroupNorm(8, cfg.width), nn.ReLU()]
        self.body = nn.Sequential(*convs)
        self.score = nn.Conv2d(cfg.width, 1, 1)
        self.posture = nn.Sequential(nn.Linear(cfg.width, cfg.width), nn.ReLU(), nn.Linear(cfg.width, cfg.postures))
        self.reset_parameters()

    def reset_parameters(self) -> None:
        for m in self.modules():
            if isinstance(m, (nn.Conv2d, nn.Linear, nn.GroupNorm)):
                m.reset_parameters()

    def inputs(self, heat: torch.Tensor, valid: torch.Tensor, strength: torch.Tensor) -> torch.Tensor:
        """(B, M (Z + 1) + 2, G, G) network input from M matched filters (B, M Z, G, G), the valid
        cells and the spot template's norms (B, G, G): each filter over its peak, and its peak."""
        v = valid.unsqueeze(1).to(heat.dtype)
        out = []
        for h in heat.chunk(self.cfg.templates, dim=1):
            peak = (h * v).amax(dim=(1, 2, 3), keepdim=True).clamp(min=1e-6)
            out += [h * v / peak, torch.log1p(peak.clamp(min=0)).expand_as(v) / 5]
        rel = torch.log((strength / strength.amax(dim=(1, 2), keepdim=True).clamp(min=1e-30)).clamp(min=1e-6))
        return torch.cat(out + [v, rel.unsqueeze(1) / 10 * v], 1)

    def forward(self, heat: torch.Tensor, valid: torch.Tensor, strength: torch.Tensor,
                cells: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        f = self.body(self.inputs(heat, valid, strength))
        s = self.score(f).squeeze(1).masked_fill(~valid, float("-inf"))
        w = torch.softmax(s.flatten(1), 1)  # (B, G*G)
        position = w @ cells
        pooled = torch.einsum("bg,bcg->bc", w, f.flatten(2))
        return position, self.posture(pooled), s


__all__ = ["FloorNet", "FloorNetConfig"]
