"""FeaStConv evaluated per vertex: the same layer as PyTorch Geometric's, without per-edge matmuls.

PyG's ``FeaStConv`` (Verma et al., CVPR 2018) computes, for every edge j -> i of the neighbourhood
(self-loops included) and every head m,

    q_m(x_i, x_j) = softmax_m(u_m^T (x_j - x_i) + c_m),   y_i = b + mean_j sum_m q_m W_m x_j,

by applying the linear maps W and u to each edge's features: E x C x M x C' multiply-adds per layer.
Both maps are linear, so ``W x_j`` and ``u^T x_j - u^T x_i`` can be computed once per vertex and
gathered along the edges (V x C x M x C', V ~ E / 6 on a triangle mesh). The result is the same layer
up to float rounding, with the parameters of the PyG module it is given (tested against PyG,
values and gradients). The IEN uses it when choosing a spot (no autograd).

Shapes:
    x (V, C), edge_index (2, E) with self-loops (``with_self_loops``) -> (V, C').
"""

from __future__ import annotations

import torch


def with_self_loops(edge_index: torch.Tensor, num_nodes: int) -> torch.Tensor:
    """Every vertex's loop added once, as PyG's FeaStConv does on each call (done once per graph here)."""
    from torch_geometric.utils import add_self_loops, remove_self_loops

    return add_self_loops(remove_self_loops(edge_index)[0], num_nodes=num_nodes)[0]


def feast_conv(conv, x: torch.Tensor, edge_index: torch.Tensor) -> torch.Tensor:
    """``conv(x, edge_index)`` for a ``torch_geometric.nn.FeaStConv`` ``conv`` (its ``lin``, ``u``,
    ``c``, ``bias``), evaluated per vertex; ``edge_index`` (source row 0, target row 1) must already
    hold the self-loops."""
    src, dst = edge_index
    heads, cout = conv.heads, conv.out_channels
    wx = conv.lin(x).view(-1, heads, cout)  # W_m x per vertex
    ux = conv.u(x)  # u_m^T x per vertex
    pick = lambda a, i: torch.index_select(a, 0, i)  # faster than advanced indexing on CPU
    q = torch.softmax(pick(ux, src) - pick(ux, dst) + conv.c, dim=1)  # (E, M): u^T (x_j - x_i) + c
    msg = (pick(wx, src) * q.unsqueeze(-1)).sum(1)  # (E, C'): sum over heads
    total = torch.zeros(x.shape[0], cout, dtype=msg.dtype, device=msg.device).index_add_(0, dst, msg)
    count = torch.bincount(dst, minlength=x.shape[0]).clamp(min=1).to(msg.dtype)
    out = total / count.unsqueeze(-1)
    return out + conv.bias if conv.bias is not None else out


__all__ = ["feast_conv", "with_self_loops"]
