"""Errors that name the real problem (issue 36, item 10): each input below used to get a message
blaming something else."""

from __future__ import annotations

import numpy as np
import pytest

from nlos_spotlight.cli import main
from nlos_spotlight.scene.examples import corner_scene
from nlos_spotlight.scene.format import TriMesh
from nlos_spotlight.scene.meshio import save_mesh


def _fails(capsys, argv, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("error:") and "Traceback" not in err, err
    for w in words:
        assert w in err, err


@pytest.fixture(scope="module")
def room_ply(tmp_path_factory):
    """The example scene's static geometry as a bare scan (meters): x -1.5..3, y -1..4, z 0..2.5."""
    sc = corner_scene("example", resolution=16)
    d = tmp_path_factory.mktemp("scan")
    save_mesh(sc.static_mesh()[0], d / "room.ply")
    return d / "room.ply", sc


def test_point_cloud_is_named(tmp_path, capsys):
    ply = tmp_path / "cloud.ply"
    ply.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                   "end_header\n1 0 0\n0 1 0\n0 0 1\n")
    _fails(capsys, ["fit", str(ply), "--out", str(tmp_path / "m"), "--preset", "tiny", "--quiet"],
           "point cloud (3 points, no triangles)")


@pytest.mark.parametrize("scale,unit", [(1000.0, "millimetres"), (100.0, "centimetres")])
def test_scan_in_other_units_is_named(room_ply, tmp_path, capsys, scale, unit):
    m = room_ply[1].static_mesh()[0]
    save_mesh(TriMesh(m.vertices * scale, m.faces), tmp_path / "scan.ply")
    _fails(capsys, ["fit", str(tmp_path / "scan.ply"), "--out", str(tmp_path / "m"), "--preset", "tiny", "--quiet"],
           "expected meters", unit)
    assert not (tmp_path / "m").exists()


def test_camera_outside_the_room_is_blamed_not_the_region(room_ply, tmp_path, capsys):
    ply, sc = room_ply
    hi = sc.static_mesh()[0].vertices.max(0)
    outside = f"{hi[0] + 1.0},{hi[1] / 2},1.0"
    _fails(capsys, ["fit", str(ply), "--out", str(tmp_path / "m"), "--preset", "tiny", "--quiet",
                    "--camera-position", outside, "--camera-look-at", "0,1,1"], "outside the scanned room",
           "--camera-position")


def test_camera_that_sees_nothing_is_blamed(tmp_path, capsys):
    """A floor and one wall: a camera above them looking up sees none of it."""
    v = np.array([[-3, -3, 0], [3, -3, 0], [3, 3, 0], [-3, 3, 0], [3, -3, 2.5], [3, 3, 2.5]], np.float64)
    f = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]])
    save_mesh(TriMesh(v, f), tmp_path / "floor.ply")
    _fails(capsys, ["fit", str(tmp_path / "floor.ply"), "--out", str(tmp_path / "m"), "--preset", "tiny", "--quiet",
                    "--camera-position", "0,0,1", "--camera-look-at", "-1,0,2.5", "--up", "z"], "sees none of the scan")


def test_unwritable_out_is_refused_before_the_work(room_ply, tmp_path, capsys):
    """Root may pass permission bits where the file system refuses (/proc): the probe says so at once."""
    _fails(capsys, ["fit", str(room_ply[0]), "--out", "/proc/nlos-x", "--preset", "tiny", "--quiet"],
           "--out: cannot create /proc/nlos-x")
    _fails(capsys, ["generate", "tiny", "--out", "/proc/nlos-x", "--quiet"], "--out: cannot create /proc/nlos-x")


def test_verify_says_what_a_directory_is(tmp_path, capsys):
    _fails(capsys, ["verify", str(tmp_path)], "not a dataset")
    (tmp_path / "config.json").write_text("{}")
    _fails(capsys, ["verify", str(tmp_path)], "unfinished", "rerun")


def test_a_scan_at_1e200_gets_one_line_and_no_warning(tmp_path, capsys):
    """Item 9: no numpy RuntimeWarning (overflow in the scan's arithmetic) before the error."""
    import warnings

    v = np.array([[1e200, 0, 0], [0, 1, 0], [0, 0, 1]])
    (tmp_path / "big.ply").write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                                      "property double z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                      "end_header\n" + "\n".join(" ".join(map(str, p)) for p in v) + "\n3 0 1 2\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _fails(capsys, ["fit", str(tmp_path / "big.ply"), "--out", str(tmp_path / "m"), "--preset", "tiny",
                        "--quiet"], "expected meters")


def test_ctrl_c_is_one_line_with_the_resume_hint(monkeypatch, capsys):
    """Item 5: Ctrl-C during a long command exits 130 with one line, not a traceback."""
    import nlos_spotlight.fit.run as run

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(run, "fit_room", interrupted)
    assert main(["fit", "scan.ply", "--out", "/tmp/nlos-never-written", "--preset", "tiny", "--quiet"]) == 130
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "interrupted" in err and "--resume" in err, err


def test_an_image_past_the_pixel_limit_is_named(tmp_path):
    """Item 5: an 8-bit PNG past PIL's pixel limit (a decompression bomb) is one line naming it."""
    import struct
    import zlib

    from nlos_spotlight.apps.images import load_frames
    from nlos_spotlight.errors import NlosError

    def chunk(kind, payload):
        return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 60_000, 60_000, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b""))
    (tmp_path / "bomb.png").write_bytes(png)
    with pytest.raises(NlosError, match="too large"):
        load_frames([str(tmp_path / "bomb.png")], (4, 4), False)


def test_device_cuda_without_a_gpu_is_one_line(tmp_path, capsys):
    import torch

    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.render.settings import resolve_device

    assert resolve_device("cpu") == "cpu"
    assert resolve_device("auto") == ("cuda" if torch.cuda.is_available() else "cpu")
    with pytest.raises(NlosError, match="--device"):
        resolve_device("tpu")
    if torch.cuda.is_available():
        pytest.skip("this machine has a GPU: --device cuda is valid here")
    _fails(capsys, ["generate", "tiny", "--out", str(tmp_path / "d"), "--device", "cuda", "--quiet"],
           "--device cuda", "no CUDA GPU")
    assert not (tmp_path / "d" / "scenes").exists()  # refused before any scene was written
