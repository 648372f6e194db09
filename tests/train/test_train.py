"""End-to-end training: gradients reach the IEN, the IEN finds the best spot, resume is exact, DDP runs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch


from nlos_spotlight.train.config import TrainConfig  # noqa: E402
from nlos_spotlight.train.loop import Trainer  # noqa: E402

CFG = TrainConfig(steps=40, batch_size=16, sensor_noise=False, tau=1.0, ckpt_every=10, log_every=5)


def _best_is_initial_worst(toy_scene, cfg: TrainConfig) -> int:
    probe = Trainer(cfg, [toy_scene()], Path("unused"))
    s = probe.scenes[0]
    with torch.no_grad():
        return int(probe.ien(s.x, s.edge_index, s.faces).argmin())


def test_nlos_loss_reaches_the_ien(toy_scene):
    tr = Trainer(CFG, [toy_scene()], Path("unused"))
    s = tr.scenes[0]
    out = tr.loss_on(s, torch.arange(8))
    out["loss"].backward()
    grads = [p.grad for p in tr.ien.parameters()]
    assert all(g is not None for g in grads) and sum(float(g.abs().sum()) for g in grads) > 0


def test_training_moves_the_spot_to_the_informative_face(toy_scene):
    best = _best_is_initial_worst(toy_scene, CFG)
    tr = Trainer(CFG, [toy_scene(best=best)], Path("unused"))
    s = tr.scenes[0]
    with torch.no_grad():
        assert int(tr.ien(s.x, s.edge_index, s.faces).argmax()) != best
    for _ in range(CFG.steps):
        tr.train_step()
    with torch.no_grad():
        p = torch.softmax(tr.ien(s.x, s.edge_index, s.faces), 0)
    assert int(p.argmax()) == best and float(p[best]) > 0.5


def test_sensor_noise_path_is_differentiable(toy_scene):
    cfg = TrainConfig(batch_size=4, sensor_noise=True)
    tr = Trainer(cfg, [toy_scene()], Path("unused"))
    out = tr.loss_on(tr.scenes[0], torch.arange(4))
    out["loss"].backward()
    assert torch.isfinite(out["loss"]) and all(p.grad is not None for p in tr.ien.parameters())


def test_resume_equals_uninterrupted(toy_scene, tmp_path):
    def run(steps_then_resume: int | None) -> dict:
        tr = Trainer(CFG, [toy_scene()], tmp_path)
        stop = steps_then_resume or 12
        while tr.step < stop:
            tr.train_step()
        if steps_then_resume:
            tr.save(tmp_path / "ck.pt")
            tr = Trainer(CFG, [toy_scene()], tmp_path)
            tr.load(tmp_path / "ck.pt")
            while tr.step < 12:
                tr.train_step()
        return {k: v.clone() for k, v in (tr.ien.state_dict() | tr.net.state_dict()).items()}

    a, b = run(None), run(5)
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_same_seed_same_checkpoint_bytes(toy_scene, tmp_path):
    """Two runs of one seed write byte-identical checkpoints, whatever the global numpy and Python
    RNGs hold (issue 36, item 13: they were stored, unseeded)."""
    import random

    import numpy as np

    def run(name: str) -> bytes:
        np.random.seed(len(name) * 7919)
        random.seed(name)
        (tmp_path / name).mkdir()
        tr = Trainer(CFG, [toy_scene()], tmp_path / name)
        while tr.step < 3:
            tr.train_step()
        tr.save(tmp_path / name / "final.pt")  # torch.save names the archive's records after the file
        return (tmp_path / name / "final.pt").read_bytes()

    assert run("a") == run("bb")


def test_two_process_torchrun_gloo(toy_scene, tmp_path):
    rooms = tmp_path / "rooms.pt"
    torch.save([toy_scene(n=16, best=2), toy_scene(n=16, seed=1)], rooms)
    script = tmp_path / "ddp.py"
    script.write_text(f"""
import sys, torch, torch.distributed as dist
from pathlib import Path
from nlos_spotlight.train.config import TrainConfig
from nlos_spotlight.train.loop import Trainer
dist.init_process_group("gloo")
# two rooms per step: one IEN pass over their union graph, one network pass over the mixed batch
cfg = TrainConfig(batch_size=4, scenes_per_step=2, sensor_noise=False, device="cpu")
tr = Trainer(cfg, torch.load({str(rooms)!r}, weights_only=False), Path("."))
for _ in range(3):
    tr.train_step()
