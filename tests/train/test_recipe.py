"""The training recipe: two-stage training, validation with best weights and early stopping, cosine schedule."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch


from nlos_spotlight.train.config import TrainConfig  # noqa: E402
from nlos_spotlight.train.loop import Trainer, _validation_pass, split_validation  # noqa: E402


def test_two_stage_freezes_the_ien_on_its_snr_spot_then_trains_the_network(toy_scene):
    cfg = TrainConfig(spot_steps=30, steps=5, batch_size=4, sensor_noise=False)
    tr = Trainer(cfg, [toy_scene()], Path("unused"))
    s = tr.scenes[0]
    with torch.no_grad():
        best = int(tr.ien(s.x, s.edge_index, s.faces).argmin())  # the initially least likely face
    snr = torch.full((len(s.faces),), 0.2)
    snr[best] = 1.0
    tr.spot_snr = [snr]
    net0 = [p.detach().clone() for p in tr.net.parameters()]
    for _ in range(cfg.spot_steps):
        tr.train_step()
    assert all(torch.equal(a, b) for a, b in zip(net0, tr.net.parameters()))  # stage 1 leaves the network
    assert tr.fixed is not None and tr.fixed[0].face == best and not tr.in_spot_stage
    ien1 = [p.detach().clone() for p in tr.ien.parameters()]
    while tr.step < tr.total_steps:
        tr.train_step()
    assert all(torch.equal(a, b) for a, b in zip(ien1, tr.ien.parameters()))  # stage 2 leaves the IEN
    assert not all(torch.equal(a, b) for a, b in zip(net0, tr.net.parameters()))


def test_two_stage_without_snr_targets_is_a_one_line_error(toy_scene):
    from nlos_spotlight.errors import NlosError

    tr = Trainer(TrainConfig(spot_steps=3, batch_size=4, sensor_noise=False), [toy_scene()], Path("unused"))
    with pytest.raises(NlosError, match="stage 1 needs"):
        tr.train_step()


def test_validation_split_is_disjoint_and_scores_like_the_loss(toy_scene):
    room = toy_scene(n=40)
    fit, val = split_validation(room, 4)
    assert fit.num_samples == 30 and val.num_samples == 10
    assert not set(fit.target[:, 0].tolist()) & set(val.target[:, 0].tolist())
    cfg = TrainConfig(batch_size=4, sensor_noise=False)
    tr = Trainer(cfg, [fit], Path("unused"), val_scenes=[val])
    row = tr.validate(batch=3)  # batches of 3 must not change the mean
    with torch.no_grad():
        ref = tr.loss_on(tr.val_scenes[0], torch.arange(val.num_samples), train=False)
    assert row["loss"] == pytest.approx(float(ref["pos_loss"] + ref["cls_loss"]), rel=1e-5)
    assert row["err_cm"] == pytest.approx(float(ref["err_cm"]), rel=1e-5)
    assert row["acc"] == pytest.approx(float(ref["acc"]), abs=1e-6)


def test_best_weights_are_kept_and_patience_stops(toy_scene, tmp_path, monkeypatch):
    room = toy_scene(n=16)
    fit, val = split_validation(room, 4)
    tr = Trainer(TrainConfig(batch_size=4, sensor_noise=False, patience=2), [fit], tmp_path, val_scenes=[val])
    losses = iter([3.0, 2.0, 2.5, 2.2, 1.0])
    monkeypatch.setattr(tr, "validate", lambda: {"loss": next(losses), "err_cm": 0.0, "acc": 0.0})
    stops = []
    for step in range(4):
        tr.step = step
        stops.append(_validation_pass(tr, tmp_path))
    assert stops == [False, False, False, True]
    assert tr.best_val == 2.0 and torch.load(tmp_path / "best.pt", weights_only=False)["step"] == 1
    assert (tmp_path / "validation.csv").read_text().count("\n") == 5


def test_a_killed_validated_run_resumes_to_the_same_weights(toy_scene, tmp_path, monkeypatch):
    """``train_validated`` checkpoints at most every ``CHECKPOINT_SECONDS``; a run killed after a
    validation row it had not checkpointed resumes from its checkpoint (that row dropped, the steps
    redone) to the uninterrupted run's weights and validation log."""
    import nlos_spotlight.train.recipe as recipe

    from nlos_spotlight.models.nlos_net import NLOSNetConfig

    room = toy_scene(n=24, res=8)
    fit, val = split_validation(room, 4)
    cfg = TrainConfig(steps=6, eval_every=1, batch_size=4, sensor_noise=False,
                      net=NLOSNetConfig(backbone="resnet10-narrow", stem="half"))
    make = lambda out: out.mkdir(exist_ok=True) or Trainer(cfg, [fit], out, val_scenes=[val])
    whole = make(tmp_path / "whole")
    recipe.train_validated(whole, tmp_path / "whole")
    assert torch.load(tmp_path / "whole" / "checkpoint.pt", weights_only=False)["step"] == 6  # the end's, alone

    out = tmp_path / "killed"
    killed = make(out)
    monkeypatch.setattr(recipe, "CHECKPOINT_SECONDS", 0.0)
    real_step = Trainer.train_step

    def step_until_the_kill(self):
        if self.step == 3:  # steps 1-3 validated and checkpointed
            monkeypatch.setattr(recipe, "CHECKPOINT_SECONDS", float("inf"))
        if self.step == 4:  # step 4 validated, not checkpointed: the kill
            raise KeyboardInterrupt
        real_step(self)

    monkeypatch.setattr(Trainer, "train_step", step_until_the_kill)
    with pytest.raises(KeyboardInterrupt):
        recipe.train_validated(killed, out)
    monkeypatch.setattr(Trainer, "train_step", real_step)
    assert (out / "validation.csv").read_text().count("\n") == 1 + 4  # header and steps 1-4
    again = make(out)
    recipe.resume_validated(again, out)
    assert again.step == 3 and (out / "validation.csv").read_text().count("\n") == 1 + 3
    steps = []
    monkeypatch.setattr(Trainer, "save", lambda self, path, real=Trainer.save:
                        (path.name == "checkpoint.pt" and steps.append(self.step)) or real(self, path))
    monkeypatch.setattr(recipe, "CHECKPOINT_SECONDS", 30.0)
    recipe.train_validated(again, out)
    assert steps == [6]  # under 30 s: the end's checkpoint alone (best.pt is written as validation improves)
    assert again.step == whole.step == 6
    assert all(torch.equal(a, b) for a, b in zip(whole.net.state_dict().values(), again.net.state_dict().values()))
    assert (out / "validation.csv").read_text() == (tmp_path / "whole" / "validation.csv").read_text()


