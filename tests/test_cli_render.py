"""``nlos render`` on a scene directory written by hand from DESIGN section 3 alone."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import numpy as np

DESIGN_JSON = {
    "format": "nlos-scene/1",
    "units": "meters",
    "shapes": [{"mesh": "wall.ply", "material": "paint"},
               {"mesh": "fridge.ply", "material": "steel"}],
    "materials": {
        "paint": {"diffuse": [0.7, 0.7, 0.7]},
        "steel": {"diffuse": [0.05, 0.05, 0.05], "specular": [0.6, 0.6, 0.6], "roughness": 0.2},
        "monitor": {"diffuse": [0.02, 0.02, 0.02], "emission": [0.5, 0.6, 0.8]}},
    "camera": {"position": [-1.6, 3.2, 1.5], "look_at": [0, 0, 1.1], "up": [0, 0, 1],
               "fov_deg": 50.0, "width": 64, "height": 64},
    "projector": {"position": [-1.3, 3.2, 1.3], "intensity": [50, 50, 50],
                  "beam_width_deg": 3.0, "cutoff_deg": 5.0},
    "ambient": {"radiance": [0.02, 0.02, 0.02], "hidden_radiance": [0.02, 0.02, 0.02]},
    "hidden_region": {"min": [0.2, 0.7], "max": [2.5, 3.5], "floor_z": 0.0},
    "human": {"mesh": "human.ply", "albedo": [0.6, 0.5, 0.4]},
}

# A wall in the plane y = 0 (facing the camera), a floor, as one ASCII PLY with four quads' worth of triangles.
WALL_PLY = """ply
format ascii 1.0
element vertex 8
property float x
property float y
property float z
element face 4
property list uchar int vertex_indices
end_header
-3 0 0
3 0 0
3 0 3
-3 0 3
-3 0 0
3 0 0
3 4 0
-3 4 0
3 0 1 2
3 0 2 3
3 4 5 6
3 4 6 7
"""


def _box_ply(lo, hi) -> str:
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    v = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0), (x0, y0, z1), (x1, y0, z1), (x1, y1, z1),
         (x0, y1, z1)]
    f = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4), (1, 2, 6), (1, 6, 5), (2, 3, 7),
         (2, 7, 6), (3, 0, 4), (3, 4, 7)]
    head = ("ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 12\nproperty list uchar int vertex_indices\nend_header\n")
    return head + "".join(f"{a} {b} {c}\n" for a, b, c in v) + "".join(f"3 {a} {b} {c}\n" for a, b, c in f)


def test_render_hand_written_scene(tmp_path):
    d = tmp_path / "hand"
    d.mkdir()
    (d / "scene.json").write_text(json.dumps(DESIGN_JSON))
    (d / "wall.ply").write_text(WALL_PLY)
    (d / "fridge.ply").write_text(_box_ply((-2.4, 0.0, 0.0), (-1.8, 0.7, 1.8)))
    # a person-sized box in the hidden region (x > 0.2), hidden from camera and projector by nothing but
    # distance here: the point is the file format and the command, the physics is tested elsewhere
    (d / "human.ply").write_text(_box_ply((1.0, 1.3, 0.0), (1.4, 1.6, 1.75)))
    def render(name, *extra, process=False):
        args = ["render", str(d), "--spot-point", "-0.3,0,1.0", "--out", str(tmp_path / name),
                "--person-samples", "256", "--spot-samples", "64", "--transport-samples", "1", *extra]
        if process:  # the console command as a user runs it
            res = subprocess.run([sys.executable, "-m", "nlos_spotlight.cli", *args], capture_output=True, text=True)
            assert res.returncode == 0, res.stderr
        else:  # the same entry point in this process (a new process costs ~3 s of imports)
            from nlos_spotlight.cli import main

            assert main(args) == 0
        return np.load(tmp_path / name)

    img = render("img.npy", process=True)
    assert img.dtype == np.float32 and img.shape == (64, 64, 3) and np.isfinite(img).all()
    n = render("nlos.npy", "--components", "nlos")
    assert n.sum() > 0 and n.max() < img.max() * 1e-2  # the hidden signal is weak but present
    # the spot is the brightest thing; it projects near the image position of the aim point
    from nlos_spotlight.render.camera import project
    from nlos_spotlight.scene import load_scene

    row, col = project(load_scene(d).camera, np.array([[-0.3, 0.0, 1.0]]))[0]
    peak = np.unravel_index(np.argmax(img.sum(-1)), img.shape[:2])
    assert abs(peak[0] - row) < 3 and abs(peak[1] - col) < 3
    # the captures without the person's shadow and bounce (most of a render's time; under 1e-3 of the light)
    fast = ("--noise", "sensor", "--seed", "3", "--components", "direct,interreflection,ambient,nlos,nlos_ambient")
    z = render("noisy.npy", *fast)
    assert np.array_equal(z, render("noisy2.npy", *fast))
    # average metering lets the spot clip: clipped values read the clip level, the rest match
    clip = z.max()
    assert (z == clip).any() and img.max() > clip
    assert z.shape == (64, 64, 3) and not np.allclose(z, img) and abs(z.sum() / np.minimum(img, clip).sum() - 1) < 0.05


def test_bad_paths_and_values_name_themselves(tmp_path, capsys, monkeypatch):
    """Bad output paths and sample counts: one line naming the path or flag, exit 2, nothing left
    behind; NLOS_DEBUG=1 shows the traceback instead."""
    import pytest

    from nlos_spotlight.cli import main
    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene
    from nlos_spotlight.scene.io import save_scene

    scene = tmp_path / "scene"
    save_scene(corner_scene("diffuse_corner", resolution=4), scene)
    aim = ",".join(str(v) for v in SPOT_TARGET)
    (tmp_path / "a_dir.npy").mkdir()
    (tmp_path / "file").write_text("x")
    base = ["render", str(scene), "--spot-point", aim, "--person-samples", "8", "--spot-samples", "4"]
    cases = [(["--out", str(tmp_path / "a_dir.npy")], "is a directory"),
             (["--out", str(tmp_path / "file" / "x.npy")], "which is a file"),
             (["--out", str(tmp_path / "x.npy"), "--pixel-samples", "0"], "--pixel-samples"),
             (["--out", str(tmp_path / "x.npy"), "--spot-samples", "-3"], "--spot-samples"),
             (["--out", str(tmp_path / "x.npy"), "--seed", "-1"], "--seed"),  # issue 36 item 16: before rendering
             (["--out", str(tmp_path / "x.npy"), "--burst", "0", "--noise", "sensor"], "--burst"),
             (["--out", str(tmp_path / "x.npy"), "--burst", "4"], "--noise sensor"),
             (["--out", "/proc/x.npy"], "/proc/x.npy")]  # probed: permission bits let root through
    for extra, words in cases:
        assert main(base + extra) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("error:") and "\n" not in err and words in err, err
    proj = ",".join(str(v) for v in corner_scene("diffuse_corner").projector.position)
    assert main(["render", str(scene), "--spot-point", proj, "--out", str(tmp_path / "y.npy")]) == 2
    assert "projector's own position" in capsys.readouterr().err
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning before the error (issue 36, item 9)
        assert main(["render", str(scene), "--spot-point", "1e308,0,0", "--out", str(tmp_path / "y.npy")]) == 2
    assert "beyond 1e+06 m" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_dir.npy", "file", "scene"]
    monkeypatch.setenv("NLOS_DEBUG", "1")
    with pytest.raises(NlosError):
        main(base + ["--out", str(tmp_path / "a_dir.npy")])


def test_argparse_errors_are_one_line(capsys):
    """A bad choice or number is one line, as every other error (issue 36, item 17)."""
    import pytest

    from nlos_spotlight.cli import main

    for argv, words in ((["fit", "x", "--out", "y", "--people", "abc"], "--people"),
                        (["predict", "x", "--backend", "tensorrt"], "tensorrt"), (["nope"], "nope")):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        err = capsys.readouterr().err.strip()
        assert exc.value.code == 2 and err.startswith("error:") and "\n" not in err and words in err, err


def test_render_preset_sets_the_sample_counts(tmp_path):
    """``--preset fast`` is the fast settings' counts (flags still override them)."""
    from nlos_spotlight.cli import main
    from nlos_spotlight.demo import bundled_scene
    from nlos_spotlight.render.settings import RENDER_PRESETS

    from nlos_spotlight.scene.examples import SPOT_TARGET

    fast = RENDER_PRESETS["fast"]
    args = ["render", str(bundled_scene()), "--spot-point", ",".join(map(str, SPOT_TARGET)), "--components", "nlos"]
    assert main([*args, "--preset", "fast", "--out", str(tmp_path / "a.npy")]) == 0
    explicit = ["--pixel-samples", str(fast.pixel_samples), "--transport-samples", str(fast.transport_pixel_samples),
                "--person-samples", str(fast.person_samples), "--spot-samples", str(fast.spot_samples)]
    assert main([*args, *explicit, "--out", str(tmp_path / "b.npy")]) == 0
    assert main([*args, "--preset", "fast", "--person-samples", "64", "--out", str(tmp_path / "c.npy")]) == 0
    a, b, c = (np.load(tmp_path / f"{k}.npy") for k in "abc")
    assert a.sum() > 0 and np.array_equal(a, b) and not np.allclose(a, c)
