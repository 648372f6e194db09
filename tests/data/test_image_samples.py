"""Image samples (docs/dataset-format.md): the person's light under a room's stored spots only.

One room of the ``tiny`` preset's renderer settings (500 body samples and a 40-vertex candidate mesh:
these tests compare renders of the same people, not the render with the physics), 5 people: the first 2 with full transport,
3 image samples; and the same room with every person at full transport (stored in full, rank 0),
whose samples are the same people, to compare against.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import torch

from nlos_spotlight.config_file import with_fields
from nlos_spotlight.data.config import load_config
from nlos_spotlight.data.generate import generate, verify
from nlos_spotlight.data.store import f16_decode, f16_encode
from nlos_spotlight.errors import NlosError
from nlos_spotlight.train.imaging import form_images
from nlos_spotlight.data.tensors import load_scene_tensors, transport_samples

M, N = 2, 5
FIELDS = dict(train_scenes=1, val_scenes=0, test_scenes=0, samples_per_scene=N, transport_rank=0, seed=5, person_samples=500, los_vertices=40,
              stored_spots_top=2)


def config(**changes):
    return with_fields(load_config("tiny"), name="tiny-images", **{**FIELDS, **changes})


@pytest.fixture(scope="module")
def datasets(tmp_path_factory):
    root = tmp_path_factory.mktemp("images")
    generate(config(transport_samples_per_scene=M), root / "mixed", progress=False)
    generate(config(), root / "full", progress=False)
    scene = lambda kind: next((root / kind / "scenes").iterdir())
    return scene("mixed"), scene("full"), root


def test_layout_and_spots(datasets):
    mixed, full, root = datasets
    assert sorted(p.name for p in (mixed / "samples").iterdir()) == ["00000.npz", "00001.npz"]
    assert sorted(p.name for p in (mixed / "images").iterdir()) == ["00002.npz", "00003.npz", "00004.npz"]
    rec = json.loads((mixed / "spots.json").read_text())
    spots = rec["spots"]
    assert spots == sorted(set(spots)) and set(rec["snr_top"]) <= set(spots) and len(rec["snr_top"]) == 2
    assert rec["policies"]["adaptive"] in spots and rec["policies"]["center"] in spots
    assert set(rec["policies"]["random"].values()) <= set(spots)
    z = np.load(mixed / "images" / "00002.npz")
    assert z["nlos_spots"].dtype == np.float16 and z["nlos_spots"].shape == (len(spots), 32, 32, 3)
    assert "transport_u" not in z.files and "body_faces" not in z.files
    done = json.loads((mixed / "done.json").read_text())
    assert done["samples"] == N and done["transport_samples"] == M
    manifest = verify(root / "mixed")
    assert manifest["format"] == "nlos-dataset/2" and manifest["splits"]["train"][0]["transport_samples"] == M
    # the full-transport people are the same files whichever kind the later people are
    for k in range(M):
        a, b = np.load(mixed / "samples" / f"{k:05d}.npz"), np.load(full / "samples" / f"{k:05d}.npz")
        assert all(np.array_equal(a[n], b[n]) for n in b.files)


def test_image_sample_equals_full_transport(datasets):
    mixed, full, _ = datasets
    spots = json.loads((mixed / "spots.json").read_text())["spots"]
    for k in range(M, N):
        img = np.load(mixed / "images" / f"{k:05d}.npz")
        ref = np.load(full / "samples" / f"{k:05d}.npz")
        f = ref["transport_v"][spots].astype(np.float64)  # rank 0: F itself, (T, H, W, 3)
        got = f16_decode(img, "nlos_spots").astype(np.float64)
        assert np.abs(f).max() > 0
        err = np.linalg.norm((got - f).reshape(len(spots), -1), axis=1) / np.linalg.norm(f.reshape(len(spots), -1),
                                                                                         axis=1).clip(1e-300)
        assert err.max() < 1e-3, err  # float16 bound 2^-11 = 4.9e-4, plus float32 summation order
        for name in ("nlos_ambient", "flash_nlos"):
            a, b = f16_decode(img, name).astype(np.float64), ref[name].astype(np.float64)
            assert np.linalg.norm(a - b) <= 1e-3 * np.linalg.norm(b)
        for name in ("position", "posture", "facing_deg", "height_m", "albedo", "trajectory", "frame"):
            assert np.array_equal(img[name], ref[name])


def test_loader_reproduces_images(datasets):
    mixed, full, _ = datasets
    spots = json.loads((mixed / "spots.json").read_text())["spots"]
    s, ref = load_scene_tensors(mixed, []), load_scene_tensors(full, [])
    t = len(s.faces)
    assert s.num_samples == N and s.transport.tolist() == [True] * M + [False] * (N - M)
    assert s.stored.tolist() == [i in spots for i in range(t)] and bool(ref.stored.all())
    assert s.u.shape[:2] == (N, t) and s.v.shape[:2] == (N, s.u.shape[2])
    idx = torch.arange(N)
    # the person's light alone (direct + ambient ~ 1 would swamp its ~1e-6 in float32 sums)
    dark = lambda x: dataclasses.replace(x, direct=torch.zeros_like(x.direct), ambient=torch.zeros_like(x.ambient),
                                         nlos_ambient=torch.zeros_like(x.nlos_ambient))
    for spot in spots:
        y = torch.zeros(t)
        y[spot] = 1
        nlos, free = form_images(dark(s), idx, y)
        nlos_ref = form_images(dark(ref), idx, y)[0]
        assert not free.any() and nlos_ref.flatten(1).norm(dim=1).min() > 0
        rel = (nlos - nlos_ref).flatten(1).norm(dim=1) / nlos_ref.flatten(1).norm(dim=1)
        assert float(rel.max()) < 1e-3, rel
        assert torch.equal(form_images(s, idx, y)[1], form_images(ref, idx, y)[1])
    assert torch.equal(s.target, ref.target) and torch.equal(s.posture, ref.posture)
    # a mixture of stored spots works too (the einsum is linear)
    y = torch.zeros(t)
    y[spots[0]], y[spots[-1]] = 0.25, 0.75
    got, want = form_images(dark(s), idx, y)[0], form_images(dark(ref), idx, y)[0]
    assert float((got - want).norm() / want.norm()) < 1e-3
    # kinds: full-transport samples only (the IEN's), image samples only (rank K, no padding)
    tr = transport_samples(s)
    assert tr.num_samples == M and bool(tr.transport.all())
    only = load_scene_tensors(mixed, [], samples="transport")
    assert torch.equal(only.u, ref.u[:M]) and bool(only.stored.all())
    im = load_scene_tensors(mixed, [], samples="images")
    assert im.u.shape == (N - M, t, len(spots)) and not bool(im.transport.any())


def test_unstored_spot_raises(datasets):
    mixed, _, _ = datasets
    s = load_scene_tensors(mixed, [])
    off = int(torch.nonzero(~s.stored & s.landed)[0])
    y = torch.zeros(len(s.faces))
    y[off] = 1
    with pytest.raises(NlosError, match=f"spot {off} is not among"):
        form_images(s, torch.arange(N), y)
    form_images(s, torch.arange(M), y)  # full-transport samples hold every spot
    form_images(transport_samples(s), torch.arange(M), y)
    grad = torch.zeros(len(s.faces), requires_grad=True)
    with pytest.raises(NlosError, match="gradient"):
        form_images(s, torch.tensor([M]), grad + torch.nn.functional.one_hot(s.stored.nonzero()[0, 0], len(s.faces)))
    form_images(s, torch.arange(N), None, "flash")  # flash and ambient images are stored for every sample
    form_images(s, torch.arange(N), None, "ambient")


def test_concat_people_of_two_renders(datasets):
    """People of one room rendered apart (``SceneTensors.concat``): every sample keeps its own image
    under every spot both renders store, even where the second stores its spots in another order."""
    mixed, _, _ = datasets
    im = load_scene_tensors(mixed, [], samples="images")
    a, b = im.subset(torch.tensor([0])), im.subset(torch.tensor([1, 2]))
    # the second render as if it had chosen its spots in reverse slot order and dropped one
    spots = im.stored.nonzero().flatten()
    stored_b = im.stored.clone()
    stored_b[spots[0]] = False
    b = dataclasses.replace(b, u=b.u.flip(2), v=b.v.flip(1), stored=stored_b)
    both = a.concat(b)
    assert both.num_samples == 3 and torch.equal(both.stored, stored_b) and torch.equal(both.posture, im.posture)
    for spot in spots[1:]:
        y = torch.zeros(len(im.faces))
        y[spot] = 1
        got, want = form_images(both, torch.arange(3), y), form_images(im, torch.arange(3), y)
        assert want[0].abs().max() > 0 and all(torch.equal(g, w) for g, w in zip(got, want))
    with pytest.raises(NlosError, match="not in the same room .'direct' differs"):
        a.concat(dataclasses.replace(b, direct=b.direct * 1.01))
    # a render that stores fewer spots: padded with empty slots
    one = dataclasses.replace(b, u=b.u[:, :, -1:], v=b.v[:, -1:], stored=im.stored)  # its slot: spots[0]
    y = torch.zeros(len(im.faces))
    y[spots[0]] = 1
    got = form_images(one.concat(a), torch.arange(3), y)
    want = form_images(im.subset(torch.tensor([1, 2, 0])), torch.arange(3), y)
    assert want[0].abs().max() > 0 and all(torch.equal(g, w) for g, w in zip(got, want))
    with pytest.raises(NlosError, match="differ in 'v'"):
        a.concat(dataclasses.replace(b, v=b.v[:, :, :4]))


def test_resume_rebuilds_what_is_missing(datasets, tmp_path):
    mixed, _, root = datasets
    manifest = json.loads((root / "mixed" / "manifest.json").read_text())
    copy = tmp_path / "copy"
    shutil.copytree(root / "mixed", copy)
    scene = copy / "scenes" / mixed.name
    for p in (copy / "manifest.json", scene / "done.json", scene / "images" / "00004.npz", scene / "spots.json"):
        p.unlink()
    torn = scene / "images" / "00003.npz"
    torn.write_bytes(torn.read_bytes()[:300])
    generate(config(transport_samples_per_scene=M), copy, progress=False)
    assert json.loads((copy / "manifest.json").read_text())["content_sha256"] == manifest["content_sha256"]


def test_resume_after_kill_during_images(datasets, tmp_path):
    _, _, root = datasets
    manifest = json.loads((root / "mixed" / "manifest.json").read_text())
    out = tmp_path / "data"
    # (a YAML config cannot have zero test rooms: run the same config through the API)
    code = ("import sys, json; from nlos_spotlight.data.config import DatasetConfig; "
            "from nlos_spotlight.data.generate import generate; "
            "generate(DatasetConfig(**json.loads(sys.argv[2])), sys.argv[1], progress=False)")
    cmd = [sys.executable, "-c", code, str(out), json.dumps(config(transport_samples_per_scene=M).to_dict())]
    env = {**os.environ, "NLOS_QUIET": "1"}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 300
    while time.time() < deadline and not list(out.glob("scenes/*/images/*.npz")) and proc.poll() is None:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not (out / "manifest.json").exists(), "killed too late to test resuming"
    res = subprocess.run(cmd, env=env, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    m = json.loads((out / "manifest.json").read_text())
    assert m["content_sha256"] == manifest["content_sha256"] and not list(out.rglob(".*.tmp*"))


def test_f16_codec_and_config():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(3, 4, 5)) * np.array([1e-9, 1e-6, 3e2])[:, None, None]
    half, scale = f16_encode(a, per_first_axis=True)
    assert half.dtype == np.float16 and scale.shape == (3,) and np.all(np.log2(scale) == np.round(np.log2(scale)))
    back = half.astype(np.float64) * scale[:, None, None]
    assert np.all(np.abs(back - a) <= 2 ** -11 * np.abs(a) + 1e-30)
    zero, s0 = f16_encode(np.zeros((2, 2)))
    assert not zero.any() and s0 == 1
    assert config().transport_samples_per_scene == -1  # the default keeps every sample at full transport


def test_config_errors(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("transport_samples_per_scene: 0\n")
    with pytest.raises(NlosError, match="transport_samples_per_scene"):
        load_config(str(bad))
    bad.write_text("stored_spots_top: -2\n")
    with pytest.raises(NlosError, match="stored_spots_top"):
        load_config(str(bad))


def test_dataset_started_before_the_new_fields_resumes(tmp_path):
    from nlos_spotlight.data.generate import _check_config

    cfg = load_config("tiny")
    old = {k: v for k, v in cfg.to_dict().items() if k not in ("transport_samples_per_scene", "stored_spots_top")}
    (tmp_path / "config.json").write_text(json.dumps(old))
    _check_config(tmp_path, cfg)  # the missing fields mean their defaults
    with pytest.raises(NlosError, match="transport_samples_per_scene"):
        _check_config(tmp_path, dataclasses.replace(cfg, transport_samples_per_scene=2))


def test_renderer_columns_for_stored_spots():
    """transport_images(spots=..., also=..., nlos_ambient=True): the same columns as the full F,
    the other renderer's render and the nlos_ambient component, from one person -> pixel pass."""
    from nlos_spotlight.data.flash import flash_scene
    from nlos_spotlight.render.person import Person
    from nlos_spotlight.render.transport import Renderer, RenderSettings
    from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene
    from nlos_spotlight.scene.format import Ambient

    settings = RenderSettings(pixel_samples=1, transport_pixel_samples=1, spot_samples=8, person_samples=24,
                              dtype="float64", device="cpu")
    sc = corner_scene("furniture", resolution=8)
    sc.ambient = Ambient(np.zeros(3), np.full(3, 0.05))
    aims = np.stack([SPOT_TARGET + [dx, 0, dz] for dx, dz in ((0, 0), (0.25, 0.1), (-0.3, -0.2), (0.1, -0.3))])
    r = Renderer(sc, settings, aim_points=aims)
    flash = Renderer(flash_scene(sc), settings, aim_points=sc.camera.look_at[None])
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, settings.person_samples)
    t = np.array([0.05, 0.1, 0.0])
    full = r.transport_images(person, t)
    got = r.transport_images(person, t, [3, 1], also=(flash,), nlos_ambient=True)
    assert got.shape == (4, 8, 8, 3) and float(full[[3, 1]].abs().max()) > 0
    torch.testing.assert_close(got[:2], full[[3, 1]], rtol=1e-10, atol=0)
    ref = flash.render(flash.spot_vector(0), person, translation=t, components=("nlos", "nlos_ambient"))
    torch.testing.assert_close(got[2], ref["nlos"], rtol=1e-10, atol=0)
    torch.testing.assert_close(got[3], ref["nlos_ambient"], rtol=1e-10, atol=0)
    with pytest.raises(ValueError, match="distinct"):
        r.transport_images(person, t, [1, 1])


