"""One LOS-mesh function for datasets, ``nlos fit`` and ``nlos spotlight``."""

from __future__ import annotations

import numpy as np
import pytest

from nlos_spotlight.errors import NlosError
from nlos_spotlight.render.rays import RayEngine
from nlos_spotlight.scene import load_scene
from nlos_spotlight.scene.builders import quad
from nlos_spotlight.scene.format import Camera
from nlos_spotlight.scene.los import los_mesh


def test_a_stored_room_holds_the_los_mesh_of_its_scene(micro_scene, micro_config):
    """Rebuilt from the stored scene by the one function, the LOS mesh is the one the dataset holds."""
    from nlos_spotlight.render.surface import StaticSurfaces

    scene_dir, _ = micro_scene
    st = np.load(scene_dir / "static.npz")
    surf = StaticSurfaces(load_scene(scene_dir))
    m = los_mesh(surf.mesh, surf.engine, load_scene(scene_dir).camera, micro_config["los_vertices"])
    np.testing.assert_allclose(m.vertices, st["los_vertices"], atol=1e-9)
    np.testing.assert_array_equal(m.faces, st["los_faces"])


def test_min_width_finds_the_small_faces_of_a_fine_scan():
    """A 2 m x 2 m wall of 3,200 triangles: an 8-pixel camera's 16 x 16 rays find at most 256 of
    them; widened to 256 pixels (512 x 512 rays) every face is found."""
    wall = quad([-1, 0, 0], [2, 0, 0], [0, 0, 2], 40, 40)
    cam = Camera(np.array([0.0, 2.0, 1.0]), np.array([0.0, 0.0, 1.0]), np.array([0, 0, 1.0]), 60.0, 8, 8)
    engine = RayEngine(wall.vertices, wall.faces)
    coarse = los_mesh(wall, engine, cam, 10**9)
    fine = los_mesh(wall, engine, cam, 10**9, min_width=256)
    assert len(wall.faces) == 3200 and len(coarse.faces) <= 256 and len(fine.faces) == 3200
    away = Camera(np.array([0.0, 2.0, 1.0]), np.array([0.0, 4.0, 1.0]), np.array([0, 0, 1.0]), 60.0, 8, 8)
    with pytest.raises(NlosError, match="sees no face"):
        los_mesh(wall, engine, away, 100)
