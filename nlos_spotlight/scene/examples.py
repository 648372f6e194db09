"""Hand-built reference scenes: the bundled example and the renderer cross-check set.

Layout (meters, z up): a relay wall in the plane y = 0 facing +y, a floor,
and a partition at x = 0 for y >= 0.7 that hides the region x > 0 from the
camera and the projector, which stand at x < 0. Light reaches the hidden
person through the 0.7 m gap between partition and relay wall.
"""

from __future__ import annotations

import numpy as np

from .builders import box, corrugated, mannequin, quad
from .format import Ambient, Camera, HiddenRegion, Human, Material, Projector, Scene, Shape, TriMesh

CROSSCHECK = ("diffuse_corner", "glossy_wall", "furniture", "corrugated", "posed_body")
"""Scenes on which ``nlos`` is checked against Mitsuba 3."""

SPOT_TARGET = np.array([-0.35, 0.0, 1.0])
"""A point on the relay wall that the camera, the projector and the person all see."""


def _mat(diffuse, specular=0.0, roughness=0.3, emission=0.0) -> Material:
    return Material(np.full(3, diffuse) if np.isscalar(diffuse) else np.asarray(diffuse, dtype=float),
                    np.full(3, specular) if np.isscalar(specular) else np.asarray(specular, dtype=float),
                    roughness, np.full(3, emission) if np.isscalar(emission) else np.asarray(emission, dtype=float))


def corner_scene(kind: str = "diffuse_corner", resolution: int = 64, human: TriMesh | None = None,
                 beam=(3.0, 5.0)) -> Scene:
    """One of :data:`CROSSCHECK` (or 'example', the demo scene with texture, a monitor and ambient light)."""
    mats = {"paint": _mat(0.7), "floor": _mat(0.35), "partition": _mat(0.6)}
    wall = quad([-2.5, 0, 0], [5.0, 0, 0], [0, 0, 2.5], 20, 10)
    if kind == "glossy_wall":
        mats["paint"] = _mat(0.25, specular=0.5, roughness=0.25)
    if kind == "corrugated":
        wall = corrugated([-2.5, 0, 0], [5.0, 0, 0], [0, 0, 2.5], amplitude=0.06, periods=12, nu=120, nv=4)
    if kind == "example":
        # a painted wall with a horizontal stripe texture (vertex colors)
        wall = quad([-2.5, 0, 0], [5.0, 0, 0], [0, 0, 2.5], 40, 20)
        z = wall.vertices[:, 2]
        wall.vertex_colors = np.where((z > 0.8) & (z < 1.0), 0.6, 1.0)[:, None] * np.array([[1.0, 0.95, 0.85]])
    shapes = [Shape("relay_wall.ply", "paint", wall),
              Shape("floor.ply", "floor", quad([-2.5, 0, 0], [5.0, 0, 0], [0, 4.0, 0], 10, 8)),
              Shape("partition.ply", "partition", quad([0, 0.7, 0], [0, 0, 2.5], [0, 3.3, 0], 5, 6))]
    if kind in ("furniture", "example"):
        mats["wood"] = _mat([0.45, 0.3, 0.18], specular=0.04, roughness=0.35)
        mats["steel"] = _mat(0.05, specular=0.6, roughness=0.2)
        shapes.append(Shape("cabinet.ply", "wood", box([-1.6, 0.0, 0.0], [-0.9, 0.45, 0.9])))
        shapes.append(Shape("fridge.ply", "steel", box([-2.4, 0.0, 0.0], [-1.75, 0.7, 1.8])))
    if kind == "example":
        mats["monitor"] = _mat(0.02, emission=[0.5, 0.6, 0.8])
        shapes.append(Shape("monitor.ply", "monitor", quad([-1.45, 0.3, 0.95], [0.5, 0, 0], [0, 0, 0.32])))
    cam = Camera(np.array([-1.6, 3.2, 1.5]), np.array([-0.5, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]),
                 50.0, resolution, resolution)
    proj = Projector(np.array([-1.3, 3.2, 1.3]), np.full(3, 50.0), *beam)
    scene = Scene(shapes, mats, cam, proj, hidden_region=HiddenRegion(np.array([0.2, 0.7]), np.array([2.5, 3.5])))
    if kind == "example":
        scene.ambient = Ambient(np.full(3, 0.02), np.full(3, 0.02))
    if human is None:
        arms = 90.0 if kind == "posed_body" else 0.0
        human = mannequin([1.1, 1.5, 0.0], 1.75, facing_deg=-120.0, arms_deg=arms)
    scene.human = Human("human.ply", np.array([0.6, 0.5, 0.4]), human)
    return scene