def test_cosine_schedule_decays_to_one_percent(toy_scene):
    cfg = TrainConfig(steps=10, batch_size=4, sensor_noise=False, lr_schedule="cosine", lr=1e-3)
    tr = Trainer(cfg, [toy_scene()], Path("unused"))
    tr.set_learning_rate()
    assert tr.opt.param_groups[-1]["lr"] == pytest.approx(1e-3)
    tr.step = 10
    tr.set_learning_rate()
    assert tr.opt.param_groups[-1]["lr"] == pytest.approx(1e-5)


def test_walks_in_training_rooms_are_held_out_of_training(toy_scene):
    """A training room's walking-trajectory frames are for tracking in seen rooms: never trained on."""
    from nlos_spotlight.data.tensors import holdout_mask, room_samples

    room = toy_scene(n=20)
    room.trajectory[15:] = torch.tensor([[0, f] for f in range(5)])
    for every in (0, 6):
        held = holdout_mask(room, every)
        assert held[15:].all()
        trained = room_samples(room, every, held=False)
        assert bool((trained.trajectory[:, 0] < 0).all())
        assert trained.num_samples == 15 - (2 if every == 6 else 0)  # k = 5, 11 held out with every = 6


def test_seen_split_keeps_its_test_people_and_trains_on_everyone_else(toy_scene):
    """train.recipe.split_room: the first max_eval of residues 9 (test) and 8 (validation); every
    other static person is in the pool, so a growing room keeps its test people and loses no one."""
    from nlos_spotlight.train.recipe import split_room

    room = toy_scene(n=60)
    room.target[:, 0] = torch.arange(60, dtype=torch.float32)  # the index, to read back who went where
    r = split_room(room, period=10, max_eval=3)
    ids = lambda s: s.target[:, 0].long().tolist()
    assert ids(r.test) == [9, 19, 29] and ids(r.val) == [8, 18, 28]
    assert ids(r.pool) == sorted(set(range(60)) - {8, 9, 18, 19, 28, 29})
    grown = split_room(toy_scene(n=80), period=10, max_eval=3)
    assert grown.test.num_samples == 3 and grown.pool.num_samples == 74


def test_bad_training_values_and_resumed_logs(tmp_path):
    """steps: -5 is refused; a resumed run drops log rows written after its checkpoint."""
    import csv

    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.train.config import TrainConfig
    from nlos_spotlight.train.loop import truncate_log

    with pytest.raises(NlosError, match="steps"):
        TrainConfig(steps=-5)
    with pytest.raises(NlosError, match="lr"):
        TrainConfig(lr=0.0)
    log = tmp_path / "metrics.csv"
    log.write_text("step,loss\n5,1.0\n10,0.9\n15,0.8\n")
    truncate_log(log, 10)
    assert [r["step"] for r in csv.DictReader(log.open())] == ["5", "10"]


def test_selection_by_metrics_or_last_weights():
    """Validation picks by loss, by posture errors + localization error (m), or the latest step;
    an unknown criterion is a one-line error."""
    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.train.loop import check_config, selection_score

    early = {"loss": 1.0, "acc": 0.47, "err_cm": 20.8}  # room 0 of the per-room run: best loss, early
    late = {"loss": 1.8, "acc": 0.60, "err_cm": 14.5}  # its last pass: higher loss, better in both metrics
    assert selection_score(early, "loss", 880) < selection_score(late, "loss", 2760)
    assert selection_score(late, "metrics", 2760) == pytest.approx(0.40 + 0.145)
    assert selection_score(late, "metrics", 2760) < selection_score(early, "metrics", 880)
    assert selection_score(late, "last", 2760) < selection_score(early, "last", 880)
    with pytest.raises(NlosError, match="select"):
        check_config(TrainConfig(select="best"))
