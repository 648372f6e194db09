"""``nlos generate``: determinism, shards that merge, resume after a kill, corruption detection."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from nlos_spotlight.data.config import DatasetConfig, load_config
from nlos_spotlight.data.generate import finalize, generate, plan, verify
from nlos_spotlight.errors import NlosError



@pytest.fixture(scope="module")
def reference(micro_config, tmp_path_factory):
    out = tmp_path_factory.mktemp("ref")
    generate(DatasetConfig(**micro_config), out, progress=False)
    return out, json.loads((out / "manifest.json").read_text())


def test_complete_and_verifiable(reference):
    out, manifest = reference
    assert manifest["format"] == "nlos-dataset/2" and manifest["config"]["seed"] == 3
    assert verify(out)["content_sha256"] == manifest["content_sha256"]
    ids = {s["id"] for split in manifest["splits"].values() for s in split}
    assert len(ids) == 3 and all(i.startswith(("train", "test")) for i in ids)
    test_scene = out / "scenes" / manifest["splits"]["test"][0]["id"]
    assert len(list((test_scene / "samples").glob("*.npz"))) == 3 + 3  # static + one 3-frame walk
    z = np.load(test_scene / "samples" / "00000.npz")
    st = np.load(test_scene / "static.npz")
    t = st["aim_points"].shape[0]
    assert z["transport_u"].shape == (t, 8) and z["transport_v"].shape == (8, 12, 12, 3)
    assert st["direct"].shape == (t, 12, 12, 3) and st["los_faces"].shape == (t, 3)


def test_same_config_same_content(micro_config, reference, tmp_path):
    out, manifest = reference
    generate(DatasetConfig(**micro_config), tmp_path, progress=False)
    assert json.loads((tmp_path / "manifest.json").read_text())["content_sha256"] == manifest["content_sha256"]


def test_shards_merge_to_the_same_content(micro_config, reference, tmp_path):
    _, manifest = reference
    parts = [tmp_path / "a", tmp_path / "b"]
    for i, d in enumerate(parts):
        generate(DatasetConfig(**micro_config), d, shard=(i, 2), progress=False)
        assert not (d / "manifest.json").exists()  # each part alone is incomplete
    merged = tmp_path / "merged"
    for d in parts:
        shutil.copytree(d, merged, dirs_exist_ok=True)
    finalize(DatasetConfig(**micro_config), merged)
    assert json.loads((merged / "manifest.json").read_text())["content_sha256"] == manifest["content_sha256"]


def test_resume_after_kill(micro_config, reference, tmp_path):
    _, manifest = reference
    cfg = tmp_path / "micro.yaml"
    cfg.write_text("\n".join(f"{k}: {v}" for k, v in micro_config.items() if k != "name") + "\n")
    out = tmp_path / "data"
    cmd = [sys.executable, "-m", "nlos_spotlight.cli", "generate", str(cfg), "--out", str(out), "--quiet"]
    env = {**os.environ, "NLOS_QUIET": "1"}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 300
    while time.time() < deadline and len(list(out.glob("scenes/*/samples/*.npz"))) < 2:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not (out / "manifest.json").exists(), "killed too late to test resuming"
    res = subprocess.run(cmd, env=env, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    m = json.loads((out / "manifest.json").read_text())
    assert m["content_sha256"] != "" and len(list(out.rglob(".*.tmp*"))) == 0
    assert len(list(out.glob("scenes/*/samples/*.npz"))) == 3 + 3 + 6
    assert m["config"] == manifest["config"]  # the YAML file is named micro.yaml: same config
    assert m["content_sha256"] == manifest["content_sha256"]


def test_other_config_refused(micro_config, reference):
    out, _ = reference
    other = DatasetConfig(**micro_config)
    other.samples_per_scene = 4
    with pytest.raises(NlosError, match="another config.*samples_per_scene"):
        generate(other, out, progress=False)


def test_a_dataset_recorded_flat_resumes_under_the_same_config(micro_config, reference, tmp_path):
    """A dataset made before the ``render`` block recorded its sampling flat in ``config.json``: the
    same config continues it (nothing rendered again, the same content) and another is refused."""
    from nlos_spotlight.config_file import flatten, with_fields

    out, manifest = reference
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    flat = flatten(DatasetConfig, json.loads((copy / "config.json").read_text()))
    assert "render" not in flat and flat["person_samples"] == micro_config["render"]["person_samples"]
    (copy / "config.json").write_text(json.dumps(flat))
    (copy / "manifest.json").unlink()  # as if the run had stopped before its manifest
    generate(DatasetConfig(**micro_config), copy, progress=False)
    assert json.loads((copy / "manifest.json").read_text())["content_sha256"] == manifest["content_sha256"]
    other = with_fields(DatasetConfig(**micro_config), person_samples=49)
    with pytest.raises(NlosError, match="another config \\(differs in: person_samples\\)"):
        generate(other, copy, progress=False)


def test_corruption_detected(reference, tmp_path):
    out, manifest = reference
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    victim = next(copy.glob("scenes/train-*/samples/00001.npz"))
    victim.write_bytes(victim.read_bytes()[:200])
    with pytest.raises(NlosError, match="corrupted"):
        verify(copy)


def test_split_by_scene_balanced_postures_positions(micro_config, reference):
    out, manifest = reference
    from nlos_spotlight.scene import load_scene

    for split in manifest["splits"].values():
        for s in split:
            d = out / "scenes" / s["id"]
            hr = load_scene(d).hidden_region
            post = []
            for p in sorted((d / "samples").glob("*.npz")):
                z = np.load(p)
                assert np.all(z["position"] >= hr.min - 1e-9) and np.all(z["position"] <= hr.max + 1e-9)
                if int(z["trajectory"]) < 0:
                    post.append(int(z["posture"]))
            assert len(set(post)) == len(post)  # 3 samples, 3 different postures (balanced cycle)
    assert {p.split for p in plan(DatasetConfig(**micro_config))} == {"train", "test"}


def test_presets_and_yaml_errors(tmp_path):
    assert load_config("tiny").train_scenes >= 1 and load_config("small").samples_per_scene > 6
    bad = tmp_path / "bad.yaml"
    bad.write_text("resolutin: 32\n")
    with pytest.raises(NlosError, match="unknown key 'resolutin'"):
        load_config(str(bad))
    bad.write_text("resolution: 100000\n")
    with pytest.raises(NlosError, match="absurd"):
        load_config(str(bad))
    with pytest.raises(NlosError, match="neither a preset"):
        load_config(str(tmp_path / "missing.yaml"))


def test_verify_names_each_bad_file_and_generate_repairs_it(micro_config, reference, tmp_path, capsys):
    """``nlos verify``: one line per bad file, exit 2; rerunning generate renders exactly those
    files again (the content hash comes back) instead of calling the dataset complete."""
    from nlos_spotlight.cli import main

    out, manifest = reference
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    assert main(["verify", str(copy)]) == 0
    a, b = sorted(copy.glob("scenes/train-*/samples/0000[01].npz"))[:2]
    a.write_bytes(a.read_bytes()[:200])  # truncated
    b.unlink()
    capsys.readouterr()
    assert main(["verify", str(copy)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and err[-1].startswith("error:") and "2 bad files" in err[-1]
    assert {line.split(": ")[1] for line in err[:2]} == {str(a), str(b)}
    keep = {p: p.stat().st_mtime_ns for p in copy.rglob("*.npz") if p not in (a, b)}
    generate(DatasetConfig(**micro_config), copy, progress=False)
    assert main(["verify", str(copy)]) == 0
    assert json.loads((copy / "manifest.json").read_text())["content_sha256"] == manifest["content_sha256"]
    assert all(p.stat().st_mtime_ns == t for p, t in keep.items())  # nothing else redone


def test_bad_values_are_refused_before_anything_is_written(tmp_path, capsys):
    from nlos_spotlight.cli import main

    assert main(["generate", "tiny", "--out", str(tmp_path / "d"), "--seed=-1"]) == 2
    assert "--seed" in capsys.readouterr().err and not (tmp_path / "d").exists()
    bad = tmp_path / "bad.yaml"
    for text, field in (("val_scenes: -1", "val_scenes"), ("transport_rank: -1", "transport_rank"),
                        ("trajectory_frames: -3", "trajectory_frames"), ("frame_rate_hz: 0", "frame_rate_hz"),
                        ("trajectories_per_test_scene: -1", "trajectories_per_test_scene"),
                        ("train_scenes: -1", "train_scenes"),
                        ("train_scenes: 0\nval_scenes: 0\ntest_scenes: 0", "at least one scene")):
        bad.write_text(text + "\n")
        with pytest.raises(NlosError, match=field):
            load_config(str(bad))
    bad.write_text("train_scenes: 0\nval_scenes: 0\ntest_scenes: 2\n")  # a test set for models trained elsewhere
    assert load_config(str(bad)).num_scenes == 2
    (tmp_path / "f").write_text("x")
    assert main(["generate", "tiny", "--out", str(tmp_path / "f")]) == 2
    assert "is a file" in capsys.readouterr().err


def test_a_room_too_big_for_memory_is_refused_before_anything_is_written(micro_config, tmp_path, monkeypatch):
    """The direct images of every candidate alone: 2 faces per LOS vertex x 2 copies x H W 3 x 4 bytes."""
    import nlos_spotlight.data.config as dc

    big = DatasetConfig(**{**micro_config, "resolution": 1024, "los_vertices": 800})
    assert dc.memory_needed_bytes(big) >= 2 * 1600 * 1024 ** 2 * 3 * 4
    monkeypatch.setattr(dc, "available_memory_bytes", lambda: 8 * 2**30)
    with pytest.raises(NlosError, match=r"resolution 1024 with 800 LOS vertices needs about 3\d\.\d GiB"):
        generate(big, tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()
    dc.check_memory(DatasetConfig(**micro_config), "config")  # the micro room fits anywhere


def test_one_manifest_reader_for_generate_verify_and_training(reference, tmp_path):
    """A missing or corrupted manifest.json: the same one-line error from every reader of it."""
    from nlos_spotlight.data.tensors import split_ids
    from nlos_spotlight.data.verify import dataset_problems

    data, _ = reference
    for name, text, match in (("missing", None, "no manifest.json"), ("list", "[1, 2]", "corrupted"),
                              ("torn", '{"splits": {"train": [{"i', "corrupted")):
        d = tmp_path / name
        shutil.copytree(data, d)
        (d / "manifest.json").unlink() if text is None else (d / "manifest.json").write_text(text)
        for read in (lambda: verify(d), lambda: split_ids(d, "train")):
            with pytest.raises(NlosError, match=match) as e:
                read()
            assert "\n" not in str(e.value)
        assert dataset_problems(d)[0][0][0].name == "manifest.json"


def test_fused_kernels_give_the_same_data(micro_config, reference, tmp_path):
    """``--fuse`` is an execution choice: every stored array agrees with the eager run's to float rounding."""
    import warnings

    out, _ = reference
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        generate(DatasetConfig(**micro_config), tmp_path, progress=False, fuse=True)
    if any("fused kernels unavailable" in str(w.message) for w in caught):
        pytest.skip("torch.compile cannot build kernels on this machine (eager fallback taken)")
    assert json.loads((tmp_path / "shards" / "0-of-1.json").read_text())["fused_kernels"] is True
    files = sorted(p.relative_to(out) for p in (out / "scenes").rglob("*.npz"))
    assert files and files == sorted(p.relative_to(tmp_path) for p in (tmp_path / "scenes").rglob("*.npz"))
    def arrays(z):  # the low-rank factors are unique only up to rotation: compare their product
        skip = ("transport_u", "transport_v", "transport_error")  # the last: the truncation's residual, at rounding level
        d = {k: z[k] for k in z.files if k not in skip}
        if "transport_u" in z.files:
            d["transport"] = np.einsum("tr,rhwc->thwc", z["transport_u"], z["transport_v"])
        return d

    for f in files:
        a, b = arrays(np.load(out / f)), arrays(np.load(tmp_path / f))
        assert a.keys() == b.keys()
        for k in a:
            x, y = a[k], b[k]
            if x.dtype.kind not in "fc":
                assert np.array_equal(x, y), (f, k)
                continue
            x, y = x.astype(np.float64), y.astype(np.float64)
            assert np.allclose(y, x, rtol=1e-3, atol=1e-5 * (np.abs(x).max() + 1e-30)), (f, k)


def test_stray_file_fails_verify_and_regenerating_removes_it(micro_config, reference, tmp_path):
    out, manifest = reference
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    stray = next(copy.glob("scenes/train-*/samples")) / "99999.npz"
    np.savez(stray, junk=np.zeros(3))
    from nlos_spotlight.data.verify import dataset_problems

    assert any(p == stray and "stray file" in why for p, why in dataset_problems(copy)[0])
    generate(DatasetConfig(**micro_config), copy, progress=False)
    assert not stray.exists() and dataset_problems(copy)[0] == []
    verify(copy)
    assert json.loads((copy / "manifest.json").read_text())["content_sha256"] == manifest["content_sha256"]
