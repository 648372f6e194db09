"""``nlos fit``: a tiny fit end to end (scene directory and bare scan), its report, ``nlos predict``
on the room model, resuming, parallel rendering, and the error paths."""

from __future__ import annotations

import dataclasses
import os
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

from nlos_spotlight.cli import main
from nlos_spotlight.config_file import flatten, with_fields
from nlos_spotlight.fit.config import BEFORE, PRESETS, FitConfig
from nlos_spotlight.fit.run import dataset_config, fit_room, render_people
from nlos_spotlight.scene.examples import corner_scene
from nlos_spotlight.scene.io import save_scene

TINY = with_fields(PRESETS["tiny"], people=24, heldout=6, transport_people=2, los_vertices=30,
                           person_samples=64, body_faces=300, min_steps=8, epochs=1.0)
"""Seconds: 36 people on 16x16 images, a 30-vertex candidate mesh."""


@pytest.fixture(scope="module")
def room_dir(tmp_path_factory):
    """The bundled example scene without its person: a partition hides x > 0 from the tripod (its
    region shrunk so that a person 0.25 m around stays behind the partition everywhere in it)."""
    from nlos_spotlight.scene.format import HiddenRegion

    d = tmp_path_factory.mktemp("room") / "example"
    sc = corner_scene("example", resolution=16)
    sc.human, sc.hidden_region = None, HiddenRegion(np.array([0.3, 1.0]), np.array([2.5, 3.5]))
    save_scene(sc, d)
    return d


