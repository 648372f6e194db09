"""What the IEN reads besides its mesh: the hidden region's place and the Adaptive Lighting prior."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.errors import NlosError


def test_ien_region_features_are_meters_from_the_hidden_region_center():
    """'region': each vertex in the region frame over REGION_SCALE_M: the hidden region's floor
    center is 0, a point 1.5 m further along the camera's floor direction and 0.6 m up is
    (1.5, 0, 0.6) / 3; the other features are unchanged; no region given is a one-line error."""
    from nlos_spotlight.data.tensors import REGION_SCALE_M, graph_inputs
    from nlos_spotlight.render.camera import camera_frame
    from nlos_spotlight.scene.format import Camera, TriMesh

    cam = Camera(np.array([0.0, 0.0, 1.5]), np.array([2.0, 2.0, 1.0]), np.array([0, 0, 1.0]), 60.0, 8, 8)
    fwd3, right, up = camera_frame(cam)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, up, -fwd3, cam.position
    fwd = np.array([1.0, 1.0]) / np.sqrt(2)
    origin, floor = np.array([3.0, 1.0]), 0.1
    verts = np.array([[3.0, 1.0, 0.1], [3.0 + 1.5 * fwd[0], 1.0 + 1.5 * fwd[1], 0.7], [3.0, 2.0, 0.1]])
    mesh = TriMesh(verts, np.array([[0, 1, 2]]))
    x0, _ = graph_inputs(mesh, pose, ["normals"])
    x, _ = graph_inputs(mesh, pose, ["normals", "region"], (origin, fwd, floor))
    torch.testing.assert_close(x[:, :6], x0)
    left = np.array([-fwd[1], fwd[0]])
    want = np.array([[0, 0, 0], [1.5, 0, 0.6], [np.dot([0, 1], fwd), np.dot([0, 1], left), 0]]) / REGION_SCALE_M
    np.testing.assert_allclose(x[:, 6:].numpy(), want, atol=1e-6)
    with pytest.raises(NlosError, match="hidden region"):
        graph_inputs(mesh, pose, ["region"])
    with pytest.raises(NlosError, match="unknown"):
        graph_inputs(mesh, pose, ["curvature"])


def test_adaptive_prior_is_the_best_face_score_over_four_decades():
    """Face scores 1, 0.01, 1e-6 and 0 of their best map to 1, 0.5, 0 and 0; a vertex takes the
    best of its faces; IEN input gains one column; no scores is a one-line error."""
    from nlos_spotlight.data.tensors import graph_inputs, prior_per_vertex
    from nlos_spotlight.scene.format import TriMesh

    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 0, 0], [2, 1, 0]], float)
    faces = np.array([[0, 1, 2], [1, 3, 2], [1, 4, 3], [4, 5, 3]])
    mesh = TriMesh(v, faces)
    p = prior_per_vertex(mesh, np.array([5.0, 0.05, 5e-6, 0.0]))
    np.testing.assert_allclose(p, [1.0, 1.0, 1.0, 0.5, 0.0, 0.0])
    pose = np.eye(4)
    pose[:3, 3] = [1.0, 0.5, 3.0]
    x, _ = graph_inputs(mesh, pose, ["normals", "adaptive"], prior=np.array([5.0, 0.05, 5e-6, 0.0]))
    assert x.shape == (6, 7)
    np.testing.assert_allclose(x[:, 6].numpy(), p)
    with pytest.raises(NlosError, match="Adaptive Lighting"):
        graph_inputs(mesh, pose, ["adaptive"])
