"""The room's relay transfer (``render/tail.py``) against closed forms: a closed box returns its
albedo (the form factors out of any point sum to one), two parallel squares the form factor between
them; the room's light carried to other relay points keeps each side's light."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from nlos_spotlight.render.person import monte_carlo
from nlos_spotlight.render.rays import RayEngine
from nlos_spotlight.render.tail import RelayTransfer, RoomLight
from nlos_spotlight.scene.builders import box, quad
from nlos_spotlight.scene.format import TriMesh

pytestmark = pytest.mark.usefixtures("one_thread")


def _points(mesh: TriMesh, n: int):
    """n stratified area samples: positions, unit normals, areas (torch float64)."""
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    face, bary, area = monte_carlo(0.5 * np.linalg.norm(cross, axis=1), n, 0.5)
    normal = cross / np.linalg.norm(cross, axis=1, keepdims=True)
    pos = np.einsum("ij,ijk->ik", bary, tri[face])
    return torch.as_tensor(pos), torch.as_tensor(normal[face]), torch.as_tensor(area)


def _transfer(mesh: TriMesh, n: int, albedo: float, floor: float) -> tuple[RelayTransfer, torch.Tensor]:
    pos, normal, area = _points(mesh, n)
    rho = torch.full((n, 3), albedo / math.pi, dtype=torch.float64)
    return RelayTransfer(pos, normal, area, rho, RayEngine(mesh.vertices, mesh.faces).occluded_rays,
                         floor * float(area.mean())), pos


def test_closed_box_returns_its_albedo():
    tr, pos = _transfer(box([0, 0, 0], [3.0, 4.0, 2.5]), 2048, 0.6, 1.0)
    start = torch.zeros(2, len(pos), 3, dtype=torch.float64)
    start[:, pos[:, 2] < 1e-9] = 1.0  # the floor lit, both sides (its outer side sends light nowhere)
    r = tr.ratios(start, 4)
    assert r[0] == pytest.approx(0.3, rel=0.05)  # half the light leaves outward; the floor clamps the edges
    assert np.allclose(r[1:], 0.6, rtol=0.03)  # inside a closed box, every relay keeps the albedo


def test_parallel_squares_return_their_form_factor():
    a, b = quad([0, 0, 0], [1, 0, 0], [0, 1, 0], 4, 4), quad([0, 0, 1], [1, 0, 0], [0, 1, 0], 4, 4)
    both = TriMesh(np.concatenate([a.vertices, b.vertices]), np.concatenate([a.faces, b.faces + len(a.vertices)]))
    tr, pos = _transfer(both, 2048, 1.0, 0.0)
    start = torch.zeros(2, len(pos), 3, dtype=torch.float64)
    start[0, pos[:, 2] < 0.5] = 1.0  # the lower square's upper side (normal +z), uniformly
    # unit squares one apart face to face: F = 0.19982 (Howell's catalogue, C-11)
    assert tr.ratios(start, 1)[0] == pytest.approx(0.19982, rel=0.01)


def test_room_light_at_its_own_points_and_flipped():
    g = torch.Generator().manual_seed(0)
    pos = torch.rand(64, 3, generator=g, dtype=torch.float64)
    normal = torch.tensor([[0.0, 0.0, 1.0]], dtype=torch.float64).expand(64, 3)
    inc = torch.rand(2, 64, 3, generator=g, dtype=torch.float64)
    light = RoomLight(pos, normal, inc)
    rho = torch.full((64, 3), 0.5, dtype=torch.float64)
    assert torch.allclose(light.at(pos, normal, rho), inc * 0.5, atol=1e-4)  # distance 0: the point itself
    assert torch.allclose(light.at(pos, -normal, rho), inc.flip(0) * 0.5, atol=1e-4)  # facing the other way: sides swap
