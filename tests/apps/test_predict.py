"""``nlos predict``: the same numbers as the network run by hand, image decoding (sRGB, 16-bit PNG),
area resampling, sequences and video, smoothing in the outputs, and one-line errors."""

from __future__ import annotations

import csv
import json
import re
import struct
import sys
import types
import zlib
from pathlib import Path

import numpy as np
import pytest
import torch
from PIL import Image


from nlos_spotlight.apps.images import (Frames, area_resize, expand_inputs, load_frames,  # noqa: E402
                                        read_image, read_png16)
from nlos_spotlight.render.color import srgb_to_linear  # noqa: E402
from nlos_spotlight.apps.predict import predict  # noqa: E402
from nlos_spotlight.cli import main  # noqa: E402
from nlos_spotlight.errors import NlosError  # noqa: E402
from nlos_spotlight.evaluate.tracking import default_window, smooth_trajectory  # noqa: E402
from nlos_spotlight.models.nlos_net import NLOSNetConfig  # noqa: E402
from nlos_spotlight.train.checkpoint import load_trained  # noqa: E402
from nlos_spotlight.train.config import TrainConfig  # noqa: E402
from nlos_spotlight.train.loop import Trainer  # noqa: E402
from nlos_spotlight.world.body import POSTURES  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_thread")  # tiny networks: one torch thread (conftest.py)

RES = 8  # the toy scene's image size: checkpoints expect (8, 8, 3)


def _checkpoint(toy_scene, path: Path, **cfg) -> Path:
    tr = Trainer(TrainConfig(**cfg), [toy_scene(n=8, res=RES)], path.parent)
    with torch.no_grad():  # a non-trivial position standardization, as after real training
        tr.net.position_mean.copy_(torch.tensor([2.0, -0.5]))
        tr.net.position_std.copy_(torch.tensor([0.7, 1.3]))
    tr.save(path)
    return path


@pytest.fixture(scope="module")
def ckpt(toy_scene, tmp_path_factory) -> Path:
    return _checkpoint(toy_scene, tmp_path_factory.mktemp("run") / "final.pt")


@pytest.fixture(scope="module")
def models(ckpt):
    return load_trained(ckpt)


def _by_hand(models, images: np.ndarray, **kw) -> tuple[np.ndarray, np.ndarray]:
    with torch.no_grad():
        pos, logits = models.net(torch.as_tensor(images, dtype=torch.float32), **kw)
    return pos.double().numpy(), torch.softmax(logits.double(), 1).numpy()


def _fails(capsys, argv: list[str], match: str) -> None:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("error: ") and err.count("\n") == 1 and match in err, err


# ---------------------------------------------------------------- numbers

def test_npy_frame_equals_the_network_by_hand(ckpt, models, tmp_path, capsys):
    img = np.random.default_rng(0).uniform(0.0, 2.0, (RES, RES, 3))
    np.save(tmp_path / "photo.npy", img)
    assert main(["predict", str(ckpt), str(tmp_path / "photo.npy"), "--json", str(tmp_path / "o.json")]) == 0
    out = json.loads((tmp_path / "o.json").read_text())
    assert "photo.npy" in capsys.readouterr().out
    xy, probs = _by_hand(models, img[None])
    f = out["frames"][0]
    np.testing.assert_allclose([f["x_m"], f["y_m"]], xy[0], atol=1e-6)
    np.testing.assert_allclose([f["probabilities"][p] for p in POSTURES], probs[0], atol=1e-7)
    assert f["posture"] == POSTURES[int(probs[0].argmax())]
    assert abs(sum(f["probabilities"].values()) - 1) < 1e-9
    assert out["smoothing"] is None and out["image_shape"] == [RES, RES] and out["postures"] == list(POSTURES)


