"""Real scans: load, clean, find up, z up with the floor at z = 0; clean_mesh on injected defects."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from nlos_spotlight.errors import NlosError
from nlos_spotlight.scene.clean import clean_mesh
from nlos_spotlight.scene.format import TriMesh
from nlos_spotlight.scene.meshio import load_mesh
from nlos_spotlight.scene.orient import detect_up_axis, dominant_planes, to_z_up, z_up_transform
from nlos_spotlight.scene.scan import load_scan

SCANS = ("copyroom.ply", "icl_livingroom2.obj", "icl_office2.obj")  # in ../shared/data/real-scans

ICL = ("icl_livingroom2.obj", "icl_office2.obj")


@lru_cache(maxsize=None)
def cleaned(path: Path) -> TriMesh:
    return clean_mesh(load_mesh(path))


@lru_cache(maxsize=None)
def z_up(path: Path) -> TriMesh:
    return load_scan(path)


def _flat_area(mesh: TriMesh, zlo: float, zhi: float) -> tuple[float, float]:
    """Area of faces with centroid z in [zlo, zhi) facing up / down (|nz| > 0.9)."""
    a, nz, z = mesh.face_areas(), mesh.face_normals()[:, 2], mesh.centroids()[:, 2]
    sel = (z >= zlo) & (z < zhi)
    return float(a[sel & (nz > 0.9)].sum()), float(a[sel & (nz < -0.9)].sum())


# ---------------------------------------------------------------- real scans

@pytest.mark.parametrize("name", SCANS)
def test_clean_real_scan(name, real_scan):
    raw, mesh = load_mesh(real_scan(name)), cleaned(real_scan(name))
    assert len(mesh.vertices) <= len(raw.vertices) and len(mesh.faces) <= len(raw.faces)
    assert mesh.face_areas().min() > 0
    assert len(np.unique(np.sort(mesh.faces, axis=1), axis=0)) == len(mesh.faces)
    assert len(np.unique(mesh.faces)) == len(mesh.vertices)  # no unreferenced vertices
    # cleaning keeps (almost) all the surface: only specks below 0.1% each go
    assert mesh.face_areas().sum() > 0.97 * raw.face_areas().sum()
    if name.endswith(".obj"):  # the OBJ loader splits vertices by texture coordinate: merged back
        assert len(mesh.vertices) < 0.8 * len(raw.vertices)
    else:
        assert mesh.face_colors is not None and mesh.face_colors.shape == (len(mesh.faces), 3)


@pytest.mark.parametrize("name", ICL)
def test_icl_up_axis_is_minus_y(name, real_scan):
    # Both ICL-NUIM reconstructions are y *down* (camera convention): the furniture stands
    # on the +y end (checked by rendering them). Their README says "y up": the axis is right,
    # the sign is not.
    up = detect_up_axis(cleaned(real_scan(name)))
    assert abs(np.linalg.norm(up) - 1) < 1e-9
    assert up[1] < -0.99


def test_copyroom_is_tilted_and_found(real_scan):
    up = detect_up_axis(cleaned(real_scan("copyroom.ply")))
    angle_to_axes = np.degrees(np.arccos(np.abs(up)))
    assert angle_to_axes.min() > 20  # not axis aligned: the scan's camera frame is tilted
    # the up found by rendering the scan (shelves, counter and bins upright): ~37 deg off -y
    assert up @ np.array([0.0, -0.804, -0.594]) / 1.0 > np.cos(np.radians(3))


@pytest.mark.parametrize("name", SCANS)
def test_z_up_floor_at_bottom(name, real_scan):
    mesh = z_up(real_scan(name))
    z = mesh.vertices[:, 2]
    height = np.quantile(z, 0.995) - np.quantile(z, 0.005)
    assert 2.2 < height < 3.2  # floor to ceiling of a room
    assert abs(np.quantile(z, 0.005)) < 0.1  # floor at z = 0
    # the bottom 5% height slice is mostly floor facing up into the room
    up, down = _flat_area(mesh, -np.inf, np.quantile(z, 0.005) + 0.05 * height)
    a, zc = mesh.face_areas(), mesh.centroids()[:, 2]
    assert up > 0.6 * a[zc < np.quantile(z, 0.005) + 0.05 * height].sum() and down < 0.05 * up
    # furniture tops (0.3-1.3 m) face up: the sign is right, not just the axis
    up_mid, down_mid = _flat_area(mesh, 0.3, 1.3)
    assert up_mid > 3 * down_mid and up_mid > 0.5


@pytest.mark.parametrize("name", SCANS)
def test_z_up_planes_axis_aligned(name, real_scan):
    axes, frac = dominant_planes(z_up(real_scan(name)))
    assert len(axes) >= 3
    for n in axes[:3]:  # the largest planes: floor/ceiling, then walls
        assert abs(n[2]) > np.cos(np.radians(5)) or abs(n[2]) < np.sin(np.radians(5))
    assert abs(axes[0][2]) > np.cos(np.radians(5)) or abs(axes[1][2]) > np.cos(np.radians(5))
    # walls are turned to face x or y
    walls = [n for n in axes[:3] if abs(n[2]) < np.sin(np.radians(5))]
    assert walls and max(np.abs(walls[0][:2])) > np.cos(np.radians(5))


def test_explicit_up_matches_detection(real_scan):
    name = "icl_office2.obj"
    auto, given = z_up(real_scan(name)), load_scan(real_scan(name), up="-y")
    np.testing.assert_allclose(given.vertices, auto.vertices, atol=0.03)
    flipped = load_scan(real_scan(name), up="y")  # wrong on purpose: the ceiling becomes the floor
    up_mid, down_mid = _flat_area(flipped, 0.3, 1.3)
    assert down_mid > up_mid


def test_load_scan_decimates(real_scan):
    mesh = load_scan(real_scan("icl_office2.obj"), target_vertices=600)
    assert abs(len(mesh.vertices) - 600) <= 60
    assert abs(np.quantile(mesh.vertices[:, 2], 0.005)) < 0.1


def test_load_scan_bad_input(tmp_path, real_scan):
    with pytest.raises(NlosError, match="up axis"):
        load_scan(real_scan("icl_office2.obj"), up="up")
    with pytest.raises(NlosError, match="not found"):
        load_scan(tmp_path / "missing.ply")


# ---------------------------------------------------------------- synthetic

def _room() -> TriMesh:
    """A 5 x 4 x 2.5 m box seen from inside (normals inward) with a table top at 0.75 m
    (only its upper side, as a scan sees it)."""
    box = trimesh.creation.box(extents=(5.0, 4.0, 2.5))
    box = trimesh.Trimesh(box.vertices + [0, 0, 1.25], box.faces[:, ::-1])
    box = box.subdivide().subdivide()
    top = trimesh.Trimesh([[0.4, 0.1, 0.75], [1.6, 0.1, 0.75], [1.6, 0.9, 0.75], [0.4, 0.9, 0.75]],
                          [[0, 1, 2], [0, 2, 3]])
    both = trimesh.util.concatenate([box, top])
    return TriMesh(np.asarray(both.vertices), np.asarray(both.faces, np.int64))


def test_synthetic_room_any_rotation():
    rng = np.random.default_rng(0)
    room = _room()
    for seed in range(5):
        rot = Rotation.random(random_state=seed).as_matrix()
        moved = TriMesh(room.vertices @ rot.T + rng.normal(size=3), room.faces)
        up = detect_up_axis(moved)
        assert up @ (rot @ [0, 0, 1.0]) > np.cos(np.radians(1))
        back, r = to_z_up(moved)
        assert np.allclose(r @ r.T, np.eye(3)) and np.linalg.det(r) > 0
        z = back.vertices[:, 2]
        assert abs(z.min()) < 1e-6 and abs(z.max() - 2.5) < 1e-6
        t = z_up_transform(moved)
        np.testing.assert_allclose(moved.vertices @ t[:3, :3].T + t[:3, 3], back.vertices, atol=1e-9)


def test_no_planes_is_an_error():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    with pytest.raises(NlosError, match="up axis"):
        detect_up_axis(TriMesh(np.asarray(sphere.vertices), np.asarray(sphere.faces, np.int64)))


def _exploded_sphere():
    """An icosphere stored like a split OBJ: three private vertices per face."""
    s = trimesh.creation.icosphere(subdivisions=2)
    v, f = np.asarray(s.vertices), np.asarray(s.faces, np.int64)
    return v, f, v[f].reshape(-1, 3), np.arange(3 * len(f)).reshape(-1, 3)


def test_clean_mesh_removes_injected_defects_and_keeps_colors():
    rng = np.random.default_rng(1)
    v0, f0, v, f = _exploded_sphere()
    fcol = rng.uniform(size=(len(f0), 3))
    vcol = (v + 1) / 2  # a color that is a function of position: merged vertices agree
    n = len(v)
    extra_v = np.array([[0.1, 0.1, 0.1], [0.2, 0.2, 0.2], [0.3, 0.3, 0.3],   # collinear
                        [5.0, 5.0, 5.0], [5.001, 5.0, 5.0], [5.0, 5.001, 5.0]])  # far tiny speck
    extra_f = np.array([[0, 0, 1],            # repeated index
                        [n, n + 1, n + 2],     # zero area
                        [n + 3, n + 4, n + 5],  # tiny component
                        f[7][::-1]])           # duplicate face, other winding
    mesh = TriMesh(np.concatenate([v, extra_v]), np.concatenate([f, extra_f]),
                   np.clip(np.concatenate([vcol, (extra_v[:, :3] - 4) / 2]), 0, 1),
                   np.concatenate([fcol, rng.uniform(size=(3, 3)), fcol[7:8]]))
    out = clean_mesh(mesh)
    assert len(out.vertices) == len(v0) and len(out.faces) == len(f0)
    np.testing.assert_allclose(out.vertex_colors, (out.vertices + 1) / 2, atol=1e-12)
    # each face keeps its own color: look faces up by their (rounded) corner positions
    key = (lambda vv, ff: [tuple(sorted(map(tuple, np.round(vv[x], 6)))) for x in ff])
    color_of = dict(zip(key(v0, f0), fcol))
    for k, c in zip(key(out.vertices, out.faces), out.face_colors):
        np.testing.assert_array_equal(c, color_of[k])


def test_clean_mesh_options_and_errors():
    _, _, v, f = _exploded_sphere()
    mesh = TriMesh(v, f)
    assert len(clean_mesh(mesh, min_component_fraction=0.0).faces) == len(f)
    with pytest.raises(NlosError, match="merge_tol"):
        clean_mesh(mesh, merge_tol=0.5)
    with pytest.raises(NlosError, match="no faces"):
        clean_mesh(TriMesh(np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]]), np.array([[0, 1, 2]])))


def test_scan_kept_in_its_own_frame_turns_by_the_smallest_rotation(tmp_path):
    """``load_scan_z_up`` (nlos spotlight, nlos fit): up -> +z, the horizontal axis orthogonal to
    the turn kept, heights and positions otherwise untouched (closed form for a y-up file)."""
    import trimesh

    from nlos_spotlight.scene.scan import load_scan_z_up, rotation_to_z

    box = trimesh.creation.box(extents=(4.0, 2.5, 3.0))  # y is the room's height in this file
    box.apply_translation((1.0, 1.25, -2.0))
    box.export(tmp_path / "room.ply")
    mesh, file_to_world = load_scan_z_up(tmp_path / "room.ply", up="y")
    r = rotation_to_z(np.array([0.0, 1.0, 0.0]))
    np.testing.assert_allclose(r @ [0, 1, 0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(r @ [1, 0, 0], [1, 0, 0], atol=1e-12)  # the turn is about x
    np.testing.assert_allclose(file_to_world[:3, :3], r)
    np.testing.assert_allclose(file_to_world[:3, 3], 0)
    lo, hi = mesh.vertices.min(0), mesh.vertices.max(0)
    np.testing.assert_allclose(lo, [-1.0, 0.5, 0.0], atol=1e-9)  # (x, y, z) -> (x, -z, y): file z in
    np.testing.assert_allclose(hi, [3.0, 3.5, 2.5], atol=1e-9)  # [-3.5, -0.5] is world y; height 0-2.5 m
    with pytest.raises(NlosError, match="unknown axis"):
        load_scan_z_up(tmp_path / "room.ply", up="up")