w = torch.cat([p.detach().flatten() for p in [*tr.net.parameters(), *tr.ien.parameters()]])
gathered = [torch.zeros_like(w) for _ in range(dist.get_world_size())]
dist.all_gather(gathered, w)
assert torch.equal(gathered[0], gathered[1]), "replicas diverged"
if dist.get_rank() == 0:
    print("DDP-OK", dist.get_world_size())
dist.destroy_process_group()
""")
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    res = subprocess.run([sys.executable, "-m", "torch.distributed.run", "--nproc_per_node=2", "--standalone",
                          str(script)], capture_output=True, text=True, env=env, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "DDP-OK 2" in res.stdout


def test_snr_loss_alone_teaches_the_best_snr_spot(toy_scene):
    """With only the auxiliary loss, the IEN's choice moves to the candidate of highest stored SNR."""
    cfg = TrainConfig(steps=30, batch_size=4, sensor_noise=False, position_weight=0.0, posture_weight=0.0,
                      snr_weight=1.0)
    best = _best_is_initial_worst(toy_scene, cfg)
    tr = Trainer(cfg, [toy_scene()], Path("unused"))
    snr = torch.full((len(tr.scenes[0].faces),), 0.2)
    snr[best] = 1.0
    tr.spot_snr = [snr]
    s = tr.scenes[0]
    with torch.no_grad():
        log_p0 = torch.log_softmax(tr.ien(s.x, s.edge_index, s.faces), 0)  # every toy candidate lands
        q = torch.exp(snr / cfg.snr_tau) / torch.exp(snr / cfg.snr_tau).sum()
        expected = -float((q * log_p0).sum())
    assert float(tr.loss_on(s, torch.arange(4))["spot_loss"].detach()) == pytest.approx(expected, rel=1e-5)
    for _ in range(cfg.steps):
        tr.train_step()
    with torch.no_grad():
        assert int(tr.ien(s.x, s.edge_index, s.faces).argmax()) == best


def test_union_graph_gives_each_scene_its_own_logits(toy_scene):
    """One IEN pass over several meshes equals one pass per mesh (reference: separate forwards)."""
    a, b = toy_scene(seed=0), toy_scene(seed=1)
    b.x = b.x + 0.3 * torch.randn(b.x.shape, generator=torch.Generator().manual_seed(0))
    tr = Trainer(CFG, [a, b], Path("unused"))
    together = tr.ien_logits(tr.scenes)
    with torch.no_grad():
        for s, got in zip(tr.scenes, together):
            assert torch.allclose(got, tr.ien(s.x, s.edge_index, s.faces), atol=1e-6)
    assert not torch.allclose(together[0], together[1])


def test_mixed_batch_loss_is_the_mean_of_per_scene_losses(toy_scene):
    """With batch norm frozen (eval) and no noise, a batch of two scenes scores as their average."""
    a, b = toy_scene(seed=0, best=2), toy_scene(seed=1, best=6)
    tr = Trainer(TrainConfig(batch_size=8, sensor_noise=False, scenes_per_step=2), [a, b], Path("unused"))
    tr.net.eval()
    sa, sb = tr.scenes
    idx = torch.arange(4)
    with torch.no_grad():
        both = tr.loss_on_many([(sa, idx), (sb, idx)], train=False)
        one, two = tr.loss_on(sa, idx, train=False), tr.loss_on(sb, idx, train=False)
    for k in ("pos_loss", "cls_loss", "err_cm", "acc"):
        assert float(both[k]) == pytest.approx((float(one[k]) + float(two[k])) / 2, rel=1e-5, abs=1e-7)


def test_config_errors_are_one_line(tmp_path):
    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.train.loop import check_config

    for bad, words in ((dict(scenes_per_step=0), "scenes_per_step"), (dict(batch_size=2, scenes_per_step=3),
                       "scenes_per_step"), (dict(holdout_every=1), "holdout_every")):
        with pytest.raises(NlosError, match=words):
            check_config(TrainConfig(**bad))
    check_config(TrainConfig(holdout_every=6, scenes_per_step=4, batch_size=16))
