"""The Illumination Estimation Network: which face of the LOS mesh to spotlight.

Per-vertex MLP encoder -> three FeaStConv layers (Verma et al., "FeaStNet: Feature-Steered Graph
Convolutions for 3D Shape Analysis", CVPR 2018) -> per-face MLP on symmetric functions of the face's
vertex features -> one logit per face. A FeaStConv layer with M heads computes

    y_i = b + 1/|N_i| sum_{j in N_i} sum_m q_m(x_i, x_j) W_m x_j,
    q_m(x_i, x_j) = softmax_m(u_m^T (x_j - x_i) + c_m),

over the mesh neighbourhood N_i including i (the WACV 2024 paper's Eq. (2)-(3)). Inputs are vertex
coordinates in the camera frame, centered and scaled (``scene.graph.normalize_positions``), so the
output is invariant to the scan's translation and scale; the face read-out (mean and max over the
three vertices) is invariant to how a face lists its vertices.

Shapes:
    pos (V, 3), optional extra features (V, C), edge_index (2, E), faces (F, 3)
    [, face_prior (F,) with ``prior_weight``] -> logits (F,).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn


@dataclass
class IENConfig:
    """Architecture of :class:`IEN`."""

    in_features: int = 3
    """Per-vertex input width: 3 coordinates (+3 normals, +3 colors when enabled)."""
    hidden: int = 64
    """Width of vertex features."""
    heads: int = 2
    """FeaStConv attention heads."""
    layers: int = 3
    """FeaStConv layers."""
    prior_weight: float = 0.0
    """Add this times each face's log prior (``face_prior``: the Adaptive Lighting score's log over
    the best one) to its logit, so the IEN learns a correction of a physics prior; 0: none."""


def mlp(sizes: list[int]) -> nn.Sequential:
    mods: list[nn.Module] = []
    for a, b in zip(sizes[:-1], sizes[1:]):
        mods += [nn.Linear(a, b), nn.ReLU()]
    return nn.Sequential(*mods[:-1])


class IEN(nn.Module):
    """Illumination Estimation Network (see module docstring)."""

    def __init__(self, cfg: IENConfig | None = None):
        super().__init__()
        from torch_geometric.nn import FeaStConv

        self.cfg = cfg = cfg or IENConfig()
        self.encoder = mlp([cfg.in_features, cfg.hidden, cfg.hidden])
        self.convs = nn.ModuleList(FeaStConv(cfg.hidden, cfg.hidden, heads=cfg.heads) for _ in range(cfg.layers))
        self.face_head = mlp([2 * cfg.hidden, cfg.hidden, cfg.hidden, 1])
        self.reset_parameters()

    def reset_parameters(self) -> None:
        for m in self.modules():
            if m is not self and hasattr(m, "reset_parameters"):
                m.reset_parameters()

    def vertex_features(self, x: torch.Tensor, edge_index: torch.Tensor) -> torch.Tensor:
        """(V, in) -> (V, hidden). Without autograd (choosing a spot) the FeaStConv layers run per
        vertex (``models.feast``: PyG's layer and parameters, its per-edge products factored out,
        2x faster); training keeps PyG's own layer. The two agree to float rounding (tested), but
        the toy IEN training of the tests amplifies rounding into a different optimum, so training
        stays on the path it was tuned with."""
        from .feast import feast_conv, with_self_loops

        h = self.encoder(x)
        if torch.is_grad_enabled():
            for conv in self.convs:
                h = torch.relu(conv(h, edge_index))
            return h
        loops = with_self_loops(edge_index, x.shape[0])
        for conv in self.convs:
            h = torch.relu(feast_conv(conv, h, loops))
        return h

    def forward(self, x: torch.Tensor, edge_index: torch.Tensor, faces: torch.Tensor,
                face_prior: torch.Tensor | None = None) -> torch.Tensor:
        h = self.vertex_features(x, edge_index)[faces]  # (F, 3, hidden)
        logits = self.face_head(torch.cat([h.mean(1), h.amax(1)], dim=-1)).squeeze(-1)
        if self.cfg.prior_weight:
            if face_prior is None or face_prior.shape != logits.shape:
                raise ValueError(f"IEN with prior_weight: expected a face prior of shape {tuple(logits.shape)}")
            logits = logits + self.cfg.prior_weight * face_prior.to(logits.dtype)
        return logits
