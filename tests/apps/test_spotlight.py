"""``nlos spotlight``: the IEN's choice by hand, reachability against geometry, aim angles, the
default camera, the three real scans end to end, and one-line CLI errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch


from nlos_spotlight.apps.spotlight import spotlight, visible_mesh  # noqa: E402
from nlos_spotlight.lighting.aim import aim_projector  # noqa: E402
from nlos_spotlight.lighting.learned import ien_logits  # noqa: E402
from nlos_spotlight.scene.setup import default_camera, load_setup  # noqa: E402
from nlos_spotlight.cli import main  # noqa: E402
from nlos_spotlight.errors import NlosError  # noqa: E402
from nlos_spotlight.render.rays import RayEngine  # noqa: E402
from nlos_spotlight.scene.builders import box, merge, quad  # noqa: E402
from nlos_spotlight.scene.format import Camera, TriMesh  # noqa: E402
from nlos_spotlight.scene.graph import mesh_to_graph, normalize_positions  # noqa: E402
from nlos_spotlight.scene.meshio import save_mesh  # noqa: E402
from nlos_spotlight.train.checkpoint import load_trained  # noqa: E402
from nlos_spotlight.train.config import TrainConfig  # noqa: E402
from nlos_spotlight.train.loop import Trainer  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[2] / "nlos_spotlight" / "assets" / "example_scene"


pytestmark = pytest.mark.usefixtures("one_thread")  # tiny networks: one torch thread (conftest.py)

@pytest.fixture(scope="module")
def ckpt(toy_scene, tmp_path_factory) -> Path:
    """An IEN with spread-out logits (random weights, scaled up) in a checkpoint with normals."""
    tr = Trainer(TrainConfig(), [toy_scene(n=8, res=8)], Path("unused"))
    # default init gives nearly equal logits (spread ~0.01); a wider init and a scaled last layer
    # give distinct probabilities, so the argmax and the ranking mean something
    with torch.no_grad():
        linears = [m for m in tr.ien.modules() if isinstance(m, torch.nn.Linear)]
        for m in linears:
            torch.nn.init.normal_(m.weight, 0.0, 2.0 / m.in_features ** 0.5)
            torch.nn.init.zeros_(m.bias)
        linears[-1].weight.mul_(100.0)
    path = tmp_path_factory.mktemp("run") / "final.pt"
    tr.save(path)
    return path


@pytest.fixture(scope="module")
def models(ckpt):
    return load_trained(ckpt)


def _fails(capsys, argv: list[str], match: str) -> None:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("error: ") and err.count("\n") == 1 and match in err, err


def _logits_by_hand(models, los: TriMesh, cam: Camera) -> np.ndarray:
    fwd = cam.look_at - cam.position
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, cam.up)
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    world_to_cam = np.eye(4)
    world_to_cam[:3, :3] = np.stack([right, up, -fwd])  # rows: camera axes (OpenGL: looking down -z)
    world_to_cam[:3, 3] = -world_to_cam[:3, :3] @ cam.position
    g = mesh_to_graph(los, frame=world_to_cam)
    x = torch.cat([normalize_positions(g.pos)[0], g.normals], dim=1)
    with torch.no_grad():
        return models.ien(x, g.edge_index, g.faces).double().numpy()


# ---------------------------------------------------------------- the choice

def test_scene_choice_is_the_argmax_of_the_ien_by_hand(models):
    setup = load_setup(EXAMPLE)
    r = spotlight(models, setup, target_vertices=300, top_k=7)
    assert setup.camera_source == "scene" and np.allclose(setup.projector, [-1.3, 3.2, 1.3])
    assert abs(len(r.los.vertices) - 300) <= 30
    logits = _logits_by_hand(models, r.los, setup.camera)
    np.testing.assert_allclose(r.logits, logits, rtol=1e-5, atol=1e-5)
    masked = np.where(r.reachable, logits, -np.inf)
    assert r.face == int(np.argmax(masked))
    expect = np.exp(masked - masked.max())
    np.testing.assert_allclose(r.probabilities, expect / expect.sum(), atol=1e-6)
    assert abs(r.probabilities.sum() - 1) < 1e-12 and np.all(r.probabilities[~r.reachable] == 0)
    assert [c.face for c in r.top] == list(np.argsort(-r.probabilities)[:7]) and r.top[0].face == r.face
    assert r.probabilities[r.face] > 3 * np.median(r.probabilities[r.reachable])  # logits spread out
    # the chosen face's normal faces the camera
    n = r.los.face_normals()[r.face]
    assert np.allclose(np.abs(r.normal), np.abs(n)) and r.normal @ (setup.camera.position - r.centroid) > 0
    # the aim: a unit vector from the projector through the centroid, and its angles
    d = r.aim.direction
    assert abs(np.linalg.norm(d) - 1) < 1e-12
    np.testing.assert_allclose(setup.projector + r.aim.distance_m * d, r.centroid, atol=1e-9)
    az, tilt = np.radians(r.aim.azimuth_deg), np.radians(r.aim.tilt_deg)
    np.testing.assert_allclose([np.cos(tilt) * np.cos(az), np.cos(tilt) * np.sin(az), np.sin(tilt)], d, atol=1e-12)
    heading = np.degrees(np.arctan2(*(setup.camera.look_at - setup.camera.position)[[1, 0]]))
    assert (r.aim.pan_deg - (r.aim.azimuth_deg - heading) + 180) % 360 == pytest.approx(180)
    assert r.aim.landing_offset_m < 1e-3  # undecimated example geometry: the beam lands on the centroid


def test_visible_mesh_holds_only_what_the_camera_sees():
    setup = load_setup(EXAMPLE)
    los = visible_mesh(setup, 10_000)  # no decimation: faces are original faces
    cam = setup.camera
    c = los.centroids()
    # every LOS face is in front of the camera and inside the field of view (a little slack for
    # faces that straddle the frame edge)
    fwd = (cam.look_at - cam.position) / np.linalg.norm(cam.look_at - cam.position)
    rel = c - cam.position
    depth = rel @ fwd
    assert np.all(depth > 0)
    cos = depth / np.linalg.norm(rel, axis=1)
    assert np.degrees(np.arccos(cos)).max() < cam.fov_deg / 2 * np.sqrt(2) + 15
    # the human mesh is not static geometry; the hidden side of the partition is not seen
    full = setup.mesh
    assert len(los.faces) < len(full.faces)


def test_occluded_faces_are_not_candidates(models, tmp_path):
    """A panel between the projector and the wall shadows part of it: those faces get probability 0,
    exactly the faces whose centroid the panel hides from the projector (analytic check)."""
    wall = quad([-2, 0, 0], [4, 0, 0], [0, 0, 2.5], 16, 10)  # y = 0
    panel = quad([0.0, 1.5, 0.8], [0.5, 0, 0], [0, 0, 0.5], 2, 2)  # y = 1.5, x 0..0.5, z 0.8..1.3
    path = tmp_path / "room.ply"
    save_mesh(merge(wall, panel), path)
    proj = np.array([1.5, 3.0, 1.3])
    setup = load_setup(path, camera_position=[-0.5, 4.0, 1.4], camera_look_at=[-0.3, 0.0, 1.0],
                       projector_position=proj, up="z")
    r = spotlight(models, setup, target_vertices=10_000)
    c = r.los.centroids()
    on_wall = np.abs(c[:, 1]) < 1e-9
    # where the segment projector -> centroid crosses y = 1.5
    s = (proj[1] - 1.5) / (proj[1] - c[:, 1])
    cross = proj + s[:, None] * (c - proj)
    hidden = on_wall & (cross[:, 0] > 0) & (cross[:, 0] < 0.5) & (cross[:, 2] > 0.8) & (cross[:, 2] < 1.3)
    assert hidden.sum() >= 8 and (on_wall & ~hidden).sum() > 100
    np.testing.assert_array_equal(r.reachable[on_wall], ~hidden[on_wall])
    assert np.all(r.reachable[~on_wall])  # the panel's own faces, lit on the camera's side
    assert np.all(r.probabilities[hidden] == 0) and r.reachable[r.face]
    assert setup.camera_source == "flags" and setup.projector_source == "flags"


def test_aim_angle_conventions():
    cam = Camera(np.zeros(3), np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]), 60.0, 8, 8)  # looks +y
    p = np.array([1.0, 2.0, 1.0])
    right = aim_projector(p, p + [3.0, 0.0, 0.0], cam)  # toward +x: the camera's right
    assert right.azimuth_deg == pytest.approx(0) and right.pan_deg == pytest.approx(-90)
    assert right.tilt_deg == pytest.approx(0) and right.distance_m == pytest.approx(3)
    left_down = aim_projector(p, p + [-1.0, 1.0, -np.sqrt(2)], cam)
    assert left_down.pan_deg == pytest.approx(45) and left_down.tilt_deg == pytest.approx(-45)
    assert left_down.azimuth_deg == pytest.approx(135)
    behind = aim_projector(p, p + [-0.001, -1.0, 0.0], cam)  # wraps to (-180, 180]
    assert 179.9 < behind.pan_deg <= 180
    assert aim_projector(p, p + [0.0, 0.0, 2.0], cam).tilt_deg == pytest.approx(90)


def test_default_camera_stands_in_the_room_and_looks_down_its_length():
    room = box([0.0, 0.0, 0.0], [6.0, 4.0, 2.5])
    engine = RayEngine(room.vertices, room.faces)
    cam = default_camera(room, engine)
    assert 0 < cam.position[0] < 6 and 0 < cam.position[1] < 4 and cam.position[2] == pytest.approx(1.5)
    fwd = cam.look_at - cam.position
    assert abs(fwd[0]) > 5 * abs(fwd[1])  # along the 6 m axis: the longest view
    assert cam.look_at[2] == pytest.approx(1.0) and cam.fov_deg == 60


# ---------------------------------------------------------------- real scans, CLI

@pytest.mark.parametrize("name", ["copyroom.ply", "icl_livingroom2.obj", "icl_office2.obj"])
def test_real_scans_end_to_end(ckpt, tmp_path, capsys, name, real_scan):
    out = tmp_path / "spot.json"
    argv = ["spotlight", str(real_scan(name)), "--checkpoint", str(ckpt), "--json", str(out), "--target-vertices", "400",
            "--top-k", "4"]
    if name == "copyroom.ply":
        argv += ["--png", str(tmp_path / "spot.png")]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "default derived from the mesh bounds" in printed and "pan" in printed and "tilt" in printed
    r = json.loads(out.read_text())
    v = np.array(r["los_mesh"]["vertices"])
    assert abs(len(v) - 400) <= 40  # decimated
    # the default camera stands inside the room, clear of furniture, at eye height, sees the LOS mesh
    setup = load_setup(real_scan(name))
    cam = np.array(r["camera"]["position"])
    assert r["camera"]["source"] == "default" and np.allclose(cam, setup.camera.position)
    w = setup.mesh.vertices
    floor = np.quantile(w[:, 2], 0.005)
    assert np.all(cam > w.min(0)) and np.all(cam < w.max(0)) and 1.3 < cam[2] - floor < 1.51  # eye height
    assert v[:, 2].min() > floor - 0.1 and v[:, 2].max() - floor > 1.5  # z up: the LOS mesh spans floor to wall
    sphere = np.random.default_rng(0).normal(size=(500, 3))
    sphere /= np.linalg.norm(sphere, axis=1, keepdims=True)
    around = setup.engine.first_hit(np.broadcast_to(cam, sphere.shape), sphere)
    assert around.hit.mean() > 0.6 and around.t[around.hit].min() > 0.25  # scans have holes; clear of objects
    m = np.array(r["file_to_world"])
    assert np.allclose(m[:3, :3] @ m[:3, :3].T, np.eye(3)) and np.allclose(m[:3, 3], 0)
    np.testing.assert_allclose(m[:3, :3] @ r["chosen"]["centroid_in_file"], r["chosen"]["centroid"], atol=1e-9)
    probs = np.array(r["probabilities"])
    assert abs(probs.sum() - 1) < 1e-9 and r["chosen"]["face"] == int(np.argmax(probs))
    assert [t["face"] for t in r["top_k"]] == list(np.argsort(-probs)[:4])
    face = np.array(r["los_mesh"]["faces"])[r["chosen"]["face"]]
    np.testing.assert_allclose(v[face].mean(0), r["chosen"]["centroid"], atol=1e-9)
    d = np.array(r["chosen"]["centroid"]) - np.array(r["projector"]["position"])
    np.testing.assert_allclose(r["aim"]["direction"], d / np.linalg.norm(d), atol=1e-9)
    assert r["aim"]["landing_offset_m"] < 0.1 + 0.02 * np.linalg.norm(d)
    if name == "copyroom.ply":
        assert (tmp_path / "spot.png").stat().st_size > 20_000


def test_flags_override_the_camera_and_projector(ckpt, tmp_path, real_scan):
    out = tmp_path / "spot.json"
    argv = ["spotlight", str(real_scan("icl_office2.obj")), "--checkpoint", str(ckpt), "--json", str(out),
            "--target-vertices", "300", "--camera-position", "-2.5,-0.6,0.0", "--camera-look-at", "1.7,-0.6,-0.5",
            "--projector-position", "-2.5,-0.9,-0.2"]  # values starting with '-': glued to their flags
    assert main(argv) == 0
    r = json.loads(out.read_text())
    assert r["camera"]["source"] == "flags" and r["camera"]["position"] == [-2.5, -0.6, 0.0]
    assert r["camera"]["look_at"] == [1.7, -0.6, -0.5]
    assert r["projector"] == {"position": [-2.5, -0.9, -0.2], "source": "flags"}


def test_cli_errors_exit_2_with_one_line(ckpt, tmp_path, capsys, monkeypatch):
    (tmp_path / "bad.pt").write_bytes(b"garbage")
    (tmp_path / "notes.txt").write_text("hello")
    st = torch.load(ckpt, weights_only=False)
    st["config"]["policy"] = "random"
    torch.save(st, tmp_path / "fixed.pt")
    c, ex = str(ckpt), str(EXAMPLE)
    _fails(capsys, ["spotlight", str(tmp_path / "missing.ply"), "--checkpoint", c], "no such scene directory")
    _fails(capsys, ["spotlight", str(tmp_path / "notes.txt"), "--checkpoint", c], "expected a scene directory")
    _fails(capsys, ["spotlight", ex, "--checkpoint", str(tmp_path / "bad.pt")], "corrupted or not a checkpoint")
    monkeypatch.delenv("NLOS_CHECKPOINT", raising=False)
    _fails(capsys, ["spotlight", ex], "no trained run")
    _fails(capsys, ["spotlight", ex, "--checkpoint", str(tmp_path / "fixed.pt")], "fixed 'random' spot policy")
    _fails(capsys, ["spotlight", ex, "--checkpoint", c, "--camera-position", "-1,3,1.5"], "go together")
    _fails(capsys, ["spotlight", ex, "--checkpoint", c, "--camera-position", "1,2",
                    "--camera-look-at", "0,0,1"], "--camera-position: expected three")
    _fails(capsys, ["spotlight", ex, "--checkpoint", c, "--projector-position", "a,b,c"], "--projector-position")
    _fails(capsys, ["spotlight", ex, "--checkpoint", c, "--top-k", "0"], "--top-k")
    _fails(capsys, ["spotlight", ex, "--checkpoint", c, "--up", "z"], "--up applies to a bare mesh")
    _fails(capsys, ["spotlight", str(EXAMPLE / "relay_wall.ply"), "--checkpoint", c, "--up", "w"], "--up: unknown")
    _fails(capsys, ["spotlight", ex, "--checkpoint", c, "--camera-position", "0,9,1",
                    "--camera-look-at", "0,20,1"], "sees no face")
    _fails(capsys, ["spotlight", ex, "--checkpoint", c, "--projector-position", "-0.2,-0.5,1.0"], "reaches none")


def test_an_ien_trained_with_region_and_prior_reads_a_room_as_its_training_did(micro_scene, tmp_path):
    """One path from a mesh to the IEN's logits: for an IEN trained with the hidden region's frame,
    the Adaptive Lighting feature and a face prior, ``ien_logits`` on the stored room's candidates
    equals the trainer's logits on the same room (issue 37: it failed on a shape mismatch before);
    a bare mesh gets one line naming what is missing."""
    from nlos_spotlight.data.static import read_static
    from nlos_spotlight.data.tensors import load_scene_tensors
    from nlos_spotlight.models.ien import IENConfig
    from nlos_spotlight.scene.io import load_scene

    scene_dir, _ = micro_scene
    feats = ["normals", "region", "adaptive"]
    s = load_scene_tensors(scene_dir, feats)
    cfg = TrainConfig(ien_features=feats, ien=IENConfig(in_features=s.x.shape[1], prior_weight=0.5))
    tr = Trainer(cfg, [s], tmp_path)
    with torch.no_grad():
        want = tr.ien_logits([s])[0].double().numpy()
    tr.save(tmp_path / "final.pt")
    models = load_trained(tmp_path / "final.pt")
    st = read_static(scene_dir, "los_vertices", "los_faces", "aim_points")
    los = TriMesh(st["los_vertices"], st["los_faces"])
    np.testing.assert_allclose(st["aim_points"], los.centroids(), atol=1e-9)  # the prior's aim: the centroid
    scene = load_scene(scene_dir)
    got = ien_logits(models, los, scene.camera, scene).double().numpy()
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)
    with pytest.raises(NlosError, match="reads region, adaptive, a face prior of the hidden region"):
        ien_logits(models, los, scene.camera)
