"""The per-vertex FeaStConv (``models.feast``) against PyTorch Geometric's layer: values and gradients."""

from __future__ import annotations

import torch
from torch_geometric.nn import FeaStConv

from nlos_spotlight.models.feast import feast_conv, with_self_loops


def test_equals_pyg_values_and_gradients():
    g = torch.Generator().manual_seed(0)
    v, cin, cout = 60, 7, 5
    edges = torch.randint(0, v, (2, 300), generator=g)
    edges = torch.cat([edges, torch.tensor([[3, 4], [3, 4]])], 1)  # loops already present: counted once
    conv = FeaStConv(cin, cout, heads=3).double()
    with torch.no_grad():
        conv.c.normal_(0, 1.0, generator=g)
        conv.bias.normal_(0, 1.0, generator=g)
    x1 = torch.randn(v, cin, generator=g, dtype=torch.float64, requires_grad=True)
    x2 = x1.detach().clone().requires_grad_(True)
    ref, fast = conv(x1, edges), feast_conv(conv, x2, with_self_loops(edges, v))
    torch.testing.assert_close(fast, ref, rtol=1e-10, atol=1e-12)
    w = torch.randn(v, cout, generator=g, dtype=torch.float64)
    ga = torch.autograd.grad((ref * w).sum(), [x1, conv.lin.weight, conv.u.weight, conv.c, conv.bias])
    gb = torch.autograd.grad((fast * w).sum(), [x2, conv.lin.weight, conv.u.weight, conv.c, conv.bias])
    for a, b in zip(ga, gb):
        torch.testing.assert_close(b, a, rtol=1e-9, atol=1e-11)


def test_isolated_vertex_keeps_its_own_term():
    """A vertex without neighbours averages over its self-loop alone: y = W x (heads sum to one) + b."""
    conv = FeaStConv(4, 3, heads=2).double()
    x = torch.randn(5, 4, dtype=torch.float64)
    edges = torch.tensor([[0, 1], [1, 0]])
    y = feast_conv(conv, x, with_self_loops(edges, 5))
    q = torch.softmax(conv.c, 0)  # u^T (x_i - x_i) = 0
    torch.testing.assert_close(y[4], (conv.lin(x[4]).view(2, 3) * q[:, None]).sum(0) + conv.bias)
