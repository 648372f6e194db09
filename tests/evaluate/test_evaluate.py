"""``nlos evaluate``: metrics against hand computation, the report's files, resume, and CLI errors."""

from __future__ import annotations

import csv
import json
import re

import numpy as np
import pytest
import torch

from nlos_spotlight.cli import main as nlos
from nlos_spotlight.data.config import DatasetConfig
from nlos_spotlight.data.generate import generate
from nlos_spotlight.evaluate.metrics import aggregate, per_class
from nlos_spotlight.evaluate.predictions import Predictions
from nlos_spotlight.train.config import TrainConfig
from nlos_spotlight.train.loop import train

MICRO = dict(name="micro-eval", seed=5, train_scenes=2, val_scenes=0, test_scenes=1, samples_per_scene=6,
             trajectories_per_test_scene=1, trajectory_frames=5, resolution=12, los_vertices=40,
             transport_rank=8, body_faces=600,
             render=dict(pixel_samples=1, transport_pixel_samples=1, spot_samples=4, person_samples=48,
                         person_quadrature="mc"))


def test_per_class_matches_hand_computation():
    p = Predictions()
    rng = np.random.default_rng(0)
    true = [0, 0, 1, 2, 5, 5, 5]
    pred = [0, 1, 1, 2, 5, 0, 5]
    for k, (t, q) in enumerate(zip(true, pred)):
        p.scene.append("s")
        p.sample.append(k)
        xy = rng.uniform(0, 3, 2)
        p.true_xy.append(xy)
        p.pred_xy.append(xy + [0.03 * (k + 1), 0.04 * (k + 1)])  # error 5 (k + 1) cm
        probs = np.full(6, 0.1)
        probs[q] = 0.5
        p.probs.append(probs)
        p.true_posture.append(t)
        p.trajectory.append((-1, -1))
    p.trajectory[-1] = (0, 0)  # a walking frame: left out of the tables
    r = per_class(p)
    assert r["accuracy"]["standing"] == pytest.approx(50.0)
    assert r["accuracy"]["unknown"] == pytest.approx(50.0)  # the third 'unknown' is a walking frame
    assert r["accuracy"]["all"] == pytest.approx(100 * 4 / 6)
    assert np.isnan(r["accuracy"]["hands_90"])
    assert r["error_cm"]["standing"] == pytest.approx((5 + 10) / 2)
    assert r["error_cm"]["all"] == pytest.approx(5 * np.mean(np.arange(1, 7)))
    agg = aggregate([r, {m: {c: v + 2.0 for c, v in d.items()} for m, d in r.items()}])
    m, s = agg["accuracy"]["all"]
    assert m == pytest.approx(100 * 4 / 6 + 1) and s == pytest.approx(np.std([0, 2], ddof=1))


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory):
    root = tmp_path_factory.mktemp("eval")
    data, run, report = root / "data", root / "run", root / "report"
    generate(DatasetConfig(**MICRO), data, progress=False)
    train(TrainConfig(steps=6, batch_size=4, ckpt_every=3, log_every=3, holdout_every=3), data, run, progress=False)
    argv = ["evaluate", str(run), "--data", str(data), "--out", str(report), "--seeds", "2",
            "--methods", "random_resnet,oracle_resnet", "--quiet"]
    assert nlos(argv) == 0
    return data, run, report, argv


def test_report_files_and_numbers_agree_with_raw_predictions(evaluated):
    data, run, report, _ = evaluated
    for name in ("report.md", "report.html", "raw.csv", "summary.csv", "evaluation.json", "fig6_policies.png",
                 "fig7_decimation.png", "fig5_tracking.png"):
        assert (report / name).is_file(), name
    html = (report / "report.html").read_text()
    assert "data:image/png;base64," in html and not re.search(r'src="(?!data:)', html)  # opens offline
    rows = list(csv.DictReader((report / "raw.csv").open()))
    samples = 6 + 5  # static samples + one walk of 5 frames in the one test scene
    assert len(rows) == 3 * 2 * samples  # methods x seeds x samples
    summary = {(r["method"], r["seed"], r["metric"], r["column"]): float(r["value"])
               for r in csv.DictReader((report / "summary.csv").open())}
    for method in ("ours", "random_resnet", "oracle_resnet"):
        for seed in ("0", "1"):
            mine = [r for r in rows if r["method"] == method and r["seed"] == seed and int(r["trajectory"]) < 0]
            err = np.mean([100 * np.hypot(float(r["pred_x"]) - float(r["true_x"]), float(r["pred_y"]) - float(r["true_y"]))
                           for r in mine])
            acc = 100 * np.mean([r["pred_posture"] == r["true_posture"] for r in mine])
            assert summary[(method, seed, "error_cm", "all")] == pytest.approx(err, abs=1e-3)
            assert summary[(method, seed, "accuracy", "all")] == pytest.approx(acc, abs=1e-3)
    ev = json.loads((report / "evaluation.json").read_text())
    assert ev["seeds"] == [0, 1] and set(ev["results"]) == {"ours", "random_resnet", "oracle_resnet"}
    snr = ev["spot_snr_over_oracle"]
    assert snr["oracle_resnet"][0] == pytest.approx(1.0) and all(0 <= v[0] <= 1 + 1e-9 for v in snr.values())


def test_report_lays_out_in_a_browser(evaluated, check_in_browser):
    """Every table, figure and heading of report.html as headless Chromium lays it out."""
    got = check_in_browser(evaluated[2] / "report.html")
    assert len(got["images"]) == 3 and any(h.startswith("Table 1") for h in got["headings"])


