"""FloorNet across rooms in the package (``train/floor_net.py``, ``nlos train --method floor-net``):
trained on a tiny dataset's rooms, its checkpoint read back to the same answers, the recorded
validation error the kept weights' own, and bad checkpoints refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from nlos_spotlight.cli import main
from nlos_spotlight.errors import NlosError

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def rooms(tmp_path_factory):
    """Two training rooms and one validation room, their people as image samples under stored spots."""
    from nlos_spotlight.data.config import DatasetConfig
    from nlos_spotlight.data.generate import generate

    out = tmp_path_factory.mktemp("fn-data")
    cfg = DatasetConfig(name="fn", seed=5, train_scenes=2, val_scenes=1, test_scenes=0, samples_per_scene=10,
                        transport_samples_per_scene=2, trajectories_per_test_scene=0, trajectories_per_train_scene=0,
                        resolution=12, los_vertices=40, transport_rank=8, body_faces=400, stored_spots_top=2,
                        render=dict(pixel_samples=1, transport_pixel_samples=1, spot_samples=4, person_samples=48,
                                    person_quadrature="mc"))
    generate(cfg, out, progress=False)
    return out


@pytest.fixture(scope="module")
def trained(rooms, tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("fn-run") / "run"
    assert main(["train", "--method", "floor-net", "tiny", "--data", str(rooms), "--out", str(run_dir), "--quiet"]) == 0
    return run_dir


def test_checkpoint_reads_back_to_the_same_answers(rooms, trained):
    from nlos_spotlight.data.tensors import finished_scene_dirs
    from nlos_spotlight.train.floor_net import load_floor_net, predict, room_arrays, validation_error

    meta = json.loads((trained / "floor_net.json").read_text())
    assert meta["format"] == "nlos-floor-net/1" and meta["training"]["steps"] == 20 and meta["train_rooms"] == 2
    run = load_floor_net(trained)
    val = [room_arrays(d, None, "images") for d in finished_scene_dirs(rooms, "val")]
    # the recorded best validation error is the kept weights' own (same noise draw)
    assert validation_error(run.net, val) == pytest.approx(meta["best_validation_cm"], rel=1e-5)
    assert min(e for _, e in meta["validation_cm"]) == pytest.approx(meta["best_validation_cm"])
    r = val[0]
    with torch.no_grad():
        pos, logits, cell = predict(run.net, r, 0, torch.arange(len(r["target"])), None)
    assert pos.shape == (len(r["target"]), 2) and logits.shape == (len(r["target"]), 6)
    # positions are soft-argmax averages of valid cells: inside the cells' bounding box
    lo, hi = r["cells"][r["valid"]].min(0).values, r["cells"][r["valid"]].max(0).values
    assert bool(((pos >= lo - 1e-5) & (pos <= hi + 1e-5)).all())
    assert np.allclose(run.mean_xy.numpy(), meta["mean_xy"])


def test_an_experiment_run_loads(trained, tmp_path):
    """Runs of experiments/backprojection-across-rooms/backprojection_net.py (run.json, its arguments as strings)."""
    from nlos_spotlight.train.floor_net import load_floor_net

    d = tmp_path / "old"
    d.mkdir()
    (d / "floor_net.pt").write_bytes((trained / "floor_net.pt").read_bytes())
    (d / "run.json").write_text(json.dumps({"args": {"steps": "3000", "templates": "1", "lr": "0.002", "ien": "None"},
                                            "mean_xy": [0.5, 0.25], "validation_cm": [[250, 60.0]],
                                            "best_validation_cm": 60.0}))
    run = load_floor_net(d)
    assert run.config.steps == 3000 and run.config.lr == 0.002 and run.best_cm == 60.0
    assert run.mean_xy.tolist() == [0.5, 0.25]


def test_bad_checkpoints_are_one_line(trained, tmp_path):
    import pickle

    from nlos_spotlight.train.floor_net import load_floor_net

    for name, content in (("torn", (trained / "floor_net.pt").read_bytes()[:100]),
                          ("code", pickle.dumps({"x": np.random.default_rng})),
                          ("missing", None)):
        d = tmp_path / name
        d.mkdir()
        (d / "floor_net.json").write_text((trained / "floor_net.json").read_text())
        if content is not None:
            (d / "floor_net.pt").write_bytes(content)
        with pytest.raises(NlosError) as e:
            load_floor_net(d)
        assert "\n" not in str(e.value) and str(d) in str(e.value)
    (tmp_path / "code" / "floor_net.json").write_text("{not json")
    with pytest.raises(NlosError, match="invalid JSON"):
        (tmp_path / "code" / "floor_net.pt").write_bytes((trained / "floor_net.pt").read_bytes())
        load_floor_net(tmp_path / "code")


def test_bad_training_configs_are_refused(rooms, tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("steps: 0\n")
    assert main(["train", "--method", "floor-net", str(bad), "--data", str(rooms), "--out", str(tmp_path / "r")]) != 0
    err = capsys.readouterr().err.strip()
    assert "steps" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "r" / "floor_net.pt").exists()
