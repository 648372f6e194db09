"""Scene directories: round trip, and a one-line error for every class of bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from nlos_spotlight.errors import NlosError
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene import load_scene, save_scene
from nlos_spotlight.scene.examples import corner_scene

FAST = RenderSettings(pixel_samples=1, transport_pixel_samples=1, spot_samples=8, person_samples=16)


@pytest.fixture
def scene_dir(tmp_path) -> Path:
    d = tmp_path / "scene"
    save_scene(corner_scene("example", resolution=8), d)
    return d


def _edit(d: Path, fn) -> None:
    js = json.loads((d / "scene.json").read_text())
    fn(js)
    (d / "scene.json").write_text(json.dumps(js))


def test_round_trip(scene_dir):
    a = corner_scene("example", resolution=8)
    b = load_scene(scene_dir)
    assert [s.mesh_file for s in a.shapes] == [s.mesh_file for s in b.shapes]
    for sa, sb in zip(a.shapes, b.shapes):
        assert np.allclose(sa.mesh.vertices, sb.mesh.vertices) and np.array_equal(sa.mesh.faces, sb.mesh.faces)
    wall = b.shapes[0].mesh
    assert wall.vertex_colors is not None and np.allclose(wall.vertex_colors, a.shapes[0].mesh.vertex_colors,
                                                          atol=1 / 255)
    assert np.allclose(b.materials["steel"].specular, 0.6) and b.materials["monitor"].emission[2] == 0.8
    assert b.human is not None and np.allclose(b.human.albedo, [0.6, 0.5, 0.4])


def _expect(d: Path, pattern: str) -> None:
    with pytest.raises(NlosError, match=pattern) as info:
        Renderer(load_scene(d), FAST)
    assert "\n" not in str(info.value)


def test_missing_directory(tmp_path):
    with pytest.raises(NlosError, match="not found"):
        load_scene(tmp_path / "nope")


def test_missing_mesh_file(scene_dir):
    (scene_dir / "floor.ply").unlink()
    _expect(scene_dir, r"shapes\[1\].*floor.ply.*not found")


def test_unreadable_mesh(scene_dir):
    (scene_dir / "floor.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 9\nend_header\n\x00")
    _expect(scene_dir, r"floor.ply")


def test_bad_json(scene_dir):
    (scene_dir / "scene.json").write_text('{"format": "nlos-scene/1", ')
    _expect(scene_dir, "invalid JSON")


def test_wrong_format_version(scene_dir):
    _edit(scene_dir, lambda js: js.update(format="nlos-scene/2"))
    _expect(scene_dir, "format.*nlos-scene/2")


@pytest.mark.parametrize("where", ["top", "camera", "material", "shape"])
def test_unknown_key(scene_dir, where):
    def add(js):
        {"top": js, "camera": js["camera"], "material": js["materials"]["paint"],
         "shape": js["shapes"][0]}[where]["colour"] = 1
    _edit(scene_dir, add)
    _expect(scene_dir, "unknown key 'colour'")


def test_nan_vertex(scene_dir):
    from nlos_spotlight.scene.meshio import save_mesh
    from nlos_spotlight.scene.builders import quad

    m = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])
    m.vertices[2, 1] = np.nan
    save_mesh(m, scene_dir / "floor.ply")
    _expect(scene_dir, "floor.ply.*vertex 2.*non-finite")


def test_nan_in_json(scene_dir):
    (scene_dir / "scene.json").write_text((scene_dir / "scene.json").read_text().replace('"fov_deg": 50.0',
                                                                                         '"fov_deg": NaN'))
    _expect(scene_dir, "camera.fov_deg")


def test_empty_mesh(scene_dir):
    (scene_dir / "floor.ply").write_text("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                                         "property float y\nproperty float z\nelement face 0\n"
                                         "property list uchar int vertex_indices\nend_header\n")
    _expect(scene_dir, "floor.ply")


@pytest.mark.parametrize("value", [[1.2, 0.5, 0.5], [-0.1, 0.5, 0.5]])
def test_albedo_outside_unit_interval(scene_dir, value):
    _edit(scene_dir, lambda js: js["materials"]["paint"].update(diffuse=value))
    _expect(scene_dir, r"materials.paint.diffuse.*outside \[0.0, 1.0\]")


def test_human_albedo_outside_unit_interval(scene_dir):
    _edit(scene_dir, lambda js: js["human"].update(albedo=[0.5, 2, 0.5]))
    _expect(scene_dir, "human.albedo")


def test_camera_sees_no_geometry(scene_dir):
    _edit(scene_dir, lambda js: js["camera"].update(look_at=[-1.6, 10.0, 1.5]))
    _expect(scene_dir, "camera: sees no geometry")


def test_projector_aimed_at_nothing(scene_dir):
    scene = load_scene(scene_dir)
    r = Renderer(scene, FAST, aim_points=np.array([[-1.3, 10.0, 1.3], [-0.3, 0.0, 1.0]]))
    assert not r.spot_landed[0] and r.spot_landed[1]
    with pytest.raises(NlosError, match="projector: aimed at nothing"):
        Renderer(scene, FAST, aim_points=np.array([[-1.3, 10.0, 1.3]]))


def test_unknown_material_reference(scene_dir):
    _edit(scene_dir, lambda js: js["shapes"][0].update(material="marble"))
    _expect(scene_dir, "unknown material 'marble'")


def test_obj_with_missing_mtl_loads(tmp_path):
    from nlos_spotlight.scene.meshio import load_mesh

    p = tmp_path / "m.obj"
    p.write_text("mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl wood\nf 1 2 3\n")
    m = load_mesh(p)
    assert m.faces.shape == (1, 3)


def test_cli_reports_one_line_and_nonzero(scene_dir, tmp_path):
    _edit(scene_dir, lambda js: js.update(format="nlos-scene/9"))
    res = subprocess.run([sys.executable, "-m", "nlos_spotlight.cli", "render", str(scene_dir), "--spot-face", "0",
                          "--out", str(tmp_path / "x.npy")], capture_output=True, text=True)
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1 and res.stderr.startswith("error: ") and "Traceback" not in res.stderr


@pytest.mark.parametrize("name,why", [("ABS", "absolute path"), ("../outside/wall.ply", "leaves the scene directory"),
                                      ("link/wall.ply", "leaves the scene directory")])
def test_mesh_names_stay_inside_the_scene(scene_dir, tmp_path, name, why):
    """A shared scene must not make reading or rewriting it touch a file elsewhere (issue 36)."""
    elsewhere = tmp_path / "outside"
    elsewhere.mkdir()
    (scene_dir / "relay_wall.ply").rename(elsewhere / "wall.ply")
    (scene_dir / "link").symlink_to(elsewhere)
    name = str(elsewhere / "wall.ply") if name == "ABS" else name
    before = (elsewhere / "wall.ply").read_bytes()
    _edit(scene_dir, lambda js: js["shapes"][0].update(mesh=name))
    with pytest.raises(NlosError, match=why) as info:
        load_scene(scene_dir)
    assert "\n" not in str(info.value) and (elsewhere / "wall.ply").read_bytes() == before


def test_save_scene_refuses_a_name_outside_before_writing(tmp_path):
    scene = corner_scene("example", resolution=8)
    scene.shapes[0].mesh_file = "../escaped.ply"
    with pytest.raises(NlosError, match="leaves the scene directory"):
        save_scene(scene, tmp_path / "out" / "scene")
    assert not (tmp_path / "escaped.ply").exists() and not (tmp_path / "out").exists()


def test_mesh_names_in_subdirectories_still_load(scene_dir):
    (scene_dir / "meshes").mkdir()
    (scene_dir / "relay_wall.ply").rename(scene_dir / "meshes" / "wall.ply")
    _edit(scene_dir, lambda js: js["shapes"][0].update(mesh="meshes/wall.ply"))
    assert load_scene(scene_dir).shapes[0].mesh_file == "meshes/wall.ply"
