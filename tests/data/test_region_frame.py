"""The region frame of the targets and its inverse (``data.tensors``)."""

import numpy as np

from nlos_spotlight.data.tensors import ground_frame, world_floor


def test_ground_frame_by_hand():
    # looking along +y from (1, 2): one metre ahead is (1, 0), one metre to the left (-x) is (0, 1)
    rel = ground_frame(np.array([[1.0, 3.0], [0.0, 2.0]]), np.array([1.0, 2.0]), np.array([0.0, 1.0]))
    np.testing.assert_allclose(rel, [[1.0, 0.0], [0.0, 1.0]], atol=1e-12)


def test_world_floor_inverts_ground_frame():
    rng = np.random.default_rng(0)
    fwd = rng.normal(size=2)
    fwd /= np.linalg.norm(fwd)
    origin, pts = rng.normal(size=2), rng.normal(size=(20, 2)) * 3
    np.testing.assert_allclose(world_floor(ground_frame(pts, origin, fwd), origin, fwd), pts, atol=1e-12)