def test_stack_gets_smoothed_trajectory_csv_json_plot(ckpt, models, tmp_path):
    rng = np.random.default_rng(1)
    n = 12
    stack = rng.uniform(0.5, 1.5, (n, RES, RES, 3)) * np.linspace(0.5, 2.0, n)[:, None, None, None]
    np.save(tmp_path / "walk.npy", stack.astype(np.float32))
    argv = ["predict", str(ckpt), str(tmp_path / "walk.npy"), "--csv", str(tmp_path / "o.csv"),
            "--json", str(tmp_path / "o.json"), "--plot", str(tmp_path / "o.png"), "--fps", "5", "--batch-size", "5"]
    assert main(argv) == 0
    xy, probs = _by_hand(models, stack.astype(np.float32))
    rows = list(csv.DictReader((tmp_path / "o.csv").open()))
    assert [r["source"] for r in rows] == [f"walk.npy[{k}]" for k in range(n)]
    np.testing.assert_allclose([[float(r["x_m"]), float(r["y_m"])] for r in rows], xy, atol=1e-5)
    np.testing.assert_allclose([[float(r[f"p_{p}"]) for p in POSTURES] for r in rows], probs, atol=2e-6)
    np.testing.assert_allclose([float(r["time_s"]) for r in rows], np.arange(n) / 5.0)
    smooth = smooth_trajectory(xy, default_window(n), 2)
    np.testing.assert_allclose([[float(r["x_smooth_m"]), float(r["y_smooth_m"])] for r in rows], smooth, atol=1e-5)
    out = json.loads((tmp_path / "o.json").read_text())
    assert out["smoothing"]["window_frames"] == default_window(n) and out["smoothing"]["order"] == 2
    np.testing.assert_allclose([[f["x_smooth_m"], f["y_smooth_m"]] for f in out["frames"]], smooth, atol=1e-9)
    assert (tmp_path / "o.png").stat().st_size > 10_000
    # explicit window and order; --no-smooth
    assert main(argv[:3] + ["--json", str(tmp_path / "w.json"), "--smooth-window", "7", "--smooth-order", "3"]) == 0
    w = json.loads((tmp_path / "w.json").read_text())
    np.testing.assert_allclose([[f["x_smooth_m"], f["y_smooth_m"]] for f in w["frames"]],
                               smooth_trajectory(xy, 7, 3), atol=1e-9)
    frames = load_frames([str(tmp_path / "walk.npy")], (RES, RES))
    assert predict(models, frames, smooth=False).smoothed is None
    assert predict(models, Frames(frames.images[:4], frames.sources[:4])).smoothed is None  # < 5 frames


def test_larger_frames_are_area_averaged_before_the_network(ckpt, models, tmp_path):
    img = np.random.default_rng(2).uniform(0.0, 1.0, (RES, RES, 3))
    big = np.kron(img, np.ones((3, 3, 1)))  # each pixel becomes a 3 x 3 block
    np.save(tmp_path / "big.npy", big)
    frames = load_frames([str(tmp_path / "big.npy")], (RES, RES))
    np.testing.assert_allclose(frames.images[0], img, atol=1e-6)
    assert main(["predict", str(ckpt), str(tmp_path / "big.npy"), "--json", str(tmp_path / "o.json")]) == 0
    f = json.loads((tmp_path / "o.json").read_text())["frames"][0]
    np.testing.assert_allclose([f["x_m"], f["y_m"]], _by_hand(models, img[None])[0][0], atol=1e-5)


def test_area_resize_is_a_box_filter():
    rng = np.random.default_rng(3)
    a = rng.uniform(size=(2, 13, 11, 3))
    out = area_resize(a, (8, 5))
    assert out.shape == (2, 8, 5, 3)
    np.testing.assert_allclose(out.mean(axis=(1, 2)), a.mean(axis=(1, 2)), atol=1e-12)  # flux kept
    # one output pixel by hand: rows [0, 13/8), columns [0, 11/5)
    wr = np.array([1.0, 5 / 8]) / (13 / 8)
    wc = np.array([1.0, 1.0, 1 / 5]) / (11 / 5)
    np.testing.assert_allclose(out[0, 0, 0], np.einsum("i,ijc,j->c", wr, a[0, :2, :3], wc), atol=1e-12)
    np.testing.assert_allclose(area_resize(np.ones((3, 4, 3)), (7, 9)), np.ones((7, 9, 3)))
    assert area_resize(a, (13, 11)) is not None and np.array_equal(area_resize(a, (13, 11)), a)


# ---------------------------------------------------------------- decoding

