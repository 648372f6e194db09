"""The world as it differs from the scan (``world.mismatch``): each draw against its closed form."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from nlos_spotlight.render.surface import StaticSurfaces
from nlos_spotlight.render.variation import CaptureVariation, preset
from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene
from nlos_spotlight.world.mismatch import mismatched_world, turned_aim, turned_camera


def _angle(a, b):
    return np.degrees(np.arccos(np.clip(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))


def _albedo(scene) -> np.ndarray:
    """(F, 3, 3) the albedo at each face's corners as the renderer shades them: material x face
    colour x vertex colour."""
    st = StaticSurfaces(scene)
    return st.face_kd[:, None] * st.mesh.vertex_colors[st.mesh.faces]


def test_camera_turns_by_its_angles_about_its_own_axes():
    sc = corner_scene("example", resolution=8)
    fwd0 = sc.camera.look_at - sc.camera.position
    a = corner_scene("example", resolution=8)
    turned_camera(a, np.radians([0.5, 0.0, 0.0]), np.zeros(3))  # pan only
    assert abs(_angle(fwd0, a.camera.look_at - a.camera.position) - 0.5) < 1e-9
    b = corner_scene("example", resolution=8)
    turned_camera(b, np.radians([0.0, 0.0, 2.0]), np.array([0.01, 0, 0]))  # roll only: the axis stays
    assert _angle(fwd0, b.camera.look_at - b.camera.position) < 1e-9
    np.testing.assert_allclose(b.camera.position - sc.camera.position, [0.01, 0, 0])
    assert abs(_angle(np.cross(fwd0, sc.camera.up), np.cross(fwd0, b.camera.up)) - 2.0) < 1e-6


def test_turned_beam_lands_where_the_tangent_says():
    """A pan of theta moves the spot on a wall square to the beam at distance D by D tan(theta)."""
    sc = corner_scene("example", resolution=8)
    proj = sc.projector.position
    aim = np.asarray(SPOT_TARGET, np.float64)
    # the example's relay wall is the plane y = 0 (its points have y = 0); aim square to it from the projector
    square = np.array([proj[0], 0.0, proj[2]])
    d = np.linalg.norm(square - proj)
    moved = turned_aim(sc, square, np.radians([1.0, 0.0]))
    assert abs(moved[1]) < 1e-9
    assert abs(np.linalg.norm(moved - square) - d * np.tan(np.radians(1.0))) < 1e-6
    np.testing.assert_allclose(turned_aim(sc, aim, np.zeros(2)), aim, atol=1e-9)


def test_zero_variation_is_the_scan_and_draws_are_seeded():
    sc = corner_scene("example", resolution=8)
    world, aim, drawn = mismatched_world(sc, SPOT_TARGET, CaptureVariation(), 3)
    assert drawn == {} and np.array_equal(aim, SPOT_TARGET)
    np.testing.assert_array_equal(world.static_mesh()[0].vertices, sc.static_mesh()[0].vertices)
    v = preset("tripod")
    a, aim_a, da = mismatched_world(sc, SPOT_TARGET, v, 5)
    b, aim_b, db = mismatched_world(sc, SPOT_TARGET, v, 5)
    assert da == db and np.array_equal(aim_a, aim_b) and set(da) == {"camera_deg", "camera_m", "albedo_factor",
                                                                     "geometry_m", "warp_m", "projector_deg"}
    np.testing.assert_array_equal(sc.static_mesh()[0].vertices, corner_scene("example", 8).static_mesh()[0].vertices)


def test_albedo_and_geometry_draws_have_their_spread():
    sc = corner_scene("example", resolution=8)
    v = dataclasses.replace(CaptureVariation(), albedo_log=0.2, geometry_m=0.01)
    logs, moves = [], []
    for seed in range(40):
        w, _, d = mismatched_world(sc, SPOT_TARGET, v, seed)
        logs.append(np.log(d["albedo_factor"]))
        moves.append(w.static_mesh()[0].vertices - sc.static_mesh()[0].vertices)
        # every face's albedo (material times mesh colour) times the factor, capped at 1
        np.testing.assert_allclose(_albedo(w), np.minimum(_albedo(sc) * d["albedo_factor"], 1.0), rtol=1e-9)
    assert abs(np.std(logs) - 0.2) < 0.03 and abs(np.std(np.concatenate(moves)) - 0.01) < 5e-4


def test_warp_is_a_smooth_field_of_its_spread():
    """The scan's smooth deformation: each axis's displacement has standard deviation sigma over
    draws, points 1 cm apart move together (correlation exp(-d^2 / 2 L^2) = 0.9998) and points 2 m
    apart independently (3e-4), as the squared-exponential kernel says."""
    from nlos_spotlight.world.mismatch import warp_field

    sigma, length = 0.01, 0.5
    p = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 2.0, 0.0], [0.3, 0.4, 0.0]])
    d = np.stack([warp_field(sigma, length, np.random.default_rng(s))(p) for s in range(2000)])  # (draws, 4, 3)
    assert np.std(d[:, 0]) == pytest.approx(sigma, rel=0.08)
    corr = lambda i, j: np.corrcoef(d[:, i].ravel(), d[:, j].ravel())[0, 1]
    assert corr(0, 1) > 0.99
    assert abs(corr(0, 2)) < 0.08
    assert corr(0, 3) == pytest.approx(np.exp(-0.25 / (2 * length**2)), abs=0.08)  # 0.5 m apart: 0.61


def test_warp_keeps_shapes_that_meet_together():
    from nlos_spotlight.world.mismatch import warped

    sc = corner_scene("example", resolution=8)
    before = [s.mesh.vertices.copy() for s in sc.shapes]
    warped(sc, 0.01, np.random.default_rng(0))
    moves = [s.mesh.vertices - b for s, b in zip(sc.shapes, before)]
    # a point shared by two shapes moves the same in both (one field of position)
    shared = 0
    for i in range(len(before)):
        for j in range(i + 1, len(before)):
            same = (before[i][:, None, :] == before[j][None, :, :]).all(-1)
            a, b = np.nonzero(same)
            np.testing.assert_allclose(moves[i][a], moves[j][b], atol=1e-12)
            shared += len(a)
    assert shared > 0
    assert 0.002 < np.std(np.concatenate(moves)) < 0.03
