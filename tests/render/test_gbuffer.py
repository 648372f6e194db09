"""The camera's G-buffer against the closed-form intersection of pixel rays with a plane."""

from __future__ import annotations

import numpy as np

from nlos_spotlight.render.camera import pixel_rays, project
from nlos_spotlight.render.gbuffer import render_gbuffer


def test_gbuffer_is_the_ray_plane_intersection(plate_scene):
    """Wall y = 0 (x in [-3, 3], z in [-1, 3]), albedo 0.8, seen from y = 1.2 with a wide lens:
    hits where the ray meets the finite wall, at o + t d with t = -o_y / d_y, normal +y (toward
    the camera), and misses beside it; every hit projects back to its pixel center."""
    sc = plate_scene(res=16, fov=120.0, kd=0.8)
    sc.human = None
    g = render_gbuffer(sc)
    d, o = pixel_rays(sc.camera, 1)
    d = d[:, :, 0]
    t = -o[1] / d[..., 1]
    p = o + t[..., None] * d
    inside = (t > 0) & (np.abs(p[..., 0]) <= 3) & (p[..., 2] >= -1) & (p[..., 2] <= 3)
    edge = (np.abs(np.abs(p[..., 0]) - 3) < 1e-6) | (np.abs(p[..., 2] + 1) < 1e-6) | (np.abs(p[..., 2] - 3) < 1e-6)
    assert inside.any() and (~inside).any()
    assert np.array_equal(g.hit[~edge], inside[~edge])
    np.testing.assert_allclose(g.position[g.hit], p[g.hit], atol=1e-6)
    np.testing.assert_allclose(g.normal[g.hit], np.broadcast_to([0.0, 1.0, 0.0], (g.hit.sum(), 3)), atol=1e-9)
    np.testing.assert_allclose(g.albedo[g.hit], 0.8, atol=1e-9)
    assert not g.position[~g.hit].any() and not g.normal[~g.hit].any()
    rows, cols = np.nonzero(g.hit)
    np.testing.assert_allclose(project(sc.camera, g.position[g.hit]), np.stack([rows, cols], 1) + 0.5, atol=1e-6)


def test_gbuffer_normals_face_the_camera_from_either_side(plate_scene):
    """The same wall seen from behind (y < 0): the normal turns to -y (materials are two-sided)."""
    sc = plate_scene(res=8, fov=30.0)
    sc.human = None
    sc.camera.position = np.array([2.5, -1.2, 1.0])
    g = render_gbuffer(sc)
    assert g.hit.all()
    np.testing.assert_allclose(g.normal.reshape(-1, 3), np.broadcast_to([0.0, -1.0, 0.0], (64, 3)), atol=1e-9)