def test_8bit_png_undoes_srgb_unless_linear(ckpt, models, tmp_path):
    rng = np.random.default_rng(4)
    codes = rng.integers(0, 256, (RES, RES, 3)).astype(np.uint8)
    Image.fromarray(codes).save(tmp_path / "p.png")
    smooth = np.linspace(0, 255, RES * RES * 3).reshape(RES, RES, 3).astype(np.uint8)  # JPEG keeps gradients
    Image.fromarray(smooth).save(tmp_path / "p.jpg", quality=100, subsampling=0)
    v = codes / 255.0
    expect = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    np.testing.assert_allclose(read_image(tmp_path / "p.png"), expect, atol=1e-12)
    np.testing.assert_allclose(read_image(tmp_path / "p.png", linear=True), v, atol=1e-12)
    assert np.abs(read_image(tmp_path / "p.jpg", linear=True) - smooth / 255).max() < 0.02  # lossy, close
    assert srgb_to_linear(np.array(1.0)) == pytest.approx(1.0) and srgb_to_linear(np.array(0.5)) == pytest.approx(
        0.21404, abs=1e-5)
    gray = rng.integers(0, 256, (RES, RES)).astype(np.uint8)
    Image.fromarray(gray).save(tmp_path / "g.png")
    np.testing.assert_allclose(read_image(tmp_path / "g.png", linear=True), np.repeat(gray[..., None] / 255, 3, 2))
    assert main(["predict", str(ckpt), str(tmp_path / "p.png"), "--json", str(tmp_path / "o.json")]) == 0
    f = json.loads((tmp_path / "o.json").read_text())["frames"][0]
    clipped = torch.as_tensor((codes == 255).any(-1))[None]  # pixels at the largest code: the camera clipped
    assert clipped.any()
    np.testing.assert_allclose([f["x_m"], f["y_m"]], _by_hand(models, expect[None], clipped=clipped)[0][0], atol=1e-5)


def _png16(a: np.ndarray, path: Path) -> None:
    """A 16-bit PNG writer whose rows cycle through all five filter types."""
    h, w, c = a.shape
    raw = a.astype(">u2").view(np.uint8).reshape(h, w * c * 2).astype(np.int64)
    bpp = 2 * c
    rows, prior = [], np.zeros_like(raw[0])
    for y in range(h):
        cur, kind = raw[y], y % 5
        left = np.concatenate([np.zeros(bpp, np.int64), cur[:-bpp]])
        upleft = np.concatenate([np.zeros(bpp, np.int64), prior[:-bpp]])
        p = left + prior - upleft
        pa, pb, pc = np.abs(p - left), np.abs(p - prior), np.abs(p - upleft)
        paeth = np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, prior, upleft))
        pred = [np.zeros_like(cur), left, prior, (left + prior) // 2, paeth][kind]
        rows.append(bytes([kind]) + ((cur - pred) % 256).astype(np.uint8).tobytes())
        prior = cur

    def chunk(t: bytes, d: bytes) -> bytes:
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    color = {1: 0, 2: 4, 3: 2, 4: 6}[c]
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, color, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(b"".join(rows))) + chunk(b"IEND", b""))


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
def test_16bit_png_every_filter(tmp_path, channels):
    a = np.random.default_rng(channels).integers(0, 65536, (11, 7, channels)).astype(np.uint16)
    _png16(a, tmp_path / "x.png")
    np.testing.assert_array_equal(read_png16(tmp_path / "x.png"), a)
    rgb = np.repeat(a[..., :1], 3, 2) if channels < 3 else a[..., :3]
    np.testing.assert_allclose(read_image(tmp_path / "x.png", linear=True), rgb / 65535.0, atol=1e-12)
    np.testing.assert_allclose(read_image(tmp_path / "x.png"), srgb_to_linear(rgb / 65535.0), atol=1e-12)


def test_16bit_png_from_pillow(tmp_path):
    a = (np.random.default_rng(5).integers(0, 65536, (9, 6))).astype(np.uint16)
    Image.fromarray(a).save(tmp_path / "g16.png")
    np.testing.assert_array_equal(read_png16(tmp_path / "g16.png")[..., 0], a)


# ---------------------------------------------------------------- sequences and video

def test_numbered_sequence_plays_in_numeric_order(ckpt, tmp_path, capsys):
    seq = tmp_path / "seq"
    seq.mkdir()
    for k in (1, 2, 10, 11, 3):
        Image.fromarray(np.full((RES, RES, 3), 20 * k, np.uint8)).save(seq / f"frame{k}.png")
    names = [p.name for p in expand_inputs([str(seq)])]
    assert names == ["frame1.png", "frame2.png", "frame3.png", "frame10.png", "frame11.png"]
    assert [p.name for p in expand_inputs([str(seq / "frame%d.png")])] == names
    assert [p.name for p in expand_inputs([str(seq / "frame*.png")])] == names
    frames = load_frames([str(seq)], (RES, RES), linear=True)
    np.testing.assert_allclose(frames.images[:, 0, 0, 0], np.array([1, 2, 3, 10, 11]) * 20 / 255, atol=1e-6)
    assert main(["predict", str(ckpt), str(seq), "--csv", str(tmp_path / "o.csv")]) == 0
    rows = list(csv.DictReader((tmp_path / "o.csv").open()))
    assert [r["source"] for r in rows] == names and rows[0]["x_smooth_m"] != ""  # 5 frames: smoothed
    # issue 36 item 16: one file four times is not a burst of four, and a negative row count is refused
    one = str(seq / "frame1.png")
    _fails(capsys, ["predict", str(ckpt), one, one, one, one, "--burst", "4"], "given 4 times")
    _fails(capsys, ["predict", str(ckpt), one, "--max-rows", "-1"], "--max-rows")


