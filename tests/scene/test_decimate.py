"""Decimation: vertex counts on target, geometric fidelity and colors on the real scans."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from nlos_spotlight.errors import NlosError
from nlos_spotlight.scene.clean import bbox_diagonal, clean_mesh
from nlos_spotlight.scene.decimate import decimate, decimate_ratio
from nlos_spotlight.scene.format import TriMesh
from nlos_spotlight.scene.meshio import load_mesh

SCANS = ("copyroom.ply", "icl_livingroom2.obj", "icl_office2.obj")  # in ../shared/data/real-scans


@lru_cache(maxsize=None)
def cleaned(path: Path) -> TriMesh:
    return clean_mesh(load_mesh(path))


@lru_cache(maxsize=None)
def decimated(path: Path, target: int) -> TriMesh:
    return decimate(cleaned(path), target)


def _tm(mesh: TriMesh) -> trimesh.Trimesh:
    return trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)


def surface_distance(src: TriMesh, dst: TriMesh, n: int = 20_000, dense: int = 300_000) -> np.ndarray:
    """(n,) distances (m) from points sampled on ``src`` to the surface of ``dst``,
    approximated by the nearest of ``dense`` samples on ``dst`` (an overestimate by
    at most about the sample spacing, ~1 cm here)."""
    pts = trimesh.sample.sample_surface(_tm(src), n, seed=0)[0]
    ref = trimesh.sample.sample_surface(_tm(dst), dense, seed=1)[0]
    return cKDTree(ref).query(pts)[0]


def _area_mean(colors: np.ndarray, mesh: TriMesh) -> np.ndarray:
    w = mesh.face_areas()
    return (colors * w[:, None]).sum(axis=0) / w.sum()


@pytest.mark.parametrize("target", [500, 1000])
@pytest.mark.parametrize("name", SCANS)
def test_vertex_count_on_target(name, target, real_scan):
    src, out = cleaned(real_scan(name)), decimated(real_scan(name), target)
    assert abs(len(out.vertices) - target) <= 0.1 * target
    assert out.faces.min() >= 0 and out.faces.max() < len(out.vertices)
    assert len(np.unique(out.faces)) == len(out.vertices)  # every vertex used
    assert out.face_areas().min() > 0
    # most of the surface stays: decimation is not deletion
    assert out.face_areas().sum() > 0.85 * src.face_areas().sum()


@pytest.mark.parametrize("name", SCANS)
def test_fidelity_at_1000_vertices(name, real_scan):
    src, out = cleaned(real_scan(name)), decimated(real_scan(name), 1000)
    d = surface_distance(src, out) / bbox_diagonal(src.vertices)
    assert d.mean() < 0.02  # measured: 0.2% (ICL) to 0.7% (copyroom) of the diagonal
    assert np.quantile(d, 0.9) < 0.05


def test_copyroom_colors_survive(real_scan):
    src = cleaned(real_scan("copyroom.ply"))
    assert src.face_colors is not None
    for target in (500, 1000):
        out = decimated(real_scan("copyroom.ply"), target)
        assert out.face_colors.shape == (len(out.faces), 3) and out.vertex_colors is None
        assert np.abs(_area_mean(out.face_colors, out) - _area_mean(src.face_colors, src)).max() < 0.05
        # colors are the scan's own: every output color exists in the input
        assert np.isin(out.face_colors.view("V24"), src.face_colors.view("V24")).all()


def test_vertex_colors_follow_position():
    s = trimesh.creation.icosphere(subdivisions=4)
    v = np.asarray(s.vertices)
    mesh = TriMesh(v, np.asarray(s.faces, np.int64), vertex_colors=(v + 1) / 2)
    out = decimate(mesh, 300)
    assert abs(len(out.vertices) - 300) <= 30
    # nearest input vertex: off by at most about one input edge (~0.08 on a unit sphere)
    assert np.abs(out.vertex_colors - (out.vertices + 1) / 2).max() < 0.1
    # a closed sphere stays a sphere
    assert np.abs(np.linalg.norm(out.vertices, axis=1) - 1).max() < 0.05


def test_ratio_semantics(real_scan):
    src = cleaned(real_scan("icl_office2.obj"))
    out = decimate_ratio(src, 0.1)
    assert abs(len(out.vertices) - 0.1 * len(src.vertices)) <= 0.1 * 0.1 * len(src.vertices)
    same = decimate_ratio(src, 1.0)
    assert same is not src and np.array_equal(same.vertices, src.vertices)
    for bad in (0.0, -0.5, 1.5, "half"):
        with pytest.raises(NlosError, match="ratio"):
            decimate_ratio(src, bad)


def test_bad_targets():
    s = trimesh.creation.icosphere(subdivisions=1)
    mesh = TriMesh(np.asarray(s.vertices), np.asarray(s.faces, np.int64))
    for bad in (3, 0, -10, 2.5):
        with pytest.raises(NlosError, match="target_vertices"):
            decimate(mesh, bad)
    big = decimate(mesh, 10 * len(mesh.vertices))  # more than there is: an unchanged copy
    assert big is not mesh and np.array_equal(big.vertices, mesh.vertices) and np.array_equal(big.faces, mesh.faces)
    big.vertices[0] = 7.0
    assert mesh.vertices[0, 0] != 7.0