def test_demo_seen_room_trains_on_the_pool_and_scores_the_test_people(tmp_path):
    """make demo's step 5 on a 25-person room: the pool (every person but the fixed test and
    validation people) trains, both captures are scored, and the mean-answer row is the error of
    the pool's mean position on the test people, computed here independently."""
    from nlos_spotlight.demo import seen_room

    generate(config(samples_per_scene=27, transport_samples_per_scene=M), tmp_path / "room", progress=False)
    table = seen_room(tmp_path / "room", tmp_path / "seen", progress=False, min_steps=2).read_text()
    rows = [line for line in table.splitlines() if line.startswith("| noise-free") or line.startswith("| default")]
    assert len(rows) == 2 and all("| 21 |" in r for r in rows)  # 25 image people - 2 test - 2 validation
    s = load_scene_tensors(next((tmp_path / "room" / "scenes").iterdir()), ["normals"], samples="images")
    k = torch.arange(s.num_samples)
    test, val = k % 10 == 9, k % 10 == 8
    mean = s.target[~test & ~val].mean(0)
    expected = 100 * (s.target[test] - mean).norm(dim=1).mean()
    assert f"{float(expected):.1f} cm |" in rows[0]
    assert json.loads((tmp_path / "seen" / "default" / "result.json").read_text())["people_per_room"] == 21
