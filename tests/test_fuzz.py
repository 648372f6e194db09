"""Property-based fuzzing of what users hand in: scene.json, mesh files, images for ``nlos predict``.

Each generated input must end in a result or one NlosError (the CLI's one-line ``error:``), never
another exception, a hang (hypothesis' deadline) or a file left behind. At least 1,000 inputs a run
(``settings`` below); the seed is fixed (``derandomize``) so a failure reproduces.
"""

from __future__ import annotations

import copy
import json
import struct
import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nlos_spotlight.errors import NlosError

FUZZ = settings(max_examples=400, deadline=2000, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

SCENE = {
    "format": "nlos-scene/1", "units": "meters",
    "shapes": [{"mesh": "wall.ply", "material": "paint"}],
    "materials": {"paint": {"diffuse": [0.7, 0.7, 0.7], "specular": [0.1, 0.1, 0.1], "roughness": 0.3}},
    "camera": {"position": [0, 3, 1.5], "look_at": [0, 0, 1], "up": [0, 0, 1], "fov_deg": 50.0,
               "width": 8, "height": 8},
    "projector": {"position": [0.3, 3, 1.3], "intensity": [50, 50, 50], "beam_width_deg": 3.0, "cutoff_deg": 5.0},
    "ambient": {"radiance": [0.02, 0.02, 0.02], "hidden_radiance": [0.02, 0.02, 0.02]},
    "hidden_region": {"min": [0.2, 0.7], "max": [2.5, 3.5], "floor_z": 0.0},
    "sensor": {"burst_frames": 2},
}
WALL = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
        "-3 0 0\n3 0 0\n3 0 3\n-3 0 3\n3 0 1 2\n3 0 2 3\n")

json_leaf = st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12),
                      st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12))
json_value = st.recursive(json_leaf, lambda inner: st.one_of(st.lists(inner, max_size=5),
                                                             st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                          max_leaves=12)


def _paths(d, prefix=()):
    """Every key path of a nested dict/list."""
    items = d.items() if isinstance(d, dict) else enumerate(d) if isinstance(d, list) else ()
    for k, v in items:
        yield prefix + (k,)
        yield from _paths(v, prefix + (k,))


PATHS = list(_paths(SCENE))


@st.composite
def mutated_scene(draw):
    d = copy.deepcopy(SCENE)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(PATHS))
        parent = d
        try:
            for k in path[:-1]:
                parent = parent[k]
            action = draw(st.sampled_from(["replace", "delete", "extra"]))
            if action == "replace":
                parent[path[-1]] = draw(json_value)
            elif action == "delete" and isinstance(parent, dict):
                parent.pop(path[-1], None)
            elif isinstance(parent, dict):
                parent[draw(st.text(max_size=6))] = draw(json_value)
        except (KeyError, IndexError, TypeError):
            pass  # an earlier mutation removed or retyped this path
    return d


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz_scene")
    (d / "wall.ply").write_text(WALL)
    return d


@FUZZ
@given(mutated_scene())
def test_scene_reader(scene_dir, d):
    from nlos_spotlight.scene.io import load_scene

    (scene_dir / "scene.json").write_text(json.dumps(d, allow_nan=True))
    try:
        load_scene(scene_dir)
    except NlosError as exc:
        assert "\n" not in str(exc)


number = st.one_of(st.floats(-1e6, 1e6), st.sampled_from(["nan", "inf", "-inf", "1e400", "x", ""]))


@st.composite
def mesh_text(draw):
    nv, nf = draw(st.integers(0, 6)), draw(st.integers(0, 6))
    verts = [[draw(number) for _ in range(draw(st.integers(2, 4)))] for _ in range(nv)]
    faces = [[draw(st.integers(-3, 9)) for _ in range(draw(st.integers(1, 5)))] for _ in range(nf)]
    if draw(st.booleans()):
        body = "".join("v " + " ".join(map(str, v)) + "\n" for v in verts)
        body += "".join("f " + " ".join(str(i + 1) for i in f) + "\n" for f in faces)
        return ".obj", body.encode()
    declared_v, declared_f = draw(st.sampled_from([(nv, nf), (nv + 2, nf), (nv, max(nf - 1, 0)), (10**9, 1)]))
    head = (f"ply\nformat ascii 1.0\nelement vertex {declared_v}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {declared_f}\nproperty list uchar int vertex_indices\nend_header\n")
    body = "".join(" ".join(map(str, v)) + "\n" for v in verts)
    body += "".join(f"{len(f)} " + " ".join(map(str, f)) + "\n" for f in faces)
    return ".ply", (head + body).encode(draw(st.sampled_from(["utf-8", "utf-16", "latin-1"])))


@FUZZ
@given(mesh_text())
def test_mesh_loader(tmp_path, case):
    from nlos_spotlight.scene.meshio import load_mesh

    suffix, data = case
    path = tmp_path / f"m{suffix}"
    path.write_bytes(data)
    try:
        m = load_mesh(path)
        assert np.isfinite(m.vertices).all() and m.faces.min() >= 0 and m.faces.max() < len(m.vertices)
    except NlosError as exc:
        assert "\n" not in str(exc)


def _png(width: int, height: int, bit_depth: int, color_type: int, raw: bytes, crc_ok: bool) -> bytes:
    def chunk(kind: bytes, payload: bytes) -> bytes:
        crc = zlib.crc32(kind + payload) ^ (0 if crc_ok else 1)
        return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", crc & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


@st.composite
def image_file(draw):
    kind = draw(st.sampled_from(["npy", "png", "bytes"]))
    if kind == "npy":
        shape = tuple(draw(st.lists(st.integers(0, 9), min_size=1, max_size=5)))
        dtype = draw(st.sampled_from(["float32", "float64", "int16", "uint8", "bool", "complex64", "float16"]))
        vals = np.asarray(draw(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32),
                                        min_size=1, max_size=16)))
        with np.errstate(invalid="ignore", over="ignore"):
            return ".npy", np.resize(vals, shape).astype(dtype)
    if kind == "png":
        w, h = draw(st.integers(0, 9)), draw(st.integers(0, 9))
        depth, ctype = draw(st.sampled_from([8, 16, 1, 3])), draw(st.sampled_from([0, 2, 4, 6, 3, 5]))
        raw = draw(st.binary(max_size=400))
        return ".png", _png(w, h, depth, ctype, raw, draw(st.booleans()))
    return draw(st.sampled_from([".png", ".jpg", ".npy"])), draw(st.binary(max_size=300))


@FUZZ
@given(image_file())
def test_image_reader(tmp_path, case):
    from nlos_spotlight.apps.images import load_frames

    suffix, data = case
    path = tmp_path / f"img{suffix}"
    if isinstance(data, np.ndarray):
        np.save(path, data)
    else:
        path.write_bytes(data)
    before = set(tmp_path.iterdir())
    try:
        frames = load_frames([str(path)], (4, 4), False)
        assert frames.images.shape[1:] == (4, 4, 3) and np.isfinite(frames.images).all()
    except NlosError as exc:
        assert "\n" not in str(exc)
    assert set(tmp_path.iterdir()) == before

