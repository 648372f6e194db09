"""Scores of a trained network on held-out people: six-way and upright / sitting / crouching posture, error.

The training recipe that calls them (the split into pool, validation and test people, the config,
the validated training) is ``train.recipe``.

Shapes: positions (N, 2) m in the region frame, posture indices (N,).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch

from ..data.tensors import SceneTensors
from ..models.nlos_net import NLOSNetConfig
from ..train.imaging import capture
from ..world.body import POSTURES

if TYPE_CHECKING:  # the recipe imports these scores: types only, no import cycle
    from ..train.loop import Trainer
    from ..train.recipe import RoomSplit

GROUPS = {"standing": 0, "hands_90": 0, "hands_45": 0, "unknown": 0, "sitting": 1, "crouching": 2}
"""Posture -> coarse group: 0 upright, 1 sitting, 2 crouching."""
GROUP_OF = np.array([GROUPS[p] for p in POSTURES])
"""Posture index -> group index."""


def score(tr: Trainer, rooms: list[RoomSplit], noise: bool, seed: int = 0, batch: int = 128) -> dict:
    """Predictions of a trained run on its rooms' test people, each room under the run's spot
    (:func:`score_rooms`). Rooms with static layers (``nlos fit``) are photographed in their
    converged light with no drift (``render.variation`` 'ideal'), as the camera would see them."""
    from ..render.variation import preset

    lights = []
    for s in tr.scenes:
        (y, mode, _), = tr.illuminations([s], train=False)
        lights.append((y, mode))
    converged = all(r.test.layers is not None for r in rooms)
    return score_rooms(tr.net, tr.cfg.net, tr.sensor, [r.test for r in rooms], lights, noise, seed, batch,
                       variation=preset("ideal") if converged else None)


def score_rooms(net, net_cfg: NLOSNetConfig, sensor, rooms: list[SceneTensors], lights: list[tuple], noise: bool,
                seed: int = 0, batch: int = 128, variation=None) -> dict:
    """Predictions of ``net`` on every sample of ``rooms``, room i under ``lights[i]`` = (spot vector
    y (T,) or None, mode), with the same sensor noise for every run (seed 20,000 + ``seed``).

    Besides the scores, ``per_person`` holds arrays over all test people (room, true and predicted
    position (N, 2) in the region frame, true and predicted posture, the posture probabilities
    (N, 6)) and ``photos`` the first test
    person of each posture as photographed (image and empty-room image (6, H, W, 3) and where the
    person stands (6, 2), NaN where a posture has no test person; first room). ``variation``: the captures vary as
    ``render.variation`` draws them (None: ideal)."""
    net.eval()
    device = next(net.parameters()).device
    gen = torch.Generator(device=device).manual_seed(20_000 + seed)  # the same noise for every run
    cols = {k: [] for k in ("room", "true_xy", "pred_xy", "true_posture", "pred_posture", "posture_prob")}
    spots, photos = [], None
    with torch.no_grad():
        for i, (t, (y, mode)) in enumerate(zip(rooms, lights)):
            spots.append(int(y.argmax()) if y is not None and mode == "spot" else -1)
            t = t.to(device)
            for a in range(0, t.num_samples, batch):
                idx = torch.arange(a, min(a + batch, t.num_samples), device=device)
                ph = capture(t, idx, y, mode, sensor, gen, noise, net_cfg, variation=variation)
                pos, logits = net(ph.images, ph.background, ph.clipped, ph.geometry)
                for k, v in (("room", torch.full_like(idx, i)), ("true_xy", t.target[idx]), ("pred_xy", pos),
                             ("true_posture", t.posture[idx]), ("pred_posture", logits.argmax(1)),
                             ("posture_prob", logits.softmax(1))):
                    cols[k].append(v.cpu().numpy())
                if i == 0:
                    photos = _first_photos(photos, t.posture[idx], t.target[idx], ph)
    pp = {k: np.concatenate(v) for k, v in cols.items()}
    true, pred = pp["true_posture"], pp["pred_posture"]
    err = np.linalg.norm(pp["pred_xy"] - pp["true_xy"], axis=1)
    conf = np.zeros((len(POSTURES), len(POSTURES)), int)
    np.add.at(conf, (true, pred), 1)
    return {"posture_accuracy": float(100 * np.mean(true == pred)),
            "posture3_accuracy": float(100 * np.mean(GROUP_OF[true] == GROUP_OF[pred])),
            "error_cm": float(100 * err.mean()), "confusion": conf.tolist(), "spots": spots,
            "per_person": pp, "photos": photos}


def _first_photos(photos: dict | None, posture: torch.Tensor, target: torch.Tensor, ph) -> dict:
    """Keep the first photograph (and empty-room photograph) of each posture seen so far, with
    where that person stands (``xy``, region frame, m)."""
    h, w = ph.images.shape[1:3]
    if photos is None:
        photos = {"image": np.full((len(POSTURES), h, w, 3), np.nan, np.float32),
                  "background": np.full((len(POSTURES), h, w, 3), np.nan, np.float32),
                  "xy": np.full((len(POSTURES), 2), np.nan, np.float64)}
    bg = ph.background if ph.background is not None else torch.zeros_like(ph.images)
    for j, p in enumerate(posture.cpu().numpy()):
        if np.isnan(photos["image"][p, 0, 0, 0]):
            photos["image"][p] = ph.images[j].cpu().numpy()
            photos["background"][p] = bg[j].cpu().numpy()
            photos["xy"][p] = target[j].cpu().numpy()
    return photos


def mean_answer_cm(rooms: list[RoomSplit]) -> float:
    """Error of answering the mean training position for every test person."""
    mean = torch.cat([r.pool.target for r in rooms]).mean(0)
    test = torch.cat([r.test.target for r in rooms])
    return float(100 * (test - mean).norm(dim=1).mean())


__all__ = ["GROUPS", "GROUP_OF", "mean_answer_cm", "score", "score_rooms"]
