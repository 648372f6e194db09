"""Training on some rooms, validating on rooms of their own under their own light."""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

from nlos_spotlight.evaluate.unseen import as_pairs, mean_answer, room_lights, train_unseen
from nlos_spotlight.lighting import Illumination
from nlos_spotlight.models.nlos_net import NLOSNetConfig
from nlos_spotlight.train.config import TrainConfig
from nlos_spotlight.train.imaging import capture


def test_validation_rooms_are_scored_under_their_own_light(micro_scene, tmp_path):
    """The room trained under the center spot validates a room lit elsewhere: the validation loss
    is that of the validation room under its given light (recomputed by hand), not under the
    training room's spot; with no validation rooms nothing is validated."""
    _, s = micro_scene
    net = NLOSNetConfig(backbone="resnet10-narrow", stem="half")
    cfg = TrainConfig(policy="center", sensor_noise=False, batch_size=3, steps=2, eval_every=1, ckpt_every=1, net=net)
    center = room_lights([s], "center", 0)[0]
    other = Illumination("spot", int(next(t for t in torch.nonzero(s.landed).flatten() if int(t) != center.face)))
    tr = train_unseen(cfg, [s], [s], [other], tmp_path / "run")
    assert (tmp_path / "run" / "validation.csv").exists() and (tmp_path / "run" / "best.pt").exists()
    row = tr.validate()
    tr.net.eval()
    idx = torch.arange(s.num_samples)
    (y, mode), = as_pairs([s], [other])
    with torch.no_grad():
        ph = capture(s, idx, y, mode, tr.sensor, None, False, net)
        pos, logits = tr.net(ph.images, ph.background, ph.clipped)
    want = (F.mse_loss(pos, s.target, reduction="sum") / 2 + F.cross_entropy(logits, s.posture, reduction="sum"))
    np.testing.assert_allclose(row["loss"], float(want) / s.num_samples, rtol=1e-5)
    tr2 = train_unseen(cfg, [s], [], [], tmp_path / "none")
    assert tr2.val_scenes is None and not (tmp_path / "none" / "validation.csv").exists()
    assert mean_answer([s], [s]) == float(100 * (s.target - s.target.mean(0)).norm(dim=1).mean())
