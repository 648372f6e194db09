"""Property-based fuzzing of what users hand in or share: scene.json (mesh names toward and past its
directory), mesh files, images for ``nlos predict`` (past PIL's pixel limit, float64-wide values),
a room model's report.json, YAML dataset configs and checkpoints.

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


@st.composite
def mutated(draw, base: dict, most: int, actions=("replace", "delete", "extra")):
    """``base`` with 1 to ``most`` of its key paths replaced by any JSON value, deleted, or given an
    extra sibling key (``actions``)."""
    d = copy.deepcopy(base)
    paths = list(_paths(base))
    for _ in range(draw(st.integers(1, most))):
        path = draw(st.sampled_from(paths))
        parent = d
        try:
            for k in path[:-1]:
                parent = parent[k]
            action = draw(st.sampled_from(actions))
            if action == "replace":
                parent[path[-1]] = draw(json_value)
            elif action == "delete" and isinstance(parent, dict):
                parent.pop(path[-1], None)
            elif action == "extra" and isinstance(parent, dict):
                parent[draw(st.text(max_size=6))] = draw(json_value)
        except (KeyError, IndexError, TypeError):
            pass  # an earlier mutation removed or retyped this path
    return d


MESH_NAMES = ["wall.ply", "./wall.ply", "sub/../wall.ply", "../wall.ply", "../../x/wall.ply", "/etc/passwd",
              "/tmp/wall.ply", "..", "", "wall.ply/..", "~/wall.ply", "wall.PLY", "link.ply"]
"""Mesh names toward and past the scene directory's edge (issue 36, item 2); ``link.ply`` is a
symlink out of it."""


@st.composite
def named_scene(draw):
    d = draw(mutated(SCENE, 3))
    if draw(st.booleans()) and isinstance(d.get("shapes"), list) and d["shapes"] and isinstance(d["shapes"][0], dict):
        d["shapes"][0]["mesh"] = draw(st.sampled_from(MESH_NAMES))
    return d


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz_scene")
    (d / "wall.ply").write_text(WALL)
    outside = tmp_path_factory.mktemp("outside") / "wall.ply"
    outside.write_text(WALL)
    (d / "link.ply").symlink_to(outside)
    return d


@FUZZ
@given(named_scene())
def test_scene_reader(scene_dir, tmp_path_factory, d):
    """A load ends in one line, or in a scene whose invariants hold, that reads only files inside
    its directory and that writes back and reads again to the same numbers (a round trip)."""
    from nlos_spotlight.scene.io import load_scene, save_scene

    (scene_dir / "scene.json").write_text(json.dumps(d, allow_nan=True))
    try:
        sc = load_scene(scene_dir)
    except NlosError as exc:
        assert "\n" not in str(exc)
        return
    name = d["shapes"][0]["mesh"]
    assert (scene_dir / name).resolve().parent == scene_dir.resolve(), name  # nothing outside was read
    cam = sc.camera
    assert np.isfinite(cam.position).all() and np.isfinite(cam.look_at).all() and 0 < cam.fov_deg < 180
    assert cam.width >= 1 and cam.height >= 1 and sc.num_faces >= 1
    for m in sc.materials.values():
        assert np.all((np.asarray(m.diffuse) >= 0) & (np.asarray(m.diffuse) <= 1))
    again_dir = tmp_path_factory.mktemp("again")
    save_scene(sc, again_dir)
    again = load_scene(again_dir)
    np.testing.assert_allclose(again.camera.position, cam.position)
    np.testing.assert_allclose(again.static_mesh()[0].vertices, sc.static_mesh()[0].vertices, rtol=1e-6)
    assert {k: m.to_dict() for k, m in again.materials.items()} == {k: m.to_dict() for k, m in sc.materials.items()}


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
        vals = np.asarray(draw(st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32),
                                                  st.sampled_from([1.7e308, -1e300, 3.5e38, 1e-320])),
                                        min_size=1, max_size=16)))  # float64-wide too: finite, then not in float32
        with np.errstate(invalid="ignore", over="ignore"):
            return ".npy", np.resize(vals, shape).astype(dtype)
    if kind == "png":
        big = st.sampled_from([20_000, 65_535, 2 ** 31 - 1])  # past PIL's pixel limit (a decompression bomb)
        w, h = draw(st.one_of(st.integers(0, 9), big)), draw(st.one_of(st.integers(0, 9), big))
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



REPORT = {
    "capture": {"burst_frames": 4, "exposure_s": 0.05},
    "spot": {"face": 3, "pan_deg": 6.3, "tilt_deg": 1.5},
    "room": {"hidden_region": {"min": [-0.5, -0.1], "max": [2.1, 1.1], "floor_z": -1.3},
             "camera": {"position": [0.35, -0.3, 0.09], "look_at": [0.9, -2.0, -0.3]}},
}


@FUZZ
@given(mutated(REPORT, 2, ("replace", "delete")))
def test_room_model_report_reader(tmp_path_factory, d):
    """A hand-edited ``report.json`` loads into a room model whose numbers a photograph can use, or
    is refused in one line (issue 36, item 15)."""
    from nlos_spotlight.fit.model import load_room_model

    m = tmp_path_factory.mktemp("model")
    (m / "fit.json").write_text("{}")
    (m / "report.json").write_text(json.dumps(d, allow_nan=True))
    try:
        room = load_room_model(m)
    except NlosError as exc:
        assert "\n" not in str(exc)
        return
    assert 1 <= room.burst_frames <= 1000 and 0 < room.exposure_s
    xy = room.room_xy(np.array([[0.0, 0.0], [1.0, -1.0]]))
    assert np.isfinite(xy).all()
    assert room.describe()


yaml_scalar = st.one_of(st.integers(-10**6, 10**6), st.floats(allow_nan=True, allow_infinity=True),
                        st.text(max_size=8), st.booleans(), st.none())
FIELDS = ["seed", "train_scenes", "val_scenes", "test_scenes", "samples_per_scene", "resolution", "los_vertices",
          "person_samples", "pixel_footprint", "families", "room", "base", "nope", "body_faces", "frame_rate_hz"]


@st.composite
def yaml_config(draw):
    if draw(st.integers(0, 4)) == 0:
        return draw(st.sampled_from(["a: &x [1, 2]\nb: *x\n", "[1, 2", "- 1\n- 2\n", "{", "base: tiny\n",
                                     "families: [nope]\n", "\t", ""]))
    lines = []
    for k in draw(st.lists(st.sampled_from(FIELDS), max_size=4, unique=True)):
        v = draw(st.one_of(yaml_scalar, st.lists(yaml_scalar, max_size=3)))
        lines.append(f"{k}: {json.dumps(v, allow_nan=True)}")
    return "\n".join(lines) + "\n"


@FUZZ
@given(yaml_config())
def test_dataset_config_reader(tmp_path, text):
    """A YAML config gives a valid ``DatasetConfig`` or one line (aliases, types, ranges)."""
    from nlos_spotlight.data.config import load_config, validate

    path = tmp_path / "c.yaml"
    path.write_text(text)
    try:
        cfg = load_config(str(path))
    except NlosError as exc:
        assert "\n" not in str(exc)
        return
    validate(cfg, "again")  # what loads is valid
    assert cfg.name == "c" and cfg.resolution >= 1


@st.composite
def checkpoint_bytes(draw):
    import io

    import torch

    kind = draw(st.sampled_from(["torch", "bytes", "truncated"]))
    if kind == "bytes":
        return draw(st.binary(max_size=200))
    obj = draw(st.sampled_from([
        {"ien": {}, "net": {}, "config": {}}, [1, 2], {"net": torch.zeros(2)}, 3.5,
        {"ien": {"w": torch.ones(1)}, "net": {"w": torch.ones(1)}, "config": {"model": "nope"}},
        {"opt": np.zeros(2)}, {"fn": np.sum}, {"cls": _a_class()}]))
    buf = io.BytesIO()
    torch.save(obj, buf)
    data = buf.getvalue()
    return data[:draw(st.integers(0, len(data)))] if kind == "truncated" else data


def _a_class():
    import collections

    return collections.OrderedDict  # a class: a global that safe loading must refuse


@FUZZ
@given(checkpoint_bytes())
def test_checkpoint_reader(tmp_path, data):
    """A checkpoint file loads to a dictionary of plain data, or one line (torn, foreign, or
    holding Python objects): nothing in it runs (issue 36, item 1)."""
    from nlos_spotlight.train.checkpoint import load_trained, read_checkpoint

    path = tmp_path / "final.pt"
    path.write_bytes(data)
    try:
        st_ = read_checkpoint(path)
        assert isinstance(st_, dict)
        load_trained(path)
    except NlosError as exc:
        assert "\n" not in str(exc)
