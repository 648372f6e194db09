"""The IEN graph: edges against trimesh, Euler characteristic, normals, frames, normalization."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
import torch
import trimesh
from scipy.spatial.transform import Rotation

from nlos_spotlight.errors import NlosError
from nlos_spotlight.scene.format import TriMesh
from nlos_spotlight.scene.graph import MeshGraph, mesh_to_graph, normalize_positions, to_pyg
from nlos_spotlight.scene.scan import load_scan

SCANS = ("copyroom.ply", "icl_livingroom2.obj", "icl_office2.obj")  # in ../shared/data/real-scans


@lru_cache(maxsize=None)
def scan(path: Path, target: int) -> TriMesh:
    return load_scan(path, target_vertices=target)


def sphere(subdivisions: int = 2) -> TriMesh:
    s = trimesh.creation.icosphere(subdivisions=subdivisions)
    return TriMesh(np.asarray(s.vertices), np.asarray(s.faces, np.int64))


def _check_edges(g: MeshGraph, mesh: TriMesh) -> None:
    """edge_index against trimesh's independent edge list and neighbour sets."""
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    ei = g.edge_index.numpy()
    assert g.edge_index.dtype == torch.int64 and ei.shape[0] == 2
    undirected = tm.edges_unique
    undirected = undirected[undirected[:, 0] != undirected[:, 1]]
    assert ei.shape[1] == 2 * len(undirected)
    assert not np.any(ei[0] == ei[1])  # no self loops
    assert len(np.unique(ei[0] * len(mesh.vertices) + ei[1])) == ei.shape[1]  # no duplicates
    pairs = set(map(tuple, ei.T))
    assert all((b, a) in pairs for a, b in pairs)  # both directions
    assert pairs == set(map(tuple, undirected)) | set(map(tuple, undirected[:, ::-1]))
    degree = np.bincount(ei[0], minlength=len(mesh.vertices))
    assert np.array_equal(degree, [len(n) for n in tm.vertex_neighbors])


def test_icosphere_euler_and_degrees():
    mesh = sphere(2)
    g = mesh_to_graph(mesh)
    _check_edges(g, mesh)
    v, e, f = g.num_vertices, g.edge_index.shape[1] // 2, g.num_faces
    assert (v, e, f) == (162, 480, 320) and v - e + f == 2  # a closed genus-0 surface
    degree = torch.bincount(g.edge_index[0])
    assert int((degree == 5).sum()) == 12 and int((degree == 6).sum()) == v - 12
    # area-weighted vertex normals of a sphere point outward along the radius
    radial = g.pos / g.pos.norm(dim=1, keepdim=True)
    assert torch.allclose(g.normals.norm(dim=1), torch.ones(v), atol=1e-6)
    assert float((g.normals * radial).sum(dim=1).min()) > 0.99


@pytest.mark.parametrize("target", [500, 1000])
@pytest.mark.parametrize("name", SCANS)
def test_real_scan_graph(name, target, real_scan):
    mesh = scan(real_scan(name), target)
    g = mesh_to_graph(mesh)
    assert abs(g.num_vertices - target) <= 0.1 * target and g.num_faces == len(mesh.faces)
    _check_edges(g, mesh)
    assert g.pos.dtype == torch.float32 and g.pos.shape == (g.num_vertices, 3)
    assert g.faces.dtype == torch.int64 and g.faces.shape == (g.num_faces, 3)
    assert torch.allclose(g.normals.norm(dim=1), torch.ones(g.num_vertices), atol=1e-5)
    np.testing.assert_allclose(g.face_normals.numpy(), mesh.face_normals(), atol=1e-5)
    np.testing.assert_allclose(g.face_centroids.numpy(), mesh.centroids(), atol=1e-5)
    if name == "copyroom.ply":  # per-face colors become area-weighted vertex colors
        assert g.colors is not None and g.colors.shape == (g.num_vertices, 3)
        assert float(g.colors.min()) >= 0 and float(g.colors.max()) <= 1
    else:
        assert g.colors is None


def _frame(seed: int, scale: float = 1.0) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = scale * Rotation.random(random_state=seed).as_matrix()
    m[:3, 3] = np.random.default_rng(seed).normal(size=3)
    return m


@pytest.mark.parametrize("scale", [1.0, 2.5])
def test_frame_transform_matches_manual(scale, real_scan):
    mesh = scan(real_scan("icl_office2.obj"), 500)
    frame = _frame(3, scale)
    g0, g = mesh_to_graph(mesh), mesh_to_graph(mesh, frame)
    rot = frame[:3, :3] / scale
    manual = mesh.vertices @ frame[:3, :3].T + frame[:3, 3]
    np.testing.assert_allclose(g.pos.numpy(), manual, atol=1e-4)
    np.testing.assert_allclose(g.face_centroids.numpy(), mesh.centroids() @ frame[:3, :3].T + frame[:3, 3], atol=1e-4)
    np.testing.assert_allclose(g.normals.numpy(), g0.normals.numpy() @ rot.T, atol=1e-5)
    np.testing.assert_allclose(g.face_normals.numpy(), g0.face_normals.numpy() @ rot.T, atol=1e-5)
    assert torch.equal(g.edge_index, g0.edge_index) and torch.equal(g.faces, g0.faces)


def test_mirror_frame_keeps_normals_transformed():
    mesh = sphere(1)
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    g0, g = mesh_to_graph(mesh), mesh_to_graph(mesh, mirror)
    np.testing.assert_allclose(g.normals.numpy(), g0.normals.numpy() * [-1, 1, 1], atol=1e-6)


def test_bad_frames():
    mesh = sphere(1)
    for bad in (np.eye(3), np.full((4, 4), np.nan), np.diag([1.0, 1, 1, 2]), np.diag([0.0, 1, 1, 1])):
        with pytest.raises(NlosError, match="frame"):
            mesh_to_graph(mesh, bad)


def test_normalize_positions_invariance(real_scan):
    pos = mesh_to_graph(scan(real_scan("copyroom.ply"), 500)).pos.double()
    norm, center, scale = normalize_positions(pos)
    assert torch.allclose(norm.mean(dim=0), torch.zeros(3, dtype=norm.dtype), atol=1e-9)
    assert abs(float(norm.pow(2).sum(dim=1).mean().sqrt()) - 1) < 1e-9
    assert torch.allclose(norm * scale + center, pos, atol=1e-9)
    shifted, c2, s2 = normalize_positions(3.7 * pos + torch.tensor([10.0, -4.0, 2.0], dtype=pos.dtype))
    assert torch.allclose(shifted, norm, atol=1e-9)
    assert abs(float(s2 / scale) - 3.7) < 1e-9
    with pytest.raises(NlosError, match="zero spread"):
        normalize_positions(torch.ones(5, 3))
    with pytest.raises(NlosError, match="positions"):
        normalize_positions(torch.ones(5, 2))


def test_to_pyg_runs_feastconv(real_scan):
    from torch_geometric.nn import FeaStConv
    from torch_geometric.utils import contains_self_loops, is_undirected

    g = mesh_to_graph(scan(real_scan("copyroom.ply"), 500))
    data = to_pyg(g)
    assert data.num_nodes == g.num_vertices and data.face.shape == (3, g.num_faces)
    assert is_undirected(data.edge_index) and not contains_self_loops(data.edge_index)
    assert data.color.shape == (g.num_vertices, 3) and data.norm.shape == (g.num_vertices, 3)
    x, _, _ = normalize_positions(data.pos)
    out = FeaStConv(3, 8, heads=2)(x, data.edge_index)
    assert out.shape == (g.num_vertices, 8) and torch.isfinite(out).all()