def test_seen_rooms_are_the_held_out_samples_under_the_training_spot(evaluated):
    from nlos_spotlight.evaluate.experiment import seen_rooms
    from nlos_spotlight.evaluate.predictions import illumination_for
    from nlos_spotlight.evaluate.runs import run_config
    from nlos_spotlight.train.checkpoint import load_trained
    from nlos_spotlight.train.loop import fixed_illuminations
    from nlos_spotlight.data.tensors import load_split, room_samples

    data, run, report, _ = evaluated
    base = run_config(run)
    ids, seen = seen_rooms(data, base)
    full = load_split(data, "train", base.ien_features)
    trained = [room_samples(s, base.holdout_every, held=False) for s in full]
    for s, held, fit in zip(full, seen, trained):
        assert held.num_samples == 2 and fit.num_samples == 4  # samples 2 and 5 of 6 held out
        # held-out and training samples partition the room: no target appears in both
        both = torch.cat([held.target, fit.target])
        assert torch.equal(both.sort(0).values, s.target.sort(0).values)
        assert not any(torch.equal(a, b) for a in held.target for b in fit.target)
    ev = json.loads((report / "evaluation.json").read_text())
    assert ev["seen_rooms"] == ids and set(ev["results_seen_rooms"]) == {"ours", "random_resnet", "oracle_resnet"}
    models = load_trained(run / "methods" / "random_resnet" / "seed1")
    train_spots = fixed_illuminations(models.config, trained)  # what train() passed to its Trainer
    for k, s in enumerate(seen):
        assert illumination_for(models, s, k, 1, seen=True).face == train_spots[k].face
    assert "Seen rooms" in (report / "report.md").read_text()
    # the IEN's SNR target reads only the samples it trains on: 4 of each room's 6
    from nlos_spotlight.lighting.snr import scene_snr

    for sid in ids:
        assert scene_snr(data / "scenes" / sid, base.holdout_every).samples == 4
        assert scene_snr(data / "scenes" / sid).samples == 6


def test_rerun_reuses_finished_runs(evaluated):
    data, run, report, argv = evaluated
    finals = sorted(run.glob("methods/*/seed*/final.pt"))
    assert len(finals) == 2 * 2 + 1  # two baselines x two seeds, ours at its second seed
    before = {p: p.stat().st_mtime_ns for p in finals}
    assert nlos(argv) == 0
    assert {p: p.stat().st_mtime_ns for p in finals} == before


def test_cli_errors_are_one_line(tmp_path, capsys):
    assert nlos(["evaluate", str(tmp_path), "--data", str(tmp_path), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err and "config.json" in err


def test_test_data_scores_the_rooms_of_another_dataset(evaluated, tmp_path):
    """``--test-data``: the finished runs are scored on a test-only dataset's rooms (its people's
    true positions in raw.csv, its scene ids), and evaluation.json names it."""
    from nlos_spotlight.data.tensors import load_scene_tensors, split_ids

    data, run, _, _ = evaluated
    other = tmp_path / "other"
    generate(DatasetConfig(**{**MICRO, "seed": 11, "train_scenes": 0, "val_scenes": 0, "test_scenes": 1}), other,
             progress=False)
    out = tmp_path / "report"
    assert nlos(["evaluate", str(run), "--data", str(data), "--test-data", str(other), "--out", str(out),
                 "--seeds", "2", "--methods", "random_resnet,oracle_resnet", "--quiet"]) == 0
    assert json.loads((out / "evaluation.json").read_text())["test_data"] == str(other)
    sid, = split_ids(other, "test")
    s = load_scene_tensors(other / "scenes" / sid, ["normals"])
    with (out / "raw.csv").open() as f:
        rows = [r for r in csv.DictReader(f) if r["method"] == "oracle_resnet" and r["seed"] == "0"]
    assert {r["scene"] for r in rows} == {sid} and len(rows) == s.num_samples
    true = np.array([[float(r["true_x"]), float(r["true_y"])] for r in sorted(rows, key=lambda r: int(r["sample"]))])
    np.testing.assert_allclose(true, s.target.numpy(), atol=1e-4)


def test_floor_net_is_a_method_read_under_ours_spot(evaluated, tmp_path):
    """``--methods floor_net``: FloorNet trained on the training rooms (``RUN/methods/floor_net``),
    read in the test room under the spot ours' IEN picks there; raw.csv holds its predictions, and
    its table row is their error."""
    from nlos_spotlight.data.tensors import load_scene_tensors, split_ids
    from nlos_spotlight.evaluate.predictions import illumination_for
    from nlos_spotlight.train.checkpoint import load_trained
    from nlos_spotlight.train.floor_net import load_floor_net

    data, run, _, _ = evaluated
    out = tmp_path / "report"
    assert nlos(["evaluate", str(run), "--data", str(data), "--out", str(out), "--methods", "floor_net", "--quiet"]) == 0
    fn = run / "methods" / "floor_net" / "seed0"
    assert (fn / "floor_net.pt").is_file() and load_floor_net(fn).config.steps == 6
    with (out / "raw.csv").open() as f:
        rows = [r for r in csv.DictReader(f) if r["method"] == "floor_net"]
    sid, = split_ids(data, "test")
    s = load_scene_tensors(data / "scenes" / sid, ["normals"])
    ours = load_trained(run)
    assert len(rows) == s.num_samples
    assert {int(r["face"]) for r in rows} == {illumination_for(ours, s, 0, 0).face}
    err = np.mean([np.hypot(float(r["pred_x"]) - float(r["true_x"]), float(r["pred_y"]) - float(r["true_y"]))
                   for r in rows if r["trajectory"] == "-1"]) * 100
    res = json.loads((out / "evaluation.json").read_text())["results"]["floor_net"]
    assert res["error_cm"]["all"][0] == pytest.approx(err, rel=1e-3)
