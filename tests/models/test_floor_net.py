"""FloorNet (``models/floor_net.py``): answers only valid cells, and learns to read a backprojection."""

from __future__ import annotations

import torch

from nlos_spotlight.models.floor_net import FloorNet, FloorNetConfig

N = 11


def grid() -> torch.Tensor:
    g = torch.linspace(-1.0, 1.0, N)
    gx, gy = torch.meshgrid(g, g, indexing="ij")
    return torch.stack([gx.flatten(), gy.flatten()], 1)


def blobs(where: torch.Tensor, gen: torch.Generator, heights: int = 3) -> torch.Tensor:
    """(B, Z, N, N) a matched filter's map: a bump at each person's place plus noise."""
    cells = grid()
    d2 = ((cells[None] - where[:, None]) ** 2).sum(-1).reshape(-1, 1, N, N)
    return 5 * torch.exp(-d2 / 0.08).expand(-1, heights, -1, -1) + torch.randn(len(where), heights, N, N, generator=gen)


def test_answers_are_averages_of_valid_cells_only(one_thread):
    torch.manual_seed(0)
    net = FloorNet(FloorNetConfig(width=16, layers=3))
    valid = torch.zeros(4, N, N, dtype=torch.bool)
    valid[:, 2:5, 6:9] = True  # x in [-0.6, -0.2], y in [0.2, 0.6]
    pos, logits, scores = net(torch.randn(4, 3, N, N), valid, torch.rand(4, N, N) + 0.1, grid())
    assert pos.shape == (4, 2) and logits.shape == (4, 6) and scores.shape == (4, N, N)
    assert (pos[:, 0] >= -0.6 - 1e-6).all() and (pos[:, 0] <= -0.2 + 1e-6).all()
    assert (pos[:, 1] >= 0.2 - 1e-6).all() and (pos[:, 1] <= 0.6 + 1e-6).all()
    assert torch.isinf(scores[~valid]).all()


def test_learns_to_find_the_bump(one_thread):
    """Trained for 150 steps on noisy bumps, it localizes fresh ones 3x better than the grid's center."""
    torch.manual_seed(0)
    gen = torch.Generator().manual_seed(0)
    net = FloorNet(FloorNetConfig(width=16, layers=3))
    opt = torch.optim.Adam(net.parameters(), lr=3e-3)
    valid = torch.ones(32, N, N, dtype=torch.bool)
    strength = torch.ones(32, N, N)
    for _ in range(150):
        where = torch.rand(32, 2, generator=gen) * 1.6 - 0.8
        pos, _, _ = net(blobs(where, gen), valid, strength, grid())
        loss = (pos - where).norm(dim=1).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    where = torch.rand(32, 2, generator=gen) * 1.6 - 0.8
    with torch.no_grad():
        pos, _, _ = net(blobs(where, gen), valid, strength, grid())
    assert (pos - where).norm(dim=1).mean() < where.norm(dim=1).mean() / 3