def test_video_through_imageio(ckpt, models, tmp_path, monkeypatch):
    video = tmp_path / "clip.mp4"
    video.write_bytes(b"\0")
    codes = np.random.default_rng(6).integers(0, 256, (6, 16, 16, 3)).astype(np.uint8)
    v3 = types.ModuleType("imageio.v3")
    v3.immeta = lambda path: {"fps": 10.0}
    v3.imiter = lambda path: iter(list(codes))
    pkg = types.ModuleType("imageio")
    pkg.v3 = v3
    monkeypatch.setitem(sys.modules, "imageio", pkg)
    monkeypatch.setitem(sys.modules, "imageio.v3", v3)
    assert main(["predict", str(ckpt), str(video), "--json", str(tmp_path / "o.json")]) == 0
    out = json.loads((tmp_path / "o.json").read_text())
    assert [f["source"] for f in out["frames"]] == [f"clip.mp4#{k}" for k in range(6)]
    assert [f["time_s"] for f in out["frames"]] == pytest.approx(np.arange(6) / 10.0)
    lin = area_resize(srgb_to_linear(codes / 255.0), (RES, RES))
    sat = (codes == 255).any(-1).reshape(6, RES, 16 // RES, RES, 16 // RES)  # 16 -> RES: integer blocks
    xy, _ = _by_hand(models, lin, clipped=torch.as_tensor(sat.any(axis=(2, 4))))  # a block holding a 255 clipped
    np.testing.assert_allclose([[f["x_m"], f["y_m"]] for f in out["frames"]], xy, atol=1e-5)
    assert out["smoothing"] is not None


def test_video_without_imageio_is_a_clear_error(ckpt, tmp_path, monkeypatch, capsys):
    (tmp_path / "clip.mp4").write_bytes(b"\0")
    monkeypatch.setitem(sys.modules, "imageio", None)
    monkeypatch.setitem(sys.modules, "imageio.v3", None)
    _fails(capsys, ["predict", str(ckpt), str(tmp_path / "clip.mp4")], "imageio")


# ---------------------------------------------------------------- background subtraction

def test_background_subtraction_network_needs_the_empty_room(toy_scene, tmp_path, capsys):
    ckpt = _checkpoint(toy_scene, tmp_path / "bg.pt", net=NLOSNetConfig(background_subtract=True))
    m = load_trained(ckpt)
    rng = np.random.default_rng(7)
    img, bg = rng.uniform(0.5, 1.0, (RES, RES, 3)), rng.uniform(0.5, 1.0, (RES, RES, 3))
    np.save(tmp_path / "img.npy", img)
    np.save(tmp_path / "bg.npy", bg)
    _fails(capsys, ["predict", str(ckpt), str(tmp_path / "img.npy")], "--background")
    assert main(["predict", str(ckpt), str(tmp_path / "img.npy"), "--background", str(tmp_path / "bg.npy"),
                 "--json", str(tmp_path / "o.json")]) == 0
    f = json.loads((tmp_path / "o.json").read_text())["frames"][0]
    xy, _ = _by_hand(m, img[None], background=torch.as_tensor(bg[None], dtype=torch.float32))
    np.testing.assert_allclose([f["x_m"], f["y_m"]], xy[0], atol=1e-5)


# ---------------------------------------------------------------- errors

@pytest.fixture
def bad_files(tmp_path) -> Path:
    nan = np.ones((3, RES, RES, 3))
    nan[1, 2, 3, 0] = np.nan
    np.save(tmp_path / "nan.npy", nan)
    np.save(tmp_path / "good.npy", np.ones((RES, RES, 3)))
    np.save(tmp_path / "four.npy", np.ones((RES, RES, 4)))
    np.save(tmp_path / "flat.npy", np.ones((RES, RES)))
    np.save(tmp_path / "text.npy", np.array(["a", "b"]))
    np.save(tmp_path / "six.npy", np.ones((6, RES, RES, 3)))
    (tmp_path / "torn.npy").write_bytes(b"\x93NUMPY garbage")
    (tmp_path / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n\0\0\0\rIHDRjunk")
    (tmp_path / "fake.jpg").write_bytes(b"not a jpeg")
    (tmp_path / "notes.txt").write_text("hello")
    (tmp_path / "clip.mp4").write_bytes(b"\0")
    (tmp_path / "bad.pt").write_bytes(b"not a checkpoint")
    return tmp_path


@pytest.mark.parametrize("inputs,match", [
    (["missing.npy"], "missing.npy: file not found"),
    (["nan.npy"], "nan.npy frame 1: image contains NaN"),
    (["four.npy"], "(H, W, 3)"),
    (["flat.npy"], "(H, W, 3)"),
    (["text.npy"], "numeric"),
    (["torn.npy"], "unreadable .npy"),
    (["broken.png"], "broken.png"),
    (["fake.jpg"], "unreadable image"),
    (["notes.txt"], "unsupported input"),
    (["clip.mp4", "good.npy"], "only input"),
    (["none_*.png"], "no files match"),
    (["none_%03d.png"], "no files match"),
])
def test_bad_inputs_raise_one_line_errors(bad_files, inputs, match):
    with pytest.raises(NlosError, match=re.escape(match)) as info:
        load_frames([str(bad_files / i) for i in inputs], (RES, RES))
    assert "\n" not in str(info.value)


def test_cli_errors_exit_2_with_one_line(ckpt, bad_files, capsys):
    p, d = str(ckpt), bad_files
    _fails(capsys, ["predict", p, str(d / "missing.npy")], "not found")
    _fails(capsys, ["predict", p, str(d / "nan.npy")], "nan.npy frame 1: image contains NaN")
    _fails(capsys, ["predict", str(d / "bad.pt"), str(d / "good.npy")], "corrupted or not a checkpoint")
    _fails(capsys, ["predict", str(d / "nope.pt"), str(d / "good.npy")], "checkpoint not found")
    _fails(capsys, ["predict", p, str(d / "good.npy"), "--fps", "0"], "--fps")
    _fails(capsys, ["predict", p, str(d / "six.npy"), "--smooth-window", "4"], "odd")


class _Payload:
    """Unpickling this creates a file: what a hostile checkpoint would do instead."""

    def __init__(self, path: Path):
        self.path = path

    def __reduce__(self):
        return Path.touch, (self.path,)


def test_a_checkpoint_that_runs_code_is_refused_before_it_runs(ckpt, tmp_path, capsys):
    st = torch.load(ckpt, weights_only=True)  # the real checkpoint is data only
    marker = tmp_path / "ran"
    st["config"]["note"] = _Payload(marker)
    torch.save(st, tmp_path / "evil.pt")
    with pytest.raises(NlosError, match="refused: it holds Python objects") as info:
        load_trained(tmp_path / "evil.pt")
    assert "\n" not in str(info.value) and not marker.exists()
    _fails(capsys, ["predict", str(tmp_path / "evil.pt"), str(tmp_path / "x.npy")], "loading it could run code")
    assert not marker.exists()


def test_outputs_never_overwrite_inputs_and_odd_frames_are_refused(ckpt, tmp_path, capsys):
    """Issue 36: --csv naming an input, a float32 overflow, a background of another size and
    frames smaller than the network's input each fail in one line, touching nothing."""
    frame = tmp_path / "frame.npy"
    np.save(frame, np.full((RES, RES, 3), 0.2))
    before = frame.read_bytes()
    _fails(capsys, ["predict", str(ckpt), str(frame), "--csv", str(frame)], "is one of this command's inputs")
    _fails(capsys, ["predict", str(ckpt), str(tmp_path), "--json", str(frame)], "is one of this command's inputs")
    assert frame.read_bytes() == before
    np.save(tmp_path / "huge.npy", np.full((RES, RES, 3), 1.7e308))
    _fails(capsys, ["predict", str(ckpt), str(tmp_path / "huge.npy")], "beyond float32's range")
    np.save(tmp_path / "wide.npy", np.full((RES, 2 * RES, 3), 0.2))
    _fails(capsys, ["predict", str(ckpt), str(frame), "--background", str(tmp_path / "wide.npy")],
           "photograph the empty room with the same camera settings")
    np.save(tmp_path / "tiny.npy", np.full((1, 1, 3), 0.2))
    _fails(capsys, ["predict", str(ckpt), str(tmp_path / "tiny.npy")], "smaller than the network's")


def test_json_holds_no_nan():
    from nlos_spotlight.apps.predict import _finite

    got = json.loads(json.dumps(_finite({"x": [1.0, float("nan")], "y": {"z": float("inf")}}), allow_nan=False))
    assert got == {"x": [1.0, None], "y": {"z": None}}