@pytest.fixture(scope="module")
def fitted(room_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("fit") / "model"
    report = fit_room(str(room_dir), out, TINY, {}, progress=False)
    return out, report


def _high_water_mb() -> float:
    """This process's peak resident memory so far by the kernel's own count (``VmHWM``), MB."""
    status = Path("/proc/self/status").read_text()
    return int(next(line for line in status.splitlines() if line.startswith("VmHWM:")).split()[1]) / 1024


def test_report_matches_its_contract(fitted):
    out, report = fitted
    on_disk = json.loads((out / "report.json").read_text())
    assert on_disk["spot"] == report["spot"] and set(on_disk) >= {"spot", "heldout", "capture"}
    s, h = on_disk["spot"], on_disk["heldout"]
    assert isinstance(s["face"], int) and len(s["aim"]) == 3
    assert h["people"] == TINY.heldout and 0 <= h["posture_accuracy"] <= 1 and np.isfinite(h["error_cm"])
    assert on_disk["capture"]["burst_frames"] == TINY.burst_frames
    # every policy's pick against the physics search: the oracle's is the best landed candidate (1.0),
    # the chosen spot is the oracle's (TINY's policy), each ratio the candidate SNR of lighting.snr
    from nlos_spotlight.lighting.snr import candidate_snr

    sp = on_disk["spot_policies"]
    snr = candidate_snr(next((out / "data" / "scenes").iterdir()))
    assert sp["policies"]["oracle"]["snr_over_best"] == pytest.approx(1.0)
    assert sp["policies"]["chosen"]["face"] == sp["policies"]["oracle"]["face"] == s["face"]
    for v in sp["policies"].values():
        assert v["snr_over_best"] == pytest.approx(snr[v["face"]] / sp["best_snr"]) and 0 <= v["snr_over_best"] <= 1
    # the aim point is the stored candidate's, and pan/tilt reproduce the beam's direction (closed form)
    st = np.load(next((out / "data" / "scenes").iterdir()) / "static.npz")
    np.testing.assert_allclose(s["aim"], st["aim_points"][s["face"]], atol=1e-9)
    room = json.loads((out / "room.json").read_text())
    proj, cam = np.array(room["projector"]["position"]), room["camera"]
    az, tilt = np.radians(s["azimuth_deg"]), np.radians(s["tilt_deg"])
    d = np.array([np.cos(tilt) * np.cos(az), np.cos(tilt) * np.sin(az), np.sin(tilt)])
    np.testing.assert_allclose(d * s["distance_m"], np.array(s["aim"]) - proj, atol=1e-9)
    view = np.array(cam["look_at"]) - np.array(cam["position"])
    heading = np.degrees(np.arctan2(view[1], view[0]))
    assert abs((s["azimuth_deg"] - heading - s["pan_deg"] + 180) % 360 - 180) < 1e-9
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") == 4 and "Where to aim the projector" in html
    # the peak memory is this process's high-water mark then (the kernel's VmHWM, read now, cannot be lower)
    hwm = _high_water_mb()
    mem = on_disk["peak_memory_mb"]
    assert 100 < mem["fit_process"] <= hwm + 1 and f"peak memory: this process {mem['fit_process']:,} MB" in html


def test_report_holds_the_rooms_ceiling(fitted):
    """The ceiling of TINY's one held-out person: an ideal observer's accuracy (fitting the nuisances
    never helps it), a finite position bound, and its row in the HTML beside the room model's."""
    out, report = fitted
    c = report["ceiling"]
    assert c["people"] == TINY.ceiling_people == 1 and c["burst_frames"] == TINY.burst_frames
    assert 0 < c["posture_accuracy"] <= c["posture_accuracy_known"] + 0.02 <= 1.02
    assert 0 < c["position_crb_cm"] < 1e4
    stored = json.loads((out / "ceiling.json").read_text())
    assert stored["posture_accuracy"] == c["posture_accuracy"] and len(stored["indices"]) == 1
    from nlos_spotlight.fit.train import heldout_indices

    assert stored["indices"] == heldout_indices(out, TINY)[:1]
    assert "The room&#x27;s ceiling" in (out / "report.html").read_text() or \
        "The room's ceiling" in (out / "report.html").read_text()


def test_report_lays_out_in_a_browser(fitted, check_in_browser):
    """The room model's report as headless Chromium lays it out: the spot table and four figures."""
    got = check_in_browser(fitted[0] / "report.html")
    assert len(got["images"]) == 4 and "Where to aim the projector" in got["headings"]


def test_heldout_scores_are_the_networks(fitted):
    """report.json's error is the mean distance between the saved predictions and the truth."""
    out, report = fitted
    hp = np.load(out / "train" / "heldout.npz")
    err = 100 * np.linalg.norm(hp["pred_xy"] - hp["true_xy"], axis=1).mean()
    assert report["heldout"]["error_cm"] == pytest.approx(err, rel=1e-6)
    assert report["heldout"]["posture_accuracy"] == pytest.approx(np.mean(hp["pred_posture"] == hp["true_posture"]))


def test_predict_reads_the_room_model(fitted, tmp_path, capsys):
    """A simulated burst of a held-out person through ``nlos predict ROOM_MODEL``: the room frame
    is the network's frame moved onto the hidden region (closed form)."""
    out, report = fitted
    hp = np.load(out / "train" / "heldout.npz")
    img, bg = hp["photo_image"], hp["photo_background"]
    k = int(np.flatnonzero(~np.isnan(img[:, 0, 0, 0]))[0])
    np.save(tmp_path / "burst.npy", np.stack([img[k]] * 2))
    np.save(tmp_path / "empty.npy", bg[k])
    assert main(["predict", str(out), str(tmp_path / "burst.npy"), "--background", str(tmp_path / "empty.npy"),
                 "--burst", "2", "--json", str(tmp_path / "p.json")]) == 0
    said = capsys.readouterr().out
    assert "room model" in said and f"bursts of {TINY.burst_frames}" in said
    frame = json.loads((tmp_path / "p.json").read_text())["frames"][0]
    hr = report["room"]["hidden_region"]
    center = (np.array(hr["min"]) + np.array(hr["max"])) / 2
    room = np.array([frame["x_room_m"], frame["y_room_m"]])
    assert np.linalg.norm(room - center) == pytest.approx(np.hypot(frame["x_m"], frame["y_m"]), abs=1e-6)


def test_predict_averages_the_room_models_burst_by_default(fitted, tmp_path, capsys):
    """Without --burst, frames that split into the room model's burst are averaged in it (a still
    person's capture), and a frame count that does not is read frame by frame, saying so."""
    out, _ = fitted
    hp = np.load(out / "train" / "heldout.npz")
    img, bg = hp["photo_image"], hp["photo_background"]
    k = int(np.flatnonzero(~np.isnan(img[:, 0, 0, 0]))[0])
    n = TINY.burst_frames
    np.save(tmp_path / "empty.npy", bg[k])
    np.save(tmp_path / "two.npy", np.stack([img[k]] * (2 * n)))
    assert main(["predict", str(out), str(tmp_path / "two.npy"), "--background", str(tmp_path / "empty.npy"),
                 "--json", str(tmp_path / "p.json")]) == 0
    said = " ".join(capsys.readouterr().out.split())
    assert f"averaging consecutive bursts of {n} frames" in said
    assert len(json.loads((tmp_path / "p.json").read_text())["frames"]) == 2
    np.save(tmp_path / "odd.npy", np.stack([img[k]] * (n + 1)))
    assert main(["predict", str(out), str(tmp_path / "odd.npy"), "--background", str(tmp_path / "empty.npy"),
                 "--json", str(tmp_path / "q.json")]) == 0
    said = " ".join(capsys.readouterr().out.split())
    assert f"{n + 1} frames read in bursts of 1 (not a multiple of {n})" in said
    assert len(json.loads((tmp_path / "q.json").read_text())["frames"]) == n + 1


def test_predict_reports_the_drift(fitted, tmp_path, capsys):
    """A room model trained under drift (the default, tripod) reports per capture what changed since
    the empty-room burst: a capture with the projector 5% brighter is flagged on the projector
    (estimated to within a tenth), the photograph as taken is not."""
    out, _ = fitted
    hp = np.load(out / "train" / "heldout.npz")
    img, bg = hp["photo_image"], hp["photo_background"]
    k = int(np.flatnonzero(~np.isnan(img[:, 0, 0, 0]))[0])
    from nlos_spotlight.train.checkpoint import load_trained

    frac = load_trained(out).net.nuisance.fraction.numpy()
    brighter = img[k] + 0.05 * bg[k] * frac
    np.save(tmp_path / "two.npy", np.stack([img[k], brighter]))
    np.save(tmp_path / "empty.npy", bg[k])
    assert main(["predict", str(out), str(tmp_path / "two.npy"), "--background", str(tmp_path / "empty.npy"),
                 "--json", str(tmp_path / "p.json"), "--csv", str(tmp_path / "p.csv")]) == 0
    said = capsys.readouterr().out
    assert "1 of 2 captures beyond what the room model tolerates" in " ".join(said.split())
    frames = json.loads((tmp_path / "p.json").read_text())["frames"]
    assert not frames[0]["drift"]["flagged"] and frames[1]["drift"]["flagged"]
    assert frames[1]["drift"]["projector"] - frames[0]["drift"]["projector"] == pytest.approx(0.05, rel=0.1)
    assert "drift_projector" in (tmp_path / "p.csv").read_text().splitlines()[0]


def test_the_drift_fit_holds_the_training_peoples_light(fitted, room_dir, tmp_path, capsys):
    """The room model's drift fit holds its training people's light directions: the first is their
    mean light over the room's (the held-out people left out), and a room model fitted before the
    directions existed gains them on --resume, the network unchanged."""
    import shutil

    import torch

    from nlos_spotlight.fit.train import keep_person_light, room_layers, room_split
    from nlos_spotlight.models.nuisance import PERSON_DIRECTIONS
    from nlos_spotlight.train.checkpoint import load_trained, read_checkpoint
    from nlos_spotlight.train.imaging import form_parts

    out, report = fitted
    nui = load_trained(out).net.nuisance
    assert nui.person.shape == (PERSON_DIRECTIONS, *nui.fraction.shape)
    spot = int(report["spot"]["face"])
    split = room_split(out, TINY, ["normals"], shadow_spot=spot)
    total = sum(room_layers(out, report["spot"]["aim"]).nominal())
    y = torch.zeros(split.pool.u.shape[1])
    y[spot] = 1

    def mean_direction(s):
        lit, amb, _ = form_parts(s, torch.arange(s.num_samples), y)
        m = ((lit + amb).double() / total.double()).mean(0)
        return (m / m.norm()).float()

    assert torch.allclose(nui.person[0], mean_direction(split.pool), atol=1e-6)
    assert not torch.allclose(nui.person[0], mean_direction(split.test), atol=1e-4)
    old = tmp_path / "old"
    shutil.copytree(out, old)
    st = read_checkpoint(old / "final.pt")
    del st["net"]["nuisance.person"]
    torch.save(st, old / "final.pt")
    assert load_trained(old).net.nuisance.person.numel() == 0
    hp = np.load(out / "train" / "heldout.npz")
    k = int(np.flatnonzero(~np.isnan(hp["photo_image"][:, 0, 0, 0]))[0])
    np.save(tmp_path / "one.npy", hp["photo_image"][k][None])
    np.save(tmp_path / "empty.npy", hp["photo_background"][k])
    capsys.readouterr()
    assert main(["predict", str(old), str(tmp_path / "one.npy"), "--background", str(tmp_path / "empty.npy")]) == 0
    assert "predates the drift fit's people directions" in " ".join(capsys.readouterr().out.split())
    fit_room(str(room_dir), old, TINY, {}, resume=True, progress=False)
    again = load_trained(old).net
    assert torch.equal(again.nuisance.person, nui.person)
    assert not keep_person_light(old / "final.pt", split.pool, spot, None)  # once only


def test_people_from_another_fit(fitted, room_dir, tmp_path):
    """--people-from trains on another room model's rendered people (hard links, nothing rendered
    again) under another capture preset; a fit with other people settings is refused, leaving nothing."""
    import dataclasses

    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.train.checkpoint import load_trained

    src, _ = fitted
    out = tmp_path / "ideal"
    report = fit_room(str(room_dir), out, dataclasses.replace(TINY, capture_preset="ideal"), {}, progress=False,
                      people_from=src)
    assert report["heldout"]["people"] == TINY.heldout
    a, b = sorted((src / "data").rglob("images/*.npz"))[0], sorted((out / "data").rglob("images/*.npz"))[0]
    assert a.stat().st_ino == b.stat().st_ino
    a, b = sorted((src / "shadow").glob("block-*.npz")), sorted((out / "shadow").glob("block-*.npz"))
    assert a and [p.stat().st_ino for p in a] == [p.stat().st_ino for p in b]  # same spot: nothing rendered again
    assert load_trained(out).net.nuisance is None and load_trained(src).net.nuisance is not None
    from nlos_spotlight.fit.ceiling import room_ceiling  # kept, and what computing it again gives

    kept = json.loads((out / "ceiling.json").read_text())
    assert (out / "ceiling.json").stat().st_mtime_ns == (src / "ceiling.json").stat().st_mtime_ns  # copied, not computed
    assert kept == json.loads((src / "ceiling.json").read_text()) and report["ceiling"]["people"] == TINY.ceiling_people
    again = room_ceiling(out, dataclasses.replace(TINY, capture_preset="ideal"), report["spot"], progress=False)
    for k in ("posture_accuracy_known", "posture_accuracy", "position_crb_cm"):
        assert again[k] == pytest.approx(kept[k], rel=1e-6), k
    with pytest.raises(NlosError, match="differs in: people"):
        fit_room(str(room_dir), tmp_path / "other", dataclasses.replace(TINY, people=TINY.people + 1), {},
                 progress=False, people_from=src)
    assert not (tmp_path / "other").exists()


def test_resume_redoes_nothing(fitted, room_dir):
    out, report = fitted
    stamps = {p: p.stat().st_mtime_ns for p in (out / "data").rglob("*.npz")}
    again = fit_room(str(room_dir), out, TINY, {}, resume=True, progress=False)
    assert again["heldout"] == report["heldout"]
    assert {p: p.stat().st_mtime_ns for p in (out / "data").rglob("*.npz")} == stamps


def test_two_processes_render_what_one_does(room_dir):
    """Image samples split over processes (``SceneBuilder.build(part=...)``) are byte-identical; the
    second process reports its own peak memory as it ends (``fit.run.WORKER_PEAKS_MB``)."""
    from nlos_spotlight.fit.run import WORKER_PEAKS_MB

    cfg = dataclasses.replace(TINY, people=6, heldout=1)
    sums, saved = [], list(WORKER_PEAKS_MB)
    try:
        for workers in (1, 2):
            WORKER_PEAKS_MB.clear()
            data = room_dir.parent / f"w{workers}"  # the room is named relative to the data: ../example
            render_people(dataset_config(cfg, room_dir), data, workers, progress=False)
            sums.append(json.loads((data / "manifest.json").read_text())["content_sha256"])
        assert len(WORKER_PEAKS_MB) == 1 and WORKER_PEAKS_MB[0] > 50  # the one spawned process
    finally:
        WORKER_PEAKS_MB[:] = saved
    assert sums[0] == sums[1]


def test_bare_scan_with_flags(room_dir, tmp_path, capsys):
    """A bare PLY (no colors: the documented gray) and the documented flags alone, from the CLI (the
    room's reading is checked: the shadow, bounce and ceiling steps are left to the fits above)."""
    from nlos_spotlight.scene.io import load_scene
    from nlos_spotlight.scene.meshio import save_mesh

    mesh = load_scene(room_dir).static_mesh()[0]
    save_mesh(dataclasses.replace(mesh, vertex_colors=None, face_colors=None), tmp_path / "scan.ply")
    cfg = ["--preset", "tiny", "--people", "12", "--quiet", "--ceiling", "0", "--shadow-samples", "0", "--bounce", "off"]
    args = ["fit", str(tmp_path / "scan.ply"), "--out", str(tmp_path / "m"), "--up", "z",
            "--camera-position", "-1.6,3.2,1.5", "--camera-look-at", "-0.5,0,1.0", "--projector-position",
            "-1.3,3.2,1.3", "--hidden-region", "0.3,1.0,2.5,3.5"]
    assert main(args + cfg) == 0, capsys.readouterr().err
    rec = json.loads((tmp_path / "m" / "room.json").read_text())
    assert rec["materials"].startswith("no colors") and rec["hidden_region"]["source"] == "flags"
    assert rec["hidden_region"]["floor_z"] == pytest.approx(0.0, abs=1e-9)


def _fails(capsys, argv, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err and "Traceback" not in err, err
    for w in words:
        assert w in err, err


def test_error_paths(room_dir, fitted, tmp_path, capsys):
    out, _ = fitted
    q = ["--preset", "tiny", "--quiet"]
    _fails(capsys, ["fit", str(tmp_path / "nothing.ply"), "--out", str(tmp_path / "a")] + q, "nothing.ply")
    _fails(capsys, ["fit", str(room_dir), "--out", str(tmp_path / "b"), "--hidden-region", "-2,1,-1,2"] + q,
           "not hidden", "%")
    _fails(capsys, ["fit", str(room_dir), "--out", str(tmp_path / "c"), "--hidden-region", "1,2,0,3"] + q,
           "--hidden-region")
    _fails(capsys, ["fit", str(room_dir), "--out", str(tmp_path / "c"), "--hidden-region", "3,1,4,2"] + q,
           "may stand on only 0.0%")  # beyond the room's floor: hidden, but nowhere to stand
    _fails(capsys, ["fit", str(room_dir), "--out", str(tmp_path / "d"), "--policy", "ien"] + q, "--checkpoint")
    _fails(capsys, ["fit", str(room_dir), "--out", str(tmp_path / "e"), "--people", "0"] + q, "people")
    _fails(capsys, ["fit", str(room_dir), "--out", str(out)] + q, "--resume")
    _fails(capsys, ["fit", str(room_dir), "--out", str(out), "--resume", "--seed", "3"] + q, "seed")
    (tmp_path / "file").write_text("x")
    _fails(capsys, ["fit", str(room_dir), "--out", str(tmp_path / "file")] + q, "file")
    assert not (tmp_path / "b").exists() and not (tmp_path / "c").exists()  # refused input leaves nothing


def test_a_process_reads_its_own_peak_memory_not_its_parents():
    """``own_peak_mb``: a process started by ``spawn`` from a parent holding 1 GiB reads its own
    peak (an interpreter with torch: a few hundred MB), though ``ru_maxrss`` there counts the
    parent's peak; a child that holds 3 GiB reads about that; ``peak_memory_mb`` is this process's
    own figure since ``reset_peak`` and its rendering processes' largest report."""
    import multiprocessing as mp
    import subprocess
    import sys
    from concurrent.futures import ProcessPoolExecutor

    from nlos_spotlight.fit import run

    held = np.ones(2 ** 27)  # 1 GiB in this process, touched
    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
        small = pool.submit(run.own_peak_mb).result()
    assert held.sum() == 2 ** 27 and 5 < small < 800, small  # the parent's 1 GiB not counted
    del held
    code = "import numpy as np; from nlos_spotlight.fit.run import own_peak_mb; a = np.ones(3 * 2 ** 27); print(own_peak_mb())"
    big = float(subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout)
    assert 3072 <= big < 3072 + 400  # the array and an interpreter with numpy
    saved = list(run.WORKER_PEAKS_MB)
    try:
        run.WORKER_PEAKS_MB[:] = [big, small]
        mem = run.peak_memory_mb()
        assert mem["rendering_process"] == round(big) and 50 < mem["fit_process"] <= _high_water_mb() + 1
        before = _high_water_mb()  # held the 1 GiB array, since freed
        run.reset_peak()  # a fit's own peak starts again from this process's present size
        assert run.own_peak_mb() < before - 512
        run.WORKER_PEAKS_MB.clear()
        assert run.peak_memory_mb()["rendering_process"] is None  # started none
    finally:
        run.WORKER_PEAKS_MB[:] = saved


def test_auto_workers_follows_the_cores_and_the_memory():
    """``--workers 0`` (the default): one process a core, no more than the memory holds at
    ``WORKER_BYTES`` each, at least one; a given count stands; one process on a GPU."""
    from nlos_spotlight.fit.config import WORKER_BYTES, auto_workers

    assert FitConfig().workers == 0
    assert auto_workers(0, cores=16, available_bytes=100e9) == 16
    assert auto_workers(0, cores=16, available_bytes=4.5 * WORKER_BYTES) == 4  # memory binds
    assert auto_workers(0, cores=2, available_bytes=0.5 * WORKER_BYTES) == 1  # never none
    assert auto_workers(0, cores=2, available_bytes=None) == 2  # memory unknown: the cores
    assert auto_workers(3, cores=16, available_bytes=100e9) == 3
    assert 1 <= auto_workers(0) <= os.cpu_count()  # this machine
    for bad in (-1, 257, 1.5, True):
        with pytest.raises(Exception, match="workers"):
            FitConfig(workers=bad)


def test_config_checks():
    with pytest.raises(Exception, match="policy"):
        FitConfig(policy="nearest")
    with pytest.raises(Exception, match="absurd"):
        FitConfig(people=10**7)
    with pytest.raises(Exception, match="2\\^63"):  # refused before anything renders
        FitConfig(seed=2**64)
    assert PRESETS["default"].samples == 24 + 3000 + 200
    for bad in ({"bounce_scale": 0.0}, {"bounce_scale": float("nan")}, {"bounce_scale": 11.0}):
        with pytest.raises(Exception, match="--bounce-scale"):
            with_fields(FitConfig(), **bad)
    for bad in ({"shadow_depth": 3}, {"shadow_depth": 17}, {"shadow_depth": 6.0}, {"shadow_depth": True}):
        with pytest.raises(Exception, match="--shadow-depth"):
            with_fields(FitConfig(), **bad)
    for bad in (0.0, -1.0, float("nan"), float("inf"), 1e6, True):
        with pytest.raises(Exception, match="--epochs"):
            FitConfig(epochs=bad)
    from nlos_spotlight.cli import _fit_flags, build_parser

    args = build_parser().parse_args(["fit", "room.ply", "--out", "o", "--epochs", "120"])
    assert _fit_flags(args)["epochs"] == 120.0 and "epochs" not in _fit_flags(build_parser().parse_args(["fit", "r", "--out", "o"]))
    assert FitConfig().shadow.shadow_depth == 10  # the room's later relays of the spot's light, which the body stops too
    no_shadow = with_fields(FitConfig(), shadow_samples=0, bounce=False).to_dict()  # moot without the shadow: as before it
    assert no_shadow["shadow"]["shadow_depth"] == BEFORE["shadow_depth"] == 4
    from nlos_spotlight.render.bounce import BOUNCE_TAIL

    cfg = FitConfig()  # the default recipe trains on every later bounce, as Mitsuba measures them
    assert cfg.bounce and cfg.bounce_scale == BOUNCE_TAIL and cfg.shadow.bounce_body_samples > 0
    off = FitConfig(bounce=False, bounce_scale=3.0).to_dict()  # moot without the bounce: recorded as before it
    assert off["bounce_scale"] == BEFORE["bounce_scale"] and off["shadow"]["bounce_body_samples"] == BEFORE["bounce_body_samples"]
    assert dataclasses.replace(FitConfig(bounce=False), bounce=True).bounce_scale == BOUNCE_TAIL
    with pytest.raises(Exception, match="add --bounce off"):  # the bounce goes through the shadow's relay points
        with_fields(FitConfig(), shadow_samples=0)
    assert not with_fields(FitConfig(), shadow_samples=0, bounce=False).bounce
    with pytest.raises(Exception, match="bounce_body_samples"):
        with_fields(FitConfig(), bounce_body_samples=-1)


def test_deeply_nested_scene_is_one_line(tmp_path, capsys):
    d = tmp_path / "deep"
    d.mkdir()
    (d / "scene.json").write_text("[" * 100_000 + "]" * 100_000)
    _fails(capsys, ["fit", str(d), "--out", str(tmp_path / "m"), "--preset", "tiny", "--quiet"], "nested too deeply")
    assert not (tmp_path / "m").exists()


def test_ien_policy_uses_the_checkpoints_choice(toy_scene, room_dir, tmp_path):
    """--policy ien: the spot is the trained IEN's most probable reachable candidate of the room,
    stored for the image samples, and the one the network is trained and scored under."""
    import torch

    from nlos_spotlight.scene.los import los_mesh
    from nlos_spotlight.fit.spot import ien_face
    from nlos_spotlight.render.surface import StaticSurfaces
    from nlos_spotlight.scene.io import load_scene
    from nlos_spotlight.train.checkpoint import load_trained
    from nlos_spotlight.train.config import TrainConfig
    from nlos_spotlight.train.loop import Trainer

    tr = Trainer(TrainConfig(), [toy_scene(n=8, res=8)], tmp_path)
    with torch.no_grad():  # spread-out logits, so the choice is not a tie
        for m in tr.ien.modules():
            if isinstance(m, torch.nn.Linear):
                torch.nn.init.normal_(m.weight, 0.0, 2.0 / m.in_features ** 0.5)
    tr.save(tmp_path / "final.pt")
    cfg = dataclasses.replace(TINY, people=12, heldout=3, policy="ien", checkpoint=str(tmp_path / "final.pt"))
    report = fit_room(str(room_dir), tmp_path / "m", cfg, {}, progress=False)
    scene = load_scene(tmp_path / "m" / "room")
    surf = StaticSurfaces(scene)
    los = los_mesh(surf.mesh, surf.engine, scene.camera, cfg.los_vertices)
    face = ien_face(load_trained(tmp_path / "final.pt"), scene, los)
    stored = json.loads(next((tmp_path / "m" / "data" / "scenes").iterdir()).joinpath("spots.json").read_text())
    assert report["spot"]["face"] == face and face in stored["spots"]


def test_killed_fit_resumes_to_the_same_model(fitted, room_dir, tmp_path):
    """Kill a two-process fit while it renders, rerun with --resume: the people and the scores are
    those of the uninterrupted one-process fit (nothing lost, nothing rendered twice differently)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    out, report = fitted
    dest = tmp_path / "killed"
    code = ("import sys, json; from nlos_spotlight.fit.config import FitConfig; "
            "from nlos_spotlight.fit.run import fit_room; "
            "fit_room(sys.argv[3], sys.argv[1], FitConfig(**json.loads(sys.argv[2])), {}, resume=True, progress=False)")
    two = dataclasses.replace(TINY, workers=2, ceiling_people=0)  # the ceiling: not compared
    cmd = [sys.executable, "-c", code, str(dest), json.dumps(two.to_dict()), str(room_dir)]
    env = {**os.environ, "NLOS_QUIET": "1"}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 300
    while time.time() < deadline and len(list(dest.glob("data/scenes/*/images/*.npz"))) < 3 and proc.poll() is None:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # the fit and its rendering process
    proc.wait()
    assert not (dest / "report.json").exists(), "killed too late to test resuming"
    fit_room(str(room_dir), dest, two, {}, resume=True, progress=False)  # in this process: ~5 s of imports less
    sha = lambda d: json.loads((d / "data" / "manifest.json").read_text())["content_sha256"]
    assert sha(dest) == sha(out)
    resumed = json.loads((dest / "report.json").read_text())
    assert resumed["heldout"] == report["heldout"]
    # the resumed fit's shadow step ran in a pool of two: each reported its own peak (ru_maxrss would
    # read at least this process's size at the fork)
    assert 50 < resumed["peak_memory_mb"]["rendering_process"] < _high_water_mb()


def test_shadow_step_stores_each_persons_blocked_light(fitted):
    """``ROOM_MODEL/shadow/`` holds every image sample's ``nlos_shadow`` under the chosen spot, in
    sample order: a person rendered again directly gives its block's image (float16 storage)."""
    from nlos_spotlight.data.generate import plan
    from nlos_spotlight.data.scene_builder import SceneBuilder
    from nlos_spotlight.fit.shadow import load_shadows, relay_offsets
    from nlos_spotlight.render.settings import RenderSettings

    out, report = fitted
    sh = load_shadows(out, TINY)
    assert sh.shape[0] == TINY.samples - TINY.transport_people and (sh <= 0).all() and (sh < 0).any()
    meta = json.loads((out / "shadow" / "meta.json").read_text())
    assert meta["face"] == report["spot"]["face"] and meta["shadow_samples"] == TINY.shadow.shadow_samples
    dcfg = dataclasses.replace(dataset_config(TINY, out / "room"), room=str((out / "room").resolve()))
    k = int(np.argmin(sh.reshape(len(sh), -1).sum(1)))  # the person who blocks the most
    settings = RenderSettings(pixel_samples=TINY.render.pixel_samples, pixel_footprint=TINY.render.pixel_footprint,
                              spot_samples=TINY.render.spot_samples, person_samples=TINY.render.person_samples,
                              shadow_samples=TINY.shadow.shadow_samples, shadow_depth=TINY.shadow.shadow_depth,
                              device="cpu")
    idx = [TINY.transport_people + k]
    offsets = relay_offsets(idx, TINY)  # each person's own relay points
    assert meta["shadow_relay"] == "per-person" and offsets is not None
    again = SceneBuilder(dcfg, plan(dcfg)[0], out / "data").rerender(
        idx, settings, np.asarray(report["spot"]["aim"]), ("nlos_shadow",), offsets)["nlos_shadow"][0]
    np.testing.assert_allclose(sh[k], again, rtol=2e-3, atol=2e-3 * np.abs(again).max())


def test_rerender_in_another_world_keeps_the_scans_people(fitted, monkeypatch):
    """A world that differs from the scan (camera turned, walls jittered) changes where people may
    stand; ``rerender(world=...)`` must still render the dataset's people (drawn in the scan), or
    the labels belong to other people (the robustness benchmark's world rows read 36% and 96% of
    them wrong before)."""
    from nlos_spotlight.data.generate import plan
    from nlos_spotlight.data.scene_builder import SceneBuilder
    from nlos_spotlight.render.settings import RenderSettings
    from nlos_spotlight.render.variation import preset
    from nlos_spotlight.world.mismatch import mismatched_world

    out, report = fitted
    dcfg = dataclasses.replace(dataset_config(TINY, out / "room"), room=str((out / "room").resolve()))
    builder = SceneBuilder(dcfg, plan(dcfg)[0], out / "data")
    scan = builder.room_scene()
    world, aim, _ = mismatched_world(scan, np.asarray(report["spot"]["aim"]),
                                     preset("tripod").only("camera-pose", "geometry").scaled(8), 3)
    moved = [s["position"] for s in builder._specs(world)]
    drawn = [s["position"] for s in builder._specs(scan)]
    assert not all(np.allclose(a, b) for a, b in zip(moved, drawn)), "the world no longer moves the draw: test is vacuous"
    seen = []
    real = SceneBuilder._person
    monkeypatch.setattr(SceneBuilder, "_person", lambda self, spec, z: seen.append(spec["position"]) or real(self, spec, z))
    idx = list(range(TINY.transport_people, TINY.samples))[:6]
    settings = RenderSettings(pixel_samples=1, spot_samples=8, person_samples=32, device="cpu")
    builder.rerender(idx, settings, aim, ("nlos",), world=world)
    np.testing.assert_array_equal(np.stack(seen), np.stack([drawn[k] for k in idx]))


def test_world_variation_trains_on_each_person_in_a_drawn_world(fitted, tmp_path):
    """``world_variation`` 'tripod': each shadow block holds its people's whole light under the spot
    rendered in drawn worlds (a person of relay set j in world [seed, stream, block, j], equal to
    rendering it there directly), not the scan's light; training reads exactly that light in
    place of the dataset's (``with_shadow``)."""
    import shutil

    import torch

    from nlos_spotlight.data.generate import plan
    from nlos_spotlight.data.scene_builder import SceneBuilder
    from nlos_spotlight.fit.shadow import (RELAY_SETS, WORLD_COMPONENTS, WORLD_STREAM, _render_block,
                                           load_block_light, relay_offsets)
    from nlos_spotlight.fit.train import with_shadow
    from nlos_spotlight.data.tensors import load_split
    from nlos_spotlight.render.settings import RenderSettings
    from nlos_spotlight.render.variation import preset
    from nlos_spotlight.world.mismatch import mismatched_world

    out, report = fitted
    dest = tmp_path / "model"
    shutil.copytree(out, dest)
    cfg = dataclasses.replace(TINY, world_variation="tripod")
    aim = np.asarray(report["spot"]["aim"])
    first = list(range(TINY.transport_people, TINY.samples))
    for b in range(0, len(first), 100):  # every block, as the step renders them
        _render_block(str(dest), cfg.to_dict(), aim.tolist(), b // 100, first[b:b + 100])
    got = load_block_light(dest, cfg)
    assert set(got) == {*WORLD_COMPONENTS, "nlos_bounce"} and all(len(v) == len(first) for v in got.values())
    dcfg = dataclasses.replace(dataset_config(TINY, dest / "room"), room=str((dest / "room").resolve()))
    builder = SceneBuilder(dcfg, plan(dcfg)[0], dest / "data")
    settings = RenderSettings(pixel_samples=TINY.render.pixel_samples, pixel_footprint=TINY.render.pixel_footprint,
                              spot_samples=TINY.render.spot_samples, person_samples=TINY.render.person_samples,
                              shadow_samples=TINY.shadow.shadow_samples, shadow_depth=TINY.shadow.shadow_depth,
                              device="cpu")
    i = 3
    k = first[i]
    world, world_aim, drawn = mismatched_world(builder.room_scene(), aim, preset("tripod").world_effects,
                                               [TINY.seed, WORLD_STREAM, 0, k % RELAY_SETS])
    assert set(drawn) >= {"camera_deg", "projector_deg", "albedo_factor", "geometry_m"}
    again = builder.rerender([k], settings, world_aim, (*WORLD_COMPONENTS, "nlos_bounce"), relay_offsets([k], cfg),
                             world=world)
    for c in (*WORLD_COMPONENTS, "nlos_bounce"):  # float16 storage; the bounce in the same world
        np.testing.assert_allclose(got[c][i], again[c][0], rtol=2e-3, atol=2e-3 * np.abs(again[c][0]).max())
    scan = builder.rerender([k], settings, aim, ("nlos",))["nlos"][0]
    assert np.linalg.norm(got["nlos"][i] - scan) > 0.01 * np.linalg.norm(scan), "the world is the scan"
    s, = load_split(dest / "data", "train", ["normals"], samples="images")
    face = report["spot"]["face"]
    w = with_shadow(s, dest, cfg, face)
    y = torch.zeros(w.u.shape[1])
    y[face] = 1
    light = torch.einsum("t,btr,brhwc->bhwc", y, w.u, w.v)
    np.testing.assert_allclose(light.numpy(), got["nlos"], rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(w.nlos_ambient.numpy(), got["nlos_ambient"], rtol=1e-6, atol=1e-12)


def test_a_fit_recorded_before_a_setting_existed_resumes(fitted, tmp_path):
    """A ``fit.json`` written before a setting existed resumes under today's defaults where the
    setting keeps that version's behaviour (``config.BEFORE``), and is refused where it does not."""
    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.fit.run import check_out

    out, _ = fitted
    rec = json.loads((out / "fit.json").read_text())
    # as a record before the sampling blocks: flat, without the dataset's sampling it did not record
    flat = {k: v for k, v in flatten(FitConfig, rec["settings"]).items()
            if k not in ("pixel_samples", "transport_pixel_samples", "spot_samples")}
    assert FitConfig.from_record(flat) == FitConfig.from_record(rec["settings"])
    old = dict(rec, settings={k: v for k, v in flat.items() if k != "world_variation"})
    (tmp_path / "fit.json").write_text(json.dumps(old))
    check_out(tmp_path, rec, resume=True)  # world_variation 'ideal' then and now
    old = dict(rec, settings={k: v for k, v in flat.items() if k != "pixel_footprint"})
    (tmp_path / "fit.json").write_text(json.dumps(old))
    with pytest.raises(NlosError, match="differs in: pixel_footprint"):
        check_out(tmp_path, rec, resume=True)  # at the pixel's centre then, a footprint now
    # a model of the recipe before the bounce: refused under today's default (the bounce), and
    # resumed with --bounce off alone (its moot settings recorded as before them)
    old = dict(rec, settings={k: v for k, v in flat.items() if not k.startswith("bounce")})
    (tmp_path / "fit.json").write_text(json.dumps(old))
    with pytest.raises(NlosError, match="differs in: bounce.*resumes with the flags it had"):
        check_out(tmp_path, rec, resume=True)
    off = dataclasses.replace(FitConfig.from_record(rec["settings"]), bounce=False).to_dict()
    check_out(tmp_path, dict(rec, settings={**rec["settings"], **off}), resume=True)


def test_a_fit_refused_before_any_person_leaves_nothing(room_dir, tmp_path, monkeypatch, capsys):
    """A fit refused after its room step, before any person is rendered, removes what it wrote, so
    that the corrected rerun (other settings) is not refused (issue 36, item 4); one refused with
    people rendered keeps them for --resume."""
    import nlos_spotlight.fit.run as run
    from nlos_spotlight.errors import NlosError

    def refuse(dcfg, data, workers, progress, device="cpu"):
        raise NlosError("camera: sees no geometry")

    monkeypatch.setattr(run, "render_people", refuse)
    _fails(capsys, ["fit", str(room_dir), "--out", str(tmp_path / "m"), "--preset", "tiny", "--quiet"],
           "sees no geometry", "nothing was kept")
    assert not (tmp_path / "m").exists()

    def half(dcfg, data, workers, progress, device="cpu"):
        (data / "scenes").mkdir(parents=True)
        (data / "scenes" / "sample-00000.npz").write_bytes(b"finished work")
        raise NlosError("a rendering process failed")

    monkeypatch.setattr(run, "render_people", half)
    _fails(capsys, ["fit", str(room_dir), "--out", str(tmp_path / "m"), "--preset", "tiny", "--quiet"], "failed")
    assert (tmp_path / "m" / "data" / "scenes" / "sample-00000.npz").exists()


def test_generate_refuses_a_bad_room_or_family_before_writing(tmp_path, capsys):
    """``families: [nope]`` and ``room: /etc`` are refused with nothing written (issue 36, item 4)."""
    (tmp_path / "fam.yaml").write_text("families: [nope]\n")
    (tmp_path / "room.yaml").write_text(f"room: {tmp_path / 'elsewhere'}\n")
    _fails(capsys, ["generate", str(tmp_path / "fam.yaml"), "--out", str(tmp_path / "a"), "--quiet"], "nope")
    _fails(capsys, ["generate", str(tmp_path / "room.yaml"), "--out", str(tmp_path / "b"), "--quiet"], "elsewhere")
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_projector_that_lights_nothing_in_view_is_refused(room_dir, tmp_path, capsys):
    """Behind the relay wall, the projector lights none of what the camera sees (issue 36, item 3)."""
    _fails(capsys, ["fit", str(room_dir), "--out", str(tmp_path / "m"), "--projector-position", "0,-1,1",
                    "--preset", "tiny", "--quiet"], "reaches none of the surfaces the camera photographs")
    assert not (tmp_path / "m").exists()


def test_a_second_fit_into_the_same_out_is_refused(room_dir, tmp_path, capsys):
    """While one fit holds ``--out`` (its lock), another is refused in one line naming it (issue 36,
    item 14); the lock goes with the process, so a later fit proceeds."""
    import subprocess
    import sys
    import time

    out = tmp_path / "m"
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time; from pathlib import Path; from nlos_spotlight.fit.run import out_lock\n"
        f"with out_lock(Path({str(out)!r})):\n    print('locked', flush=True); time.sleep(60)")],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        _fails(capsys, ["fit", str(room_dir), "--out", str(out), "--preset", "tiny", "--quiet"],
               "another nlos fit", str(holder.pid))
        assert out.exists()  # the running fit's directory is left alone
    finally:
        holder.kill()
        holder.wait()
    time.sleep(0.1)
    from nlos_spotlight.fit.run import out_lock

    with out_lock(out):  # released with its process
        pass


@pytest.mark.parametrize("edit,words", [
    (lambda r: r["room"]["hidden_region"].update(min=[float("nan"), 0.0]), "non-finite"),
    (lambda r: r["capture"].update(burst_frames=0), "burst_frames"),
    (lambda r: r["capture"].update(exposure_s=-1), "exposure_s"),
    (lambda r: r["room"]["hidden_region"].update(max=r["room"]["hidden_region"]["min"]), "not a box"),
    (lambda r: r.update(light={"mode": "flash"}), "aims no spot"),
    (lambda r: r.update(light={"mode": "strobe"}), "light must be"),
])
def test_a_hand_edited_report_is_refused(fitted, tmp_path, edit, words):
    """``report.json`` is validated when a room model is loaded (issue 36, item 15); the fit's own loads."""
    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.fit.model import load_room_model

    out, _ = fitted
    assert load_room_model(out).burst_frames == TINY.burst_frames
    d = tmp_path / "model"
    d.mkdir()
    (d / "fit.json").write_text((out / "fit.json").read_text())
    rep = json.loads((out / "report.json").read_text())
    edit(rep)
    (d / "report.json").write_text(json.dumps(rep))  # NaN written as JSON's non-standard NaN, as an editor might
    with pytest.raises(NlosError, match=words):
        load_room_model(d)


def test_predict_refuses_weights_of_another_light(fitted, tmp_path, capsys):
    """A spot room model whose report was swapped for a flash fit's (or the reverse: the weights are
    the other's) is refused by ``nlos predict`` in one line, before any photograph is read."""
    out, _ = fitted
    d = tmp_path / "model"
    d.mkdir()
    for name in ("fit.json", "final.pt"):
        shutil.copy(out / name, d / name)
    rep = json.loads((out / "report.json").read_text())
    rep.update(light={"mode": "flash"}, spot=None)
    (d / "report.json").write_text(json.dumps(rep))
    np.save(tmp_path / "one.npy", np.zeros((8, 8, 3), np.float32))
    _fails(capsys, ["predict", str(d), str(tmp_path / "one.npy")], "trained under a projector spot",
           "the flash at the camera")


def test_jittered_footprint_renders_each_set_of_people_with_its_own_draw(room_dir):
    """``--footprint jittered``: every image sample's light is rendered with its sampling set's
    footprint draw (``data.config.sampling_set``), which ``rerender`` reproduces and the fixed set
    does not; its shadow uses the same camera sub-samples."""
    from nlos_spotlight.data.config import sampling_set
    from nlos_spotlight.data.generate import plan
    from nlos_spotlight.data.scene_builder import SceneBuilder
    from nlos_spotlight.data.store import f16_decode

    cfg = with_fields(TINY, people=10, heldout=1, footprint_jitter=True)
    data = room_dir.parent / "jittered"
    dcfg = dataset_config(cfg, room_dir)
    render_people(dcfg, data, 1, progress=False)
    builder = SceneBuilder(dataclasses.replace(dcfg, room=str(room_dir.resolve())), plan(dcfg)[0], data)
    files = sorted(data.rglob("images/*.npz"))
    idx = [int(f.stem) for f in files[:3]]
    assert len({sampling_set(k) for k in idx}) == 3
    stored = np.stack([f16_decode(np.load(f), "nlos_ambient") for f in files[:3]])
    aim = builder.room_scene().camera.look_at  # nlos_ambient does not depend on the spot
    settings = dcfg.render_settings()
    again = builder.rerender(idx, settings, aim, ("nlos_ambient",))["nlos_ambient"]
    fixed = builder.rerender(idx, dataclasses.replace(settings, footprint_jitter=False), aim, ("nlos_ambient",))["nlos_ambient"]
    for s, a, f in zip(stored, again, fixed):
        scale = np.abs(a).max()
        np.testing.assert_allclose(s, a, rtol=2e-3, atol=2e-3 * scale)
        assert np.abs(s - f).max() > 0.02 * scale


def test_bounce_is_stored_and_trained_on(fitted, room_dir, tmp_path):
    """``--bounce on``: the shadow step stores each person's ``nlos_bounce`` beside its shadow (a person
    rendered again gives its block's image), and training photographs add it scaled with the clothing."""
    import torch

    from nlos_spotlight.data.generate import plan
    from nlos_spotlight.data.scene_builder import SceneBuilder
    from nlos_spotlight.data.tensors import load_split
    from nlos_spotlight.fit.shadow import load_block_light, relay_offsets
    from nlos_spotlight.fit.train import with_shadow
    from nlos_spotlight.train.imaging import form_parts

    src, report = fitted
    cfg = with_fields(TINY, bounce=True, bounce_body_samples=32)  # under the body's 64: resampled
    out = tmp_path / "bounce"
    fit_room(str(room_dir), out, cfg, {}, progress=False, people_from=src)
    got = load_block_light(out, cfg)
    assert set(got) == {"nlos_shadow", "nlos_bounce"} and (got["nlos_bounce"] >= 0).all() and got["nlos_bounce"].max() > 0
    dcfg = dataclasses.replace(dataset_config(cfg, out / "room"), room=str((out / "room").resolve()))
    k = int(np.argmax(got["nlos_bounce"].reshape(len(got["nlos_bounce"]), -1).sum(1)))
    idx = [cfg.transport_people + k]
    settings = dcfg.render_settings(**dataclasses.asdict(cfg.shadow))
    builder = SceneBuilder(dcfg, plan(dcfg)[0], out / "data")
    again = builder.rerender(idx, settings, np.asarray(report["spot"]["aim"]), ("nlos_bounce",),
                             relay_offsets(idx, cfg))["nlos_bounce"][0]
    np.testing.assert_allclose(got["nlos_bounce"][k], again, rtol=2e-3, atol=2e-3 * np.abs(again).max())
    own = builder.rerender(idx, dataclasses.replace(settings, bounce_body_samples=0), np.asarray(report["spot"]["aim"]),
                           ("nlos_bounce",), relay_offsets(idx, cfg))["nlos_bounce"][0]
    assert np.abs(own - again).max() > 1e-3 * np.abs(own).max()  # the 32 samples were used, not the body's own
    s, = load_split(out / "data", "train", [], samples="images")
    s = with_shadow(s, out, dataclasses.replace(cfg, bounce_scale=1.0), report["spot"]["face"])  # as stored
    y = torch.zeros(len(s.faces))
    y[report["spot"]["face"]] = 1.0
    i = torch.tensor([k])
    base = form_parts(s, i, y)[0] - form_parts(dataclasses.replace(s, bounce=None), i, y)[0]
    np.testing.assert_allclose(base[0].numpy(), s.bounce[k].numpy(), rtol=1e-5, atol=1e-9)
    half = form_parts(s, i, y, albedo=s.albedo[i] * 0.5)[0] - form_parts(dataclasses.replace(s, bounce=None), i, y,
                                                                          albedo=s.albedo[i] * 0.5)[0]
    np.testing.assert_allclose(half[0].numpy(), 0.5 * s.bounce[k].numpy(), rtol=1e-4, atol=1e-9)
    tail = with_shadow(load_split(out / "data", "train", [], samples="images")[0], out,
                       dataclasses.replace(cfg, bounce_scale=1.9), report["spot"]["face"])
    np.testing.assert_allclose(tail.bounce[k].numpy(), 1.9 * s.bounce[k].numpy(), rtol=1e-6)  # every later bounce
    meta = json.loads((out / "shadow" / "meta.json").read_text())
    assert meta["bounce_near_field"] == 1.0
    del meta["bounce_near_field"]  # as a fit before the bounce's distance floor wrote it
    (out / "shadow" / "meta.json").write_text(json.dumps(meta))
    stamps = {p: p.stat().st_mtime_ns for p in (out / "shadow").glob("block-*.npz")}
    fit_room(str(room_dir), out, cfg, {}, resume=True, progress=False)  # trained: keeps what it learned on
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps
    meta = json.loads((out / "shadow" / "meta.json").read_text())
    assert meta["bounce_near_field"] == 0.0
    del meta["bounce_near_field"]
    (out / "shadow" / "meta.json").write_text(json.dumps(meta))
    (out / "train" / "result.json").unlink()  # not trained yet: rendered again with the floor
    fit_room(str(room_dir), out, cfg, {}, resume=True, progress=False)
    assert all(p.stat().st_mtime_ns != t for p, t in stamps.items())
    meta = json.loads((out / "shadow" / "meta.json").read_text())
    assert meta["bounce_near_field"] == 1.0 and meta["bounce_body_samples"] == 32
    del meta["bounce_body_samples"]  # as a fit before the bounce's body samples: the body's own quadrature
    (out / "shadow" / "meta.json").write_text(json.dumps(meta))
    stamps = {p: p.stat().st_mtime_ns for p in (out / "shadow").glob("block-*.npz")}
    assert (out / "train" / "result.json").exists()  # the resume above trained it again: it keeps its blocks
    fit_room(str(room_dir), out, cfg, {}, resume=True, progress=False)
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps
    assert json.loads((out / "shadow" / "meta.json").read_text())["bounce_body_samples"] == 0


def test_another_shadow_depth_renders_the_shadow_again_and_keeps_the_rest(fitted, tmp_path, monkeypatch):
    """Another ``--shadow-depth`` renders each block's ``nlos_shadow`` again and keeps its bounce as it
    is (the bounce does not depend on the depth: a person rendered again at the new depth gives both);
    a block the step has not reached yet (also one written before blocks recorded their depth) is
    found on resume, and one whose file is torn is rendered whole."""
    import shutil

    from nlos_spotlight.data.generate import plan
    from nlos_spotlight.data.scene_builder import SceneBuilder
    from nlos_spotlight.data.store import atomic_npz
    from nlos_spotlight.fit import shadow
    from nlos_spotlight.fit.shadow import load_block_light, relay_offsets, render_shadows

    src, report = fitted
    out = tmp_path / "depth"
    shutil.copytree(src, out)
    monkeypatch.setattr(shadow, "BLOCK", 10)  # several blocks, in this process
    d4 = with_fields(TINY, bounce=True, bounce_body_samples=32, shadow_depth=4, workers=1)
    render_shadows(out, d4, report["spot"], progress=False)
    before = load_block_light(out, d4)
    blocks = sorted((out / "shadow").glob("block-*.npz"))
    assert len(blocks) > 2
    with np.load(blocks[0]) as z:
        assert int(z["shadow_depth"]) == 4
        old = {k: z[k] for k in z.files if k != "shadow_depth"}
    atomic_npz(blocks[0], **old)  # as written before blocks recorded their depth
    d10 = with_fields(d4, shadow_depth=10)
    render_shadows(out, d10, report["spot"], progress=False)
    after = load_block_light(out, d10)
    np.testing.assert_array_equal(after["nlos_bounce"], before["nlos_bounce"])  # kept, not rendered again
    dcfg = dataclasses.replace(dataset_config(d10, out / "room"), room=str((out / "room").resolve()))
    k = int(np.argmax(np.abs(after["nlos_shadow"] - before["nlos_shadow"]).reshape(len(after["nlos_shadow"]), -1).sum(1)))
    idx = [d10.transport_people + k]
    settings = dcfg.render_settings(**dataclasses.asdict(d10.shadow))
    again = SceneBuilder(dcfg, plan(dcfg)[0], out / "data").rerender(
        idx, settings, np.asarray(report["spot"]["aim"]), ("nlos_shadow", "nlos_bounce"), relay_offsets(idx, d10))
    for c in ("nlos_shadow", "nlos_bounce"):
        np.testing.assert_allclose(after[c][k], again[c][0], rtol=2e-3, atol=2e-3 * np.abs(again[c][0]).max())
    assert np.abs(after["nlos_shadow"][k] - before["nlos_shadow"][k]).max() > 1e-3 * np.abs(before["nlos_shadow"][k]).max()
    # a fit stopped half-way: one block still at depth 4, another torn
    with np.load(blocks[0]) as z:
        atomic_npz(blocks[0], **{**{k: z[k] for k in z.files}, "shadow_depth": np.asarray(4)})
    blocks[-1].write_bytes(b"torn")
    stamps = {p: p.stat().st_mtime_ns for p in blocks}
    render_shadows(out, d10, report["spot"], progress=False)
    assert [p for p in blocks if p.stat().st_mtime_ns != stamps[p]] == sorted({blocks[0], blocks[-1]})
    again = load_block_light(out, d10)
    for c in ("nlos_shadow", "nlos_bounce"):
        np.testing.assert_allclose(again[c], after[c], rtol=1e-6, atol=1e-9)


def test_method_fits_a_baseline_on_the_same_people(fitted, room_dir, tmp_path):
    """``--method chandran``: Adaptive Lighting's spot and Chandran's CNN fitted on the same rendered
    people (``--people-from``: fixed policies' spots are stored for every person); its checkpoint is
    that network, its report names it; a policy against the method's, or a method that lights no
    spot with the spot's shadow, is refused in one line."""
    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.evaluate.methods import BY_NAME
    from nlos_spotlight.train.checkpoint import load_trained

    src, _ = fitted
    out = tmp_path / "chandran"
    report = fit_room(str(room_dir), out, dataclasses.replace(TINY, method="chandran", policy="adaptive"), {},
                      progress=False, people_from=src)
    assert report["training"]["method"] == "chandran" and report["training"]["policy"] == "adaptive"
    assert report["spot"]["face"] == report["spot_policies"]["policies"]["adaptive"]["face"]
    models = load_trained(out)
    assert models.config.arch == BY_NAME["chandran"].arch == "chandran" and models.config.policy == "adaptive"
    assert "Chandran" in report["training"]["network"]
    for bad in (dict(method="tancik"), dict(method="chandran", policy="oracle"),
                dict(method="ours_task_only")):
        with pytest.raises(NlosError, match="--method"):
            with_fields(TINY, **bad)
    with pytest.raises(NlosError, match="not 'floor_net' \\(FloorNet is the method for rooms nobody fitted"):
        with_fields(TINY, method="floor_net")  # refused with its reason


NO_SPOT = dict(shadow_samples=0, bounce=False, capture_preset="ideal")
"""TINY's settings without a spot term (``fit.config.UNAIMED_DEFAULTS``)."""


@pytest.mark.parametrize("method,light", [("tancik", "flash"), ("dlnlos", "ambient")])
def test_method_without_a_spot_fits_under_its_light(fitted, room_dir, tmp_path, capsys, method, light):
    """``--method tancik`` (the flash) and ``dlnlos`` (projector off) on the same rendered people
    (``--people-from``): the network trains on the light the dataset stores for it, read here from
    the files (the flash's or the room's own person-free light and the person's ``flash_nlos`` /
    ``nlos_ambient``); the held-out empty-room photograph is that light to the noise, not the spot's;
    no spot, shadow or layers, the report says what it left out, the SNR and the ceiling are that
    light's; ``nlos predict`` says what to photograph and reads the model back as it was scored."""
    from nlos_spotlight.data.store import f16_decode
    from nlos_spotlight.fit.train import fit_train_config, room_split
    from nlos_spotlight.lighting.snr import scene_snr
    from nlos_spotlight.train.checkpoint import load_trained
    from nlos_spotlight.train.imaging import capture
    from nlos_spotlight.train.loop import Trainer

    src, spot_report = fitted
    out = tmp_path / method
    cfg = with_fields(TINY, method=method, policy=light, **NO_SPOT)
    report = fit_room(str(room_dir), out, cfg, {}, progress=False, people_from=src)
    a, b = (sorted((d / "data").rglob("images/*.npz"))[0] for d in (src, out))
    assert a.stat().st_ino == b.stat().st_ino  # the spot fit's people, nothing rendered again
    assert report["spot"] is None and report["light"]["mode"] == light
    assert set(report["light"]["not_rendered"]) == {"spot", "layers", "shadow", "bounce"}
    assert not (out / "layers.npz").exists() and not (out / "shadow").exists()
    assert report["training"]["method"] == method and method in report["training"]["network"]
    models = load_trained(out)
    assert (models.config.policy, models.config.arch) == (light, method) and models.net.nuisance is None
    scene = next((out / "data" / "scenes").iterdir())
    with np.load(scene / "static.npz") as z:  # the files, not the loader
        free = z["ambient"] + (z["flash_direct"] if light == "flash" else 0)
        spot_free = z["direct"][spot_report["spot"]["face"]] + z["ambient"]
    # training: the fit's trainer lights the room with that light, and its noise-free photographs
    # are the stored components summed
    split = room_split(out, cfg, ["normals"])
    tr = Trainer(fit_train_config(cfg, out), [split.pool], tmp_path / "tr")
    (y, mode, _), = tr.illuminations(tr.scenes, train=True)
    assert mode == light and y is None
    idx = torch.arange(3)
    ph = capture(tr.scenes[0].to("cpu"), idx, y, mode, tr.sensor, None, False, tr.cfg.net)
    first = cfg.transport_people  # pool people 0..2 are the first image samples (split_room's period)
    for j in idx.tolist():
        with np.load(scene / "images" / f"{first + j:05d}.npz") as z:
            person = f16_decode(z, "nlos_ambient") + (f16_decode(z, "flash_nlos") if light == "flash" else 0)
        np.testing.assert_allclose(ph.images[j].numpy(), free + person, rtol=1e-5, atol=1e-9)
        np.testing.assert_allclose(ph.background[j].numpy(), free, rtol=1e-6)
    # scoring: the held-out empty-room photographs (noisy, a burst; the flash clips a few pixels)
    # are that light to 1% in nearly every pixel, and wherever the spot's differs, that light's
    bg = np.load(out / "train" / "heldout.npz")["photo_background"]
    bg = bg[~np.isnan(bg[:, 0, 0, 0])]
    near = lambda ref: np.abs(bg / ref - 1) < 0.01
    differ = np.abs(spot_free / free - 1) > 0.1
    assert near(free).mean() > 0.95 and differ.sum() >= 10
    assert near(free)[:, differ].mean() > 0.95 and near(spot_free)[:, differ].mean() < 0.05
    # the chosen row is that light's SNR over the best spot's
    snr = scene_snr(next((src / "data" / "scenes").iterdir()))
    sp = report["spot_policies"]
    assert sp["policies"]["chosen"]["light"] == light and sp["policies"]["chosen"]["face"] == -1
    assert sp["policies"]["chosen"]["snr_over_best"] == pytest.approx(
        (snr.flash if light == "flash" else snr.ambient) / sp["best_snr"])
    assert sp["policies"]["oracle"] == spot_report["spot_policies"]["policies"]["oracle"]
    c = report["ceiling"]
    assert c["people"] == TINY.ceiling_people and 0 <= c["posture_accuracy"] <= 1 and c["position_crb_cm"] > 0
    stored = json.loads((out / "ceiling.json").read_text())
    assert stored["key"]["light"] == light
    _ceiling_renders_the_stored_light(out, cfg, scene, light, stored["indices"][0])
    html = (out / "report.html").read_text()
    assert "Light: no spot" in html and "Where to aim the projector" not in html
    again = fit_room(str(room_dir), out, cfg, {}, resume=True, progress=False)
    assert again["heldout"] == report["heldout"] and again["ceiling"] == report["ceiling"]
    # predict: what to photograph, no aim; the evaluation's answer for a held-out person's photograph
    hp = np.load(out / "train" / "heldout.npz")
    k = int(np.flatnonzero(~np.isnan(hp["photo_image"][:, 0, 0, 0]))[0])
    np.save(tmp_path / "one.npy", hp["photo_image"][k][None])
    np.save(tmp_path / "empty.npy", hp["photo_background"][k])
    capsys.readouterr()
    assert main(["predict", str(out), str(tmp_path / "one.npy"), "--background", str(tmp_path / "empty.npy"),
                 "--burst", "1", "--json", str(tmp_path / "p.json")]) == 0
    said = " ".join(capsys.readouterr().out.split())
    assert {"flash": "flash photographs", "ambient": "projector-off photographs"}[light] in said
    assert "pan" not in said and "spot on face" not in said
    frame = json.loads((tmp_path / "p.json").read_text())["frames"][0]
    person = int(np.flatnonzero(np.all(hp["true_xy"] == hp["photo_xy"][k], axis=1))[0])
    assert [frame["x_m"], frame["y_m"]] == pytest.approx(hp["pred_xy"][person].tolist(), abs=1e-4)


def _ceiling_renders_the_stored_light(out, cfg, scene, light: str, i: int) -> None:
    """The ceiling's renderer of a light without a spot gives held-out person ``i``'s light as the
    dataset stored it (``flash_nlos`` + ``nlos_ambient``, or ``nlos_ambient``; float16 with a scale)."""
    from nlos_spotlight.data.store import f16_decode
    from nlos_spotlight.fit.ceiling import light_renderer, person_light
    from nlos_spotlight.fit.run import room_builder

    builder, dcfg = room_builder(out, cfg)
    room, specs = builder._scan_people()
    r, y = light_renderer(room, dcfg.render_settings(), light, {})
    t = np.array([*specs[i]["position"], room.hidden_region.floor_z])
    got = person_light(r, y, specs[i]["params"], t, dcfg).numpy()
    with np.load(scene / "images" / f"{i:05d}.npz") as z:
        stored = f16_decode(z, "nlos_ambient") + (f16_decode(z, "flash_nlos") if light == "flash" else 0)
    scale = np.abs(stored).max()
    assert scale > 0
    np.testing.assert_allclose(got.reshape(stored.shape) / scale, stored / scale, atol=2e-3)


def test_a_method_without_a_spot_refuses_the_spots_terms(room_dir, tmp_path, capsys, monkeypatch):
    """``nlos fit --method tancik|dlnlos`` sets the settings without a spot term where nothing says
    otherwise, and refuses one that renders a spot's term (bounce, shadow, drawn worlds, drift) in
    one line naming it, leaving nothing; the policy of a light without a spot goes with its method."""
    import nlos_spotlight.fit.run as run

    got = {}
    monkeypatch.setattr(run, "fit_room", lambda room, out, cfg, *a, **k: got.setdefault("cfg", cfg))
    assert main(["fit", str(room_dir), "--out", str(tmp_path / "ok"), "--preset", "tiny", "--method", "dlnlos"]) == 0
    assert (got["cfg"].policy, got["cfg"].shadow.shadow_samples, got["cfg"].capture_preset) == ("ambient", 0, "ideal")
    monkeypatch.undo()
    q = ["--preset", "tiny", "--quiet"]
    for flags, words in ((["--method", "dlnlos", "--bounce", "on"], ("--bounce on", "--method dlnlos lights no spot")),
                         (["--method", "tancik", "--shadow-samples", "64"], ("--shadow-samples 64", "flash")),
                         (["--method", "tancik", "--world-variation", "tripod"], ("--world-variation tripod",)),
                         (["--method", "dlnlos", "--capture-preset", "tripod"], ("--capture-preset tripod",)),
                         (["--policy", "flash"], ("--policy", "--method tancik")),
                         (["--method", "tancik", "--policy", "oracle"], ("--method tancik lights no spot",))):
        _fails(capsys, ["fit", str(room_dir), "--out", str(tmp_path / "bad")] + flags + q, *words)
        assert not (tmp_path / "bad").exists()


def test_finished_model_reads_the_fit_or_says_why_not(fitted, tmp_path):
    """``finished_model``: a finished room model's config, the report's aim and its people's builder
    (a person rendered again by it is the dataset's); a folder that is not one is one line."""
    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.fit.run import finished_model, heldout_model

    out, report = fitted
    cfg, aim, builder, dcfg = finished_model(out)
    assert cfg == TINY and np.allclose(aim, report["spot"]["aim"])
    assert builder.cfg.room == str((out / "room").resolve())
    with pytest.raises(NlosError, match="not a finished room model"):
        finished_model(tmp_path)
    # the studies' start: the same model and its first held-out people, the ones the report scored
    *_, idx = heldout_model(out, 4)
    assert len(idx) == 4 and min(idx) >= cfg.transport_people and len(set(idx)) == 4
    assert heldout_model(out, 100)[-1][:4] == idx and len(heldout_model(out, 100)[-1]) == TINY.heldout
