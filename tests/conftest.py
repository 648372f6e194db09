"""Shared fixtures: small scenes built in code."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.scene.builders import quad
from nlos_spotlight.scene.format import Ambient, Camera, Human, Material, Projector, Scene, Shape


def plate_scene(res: int = 3, fov: float = 2.0, plate_albedo=0.0, hidden=1.0, kd=0.8) -> Scene:
    """A diffuse wall (y = 0, facing +y), a camera looking at (0, 0, 1) from the side, and a
    1 m x 1 m 'person' plate parallel to the wall at distance 1, centered in front of (0, 0, 1)."""
    wall = quad([-3, 0, -1], [6, 0, 0], [0, 0, 4], 6, 4)
    plate = quad([-0.5, 1.0, 0.5], [1, 0, 0], [0, 0, 1], 8, 8)
    cam = Camera(np.array([2.5, 1.2, 1.0]), np.array([0.0, 0.0, 1.0]), np.array([0, 0, 1.0]), fov, res, res)
    proj = Projector(np.array([1.0, 3.0, 1.0]), np.full(3, 10.0), 20.0, 30.0)
    sc = Scene([Shape("wall.ply", "paint", wall)], {"paint": Material(np.full(3, kd))}, cam, proj,
               ambient=Ambient(np.zeros(3), np.full(3, hidden)))
    sc.human = Human("plate.ply", np.full(3, plate_albedo), plate)
    return sc


@pytest.fixture
def small_corner():
    from nlos_spotlight.scene.examples import corner_scene

    return corner_scene("furniture", resolution=8)


@pytest.fixture(autouse=True)
def _seed():
    torch.manual_seed(0)
    np.random.seed(0)
