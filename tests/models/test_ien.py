"""IEN: FeaStConv stack against a dense float64 reference of the paper's equations; invariances."""

from __future__ import annotations

import numpy as np
import torch

from nlos_spotlight.models.ien import IEN, IENConfig


def _mesh(seed: int = 0):
    import trimesh

    tm = trimesh.creation.icosphere(subdivisions=2)
    rng = np.random.default_rng(seed)
    v = tm.vertices * rng.uniform(0.5, 2.0, 3) + rng.normal(0, 0.05, tm.vertices.shape)
    e = tm.edges_unique
    edge_index = torch.as_tensor(np.concatenate([e, e[:, ::-1]]).T.copy(), dtype=torch.long)
    return torch.as_tensor(v), edge_index, torch.as_tensor(tm.faces, dtype=torch.long)


def dense_feast(conv, x: torch.Tensor, adj: torch.Tensor) -> torch.Tensor:
    """y_i = b + 1/|N_i| sum_j A_ij sum_m softmax_m(u_m.(x_j - x_i) + c_m) W_m x_j, N_i including i."""
    a = adj.clone().fill_diagonal_(1)
    heads = conv.heads
    u, c = conv.u.weight, conv.c  # (M, C_in), (M,)
    w = conv.lin.weight.view(heads, -1, x.shape[1])  # (M, C_out, C_in)
    diff = x.unsqueeze(0) - x.unsqueeze(1)  # [i, j] = x_j - x_i
    q = torch.softmax(diff @ u.T + c, dim=-1)  # (N, N, M)
    wx = torch.einsum("moc,jc->jmo", w, x)  # (N, M, C_out)
    msg = torch.einsum("ijm,jmo->ijo", q, wx)
    return (a.unsqueeze(-1) * msg).sum(1) / a.sum(1, keepdim=True) + conv.bias


def test_feast_stack_matches_dense_reference():
    torch.manual_seed(0)
    pos, ei, faces = _mesh()
    net = IEN(IENConfig(hidden=16)).double()
    adj = torch.zeros(len(pos), len(pos), dtype=torch.float64)
    adj[ei[0], ei[1]] = 1
    h_ref = net.encoder(pos)
    for conv in net.convs:
        h_ref = torch.relu(dense_feast(conv, h_ref, adj))
    assert torch.allclose(net.vertex_features(pos, ei), h_ref, rtol=1e-10, atol=1e-12)


def test_face_probabilities_invariant_to_permutations_translation_scale():
    torch.manual_seed(1)
    pos, ei, faces = _mesh(1)
    net = IEN(IENConfig(hidden=16)).double()
    from nlos_spotlight.scene.graph import normalize_positions

    def probs(p, e, f):
        return torch.softmax(net(normalize_positions(p)[0], e, f), 0)

    base = probs(pos, ei, faces)
    perm = torch.randperm(len(pos))
    inv = torch.empty_like(perm)
    inv[perm] = torch.arange(len(pos))
    fperm = torch.randperm(len(faces))
    moved = probs(pos[perm], inv[ei], inv[faces][fperm])
    assert torch.allclose(moved, base[fperm], rtol=1e-9, atol=1e-12)
    rolled = probs(pos, ei, faces.roll(1, dims=1))  # a face listing its vertices in another order
    assert torch.allclose(rolled, base, rtol=1e-9, atol=1e-12)
    shifted = probs(pos * 3.7 + torch.tensor([5.0, -2.0, 1.0], dtype=torch.float64), ei, faces)
    assert torch.allclose(shifted, base, rtol=1e-9, atol=1e-12)
    assert base.max() / base.min() > 1.0 + 1e-6  # not trivially constant
