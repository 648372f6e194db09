"""The training recipe: one network on N people per room, best weights by validation, scored on held-out people.

``nlos fit`` (one room), ``make demo`` and the seen-rooms studies
(``experiments/seen-rooms-learning-curve``) train with it. Per room the static samples split by
index k: ``k % 10 == 9`` test, ``k % 10 == 8`` validation (the first 100 of each), all others the
training pool, of which a run takes the first N. Indices are in generation order and postures are
a random permutation per room, so every subset is posture-balanced in expectation; the test and
validation people are the same for every N. The scores are ``evaluate.seen``'s.

Shapes: positions (N, 2) m in the region frame, posture indices (N,).
"""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass
from pathlib import Path

import torch

from ..data.tensors import SceneTensors
from ..models.nlos_net import NLOSNetConfig
from .config import TrainConfig
from .loop import Trainer, truncate_log


@dataclass
class RoomSplit:
    """One training room's people: the pool to train on, validation and test."""

    pool: SceneTensors
    """Training candidates, in index order."""
    val: SceneTensors
    """Validation people (best-weight selection and early stopping)."""
    test: SceneTensors
    """Held-out people the results are reported on."""


def split_masks(s: SceneTensors, period: int = 10, max_eval: int = 100) -> tuple[torch.Tensor, ...]:
    """(pool, validation, test) bool masks over the samples: static samples by index, k % period ==
    period - 1 test, == period - 2 validation (the first ``max_eval`` of each, so a room still being
    generated keeps the same test people as it grows), every other static sample the pool."""
    k = torch.arange(s.num_samples)
    static = s.trajectory[:, 0] < 0
    first = lambda m: m & (torch.cumsum(m.long(), 0) <= max_eval)
    test = first(static & (k % period == period - 1))
    val = first(static & (k % period == period - 2))
    return static & ~test & ~val, val, test  # beyond the first max_eval, residues period-2 and -1 train too


def split_room(s: SceneTensors, period: int = 10, max_eval: int = 100) -> RoomSplit:
    """The room's samples split by :func:`split_masks`, the training pool in index order."""
    take = lambda m: s.subset(torch.nonzero(m).flatten())
    return RoomSplit(*(take(m) for m in split_masks(s, period, max_eval)))


@dataclass
class SeenResult:
    """Scores of one run on the test people of its rooms."""

    posture_accuracy: float
    """Six-way accuracy, %."""
    posture3_accuracy: float
    """Upright / sitting / crouching accuracy, %."""
    error_cm: float
    """Mean localization error, cm."""
    mean_answer_cm: float
    """Error of always answering the training people's mean position, cm (the chance level)."""
    confusion: list[list[int]]
    """6 x 6 counts, rows true posture, columns predicted."""
    spots: list[int]
    """Each room's spot face (-1 for flash or ambient)."""
    people_per_room: int
    """Training people per room."""
    steps: int
    """Optimizer steps taken (early stopping may end before the budget)."""
    seconds: float
    """Wall time of training and scoring."""
    unstored_choices: int = 0
    """IEN runs on image samples: rooms where the IEN's first choice was not a stored spot."""


def seen_config(rooms: int, seed: int = 0, noise: bool = True, policy: str = "oracle", arch: str = "resnet18",
                backbone: str = "resnet10-narrow", stem: str = "half", pool_grid: int = 1, batch: int = 64,
                lr: float = 2e-3, patience: int = 0) -> TrainConfig:
    """The seen-rooms recipe (``experiments/seen-rooms-learning-curve/learning_curve.py``, ``make demo``):
    the photograph minus the empty-room photograph, the lighter ResNet with the half stem, Adam with a cosine schedule,
    and every batch mixing all ``rooms`` (``scenes_per_step``): with one room per batch, batch norm
    trains on one room's statistics and tests on the running mix of all of them
    (``experiments/seen-rooms-learning-curve/learning_ablation.py``: 66 -> 32 cm at 500 people in two rooms).
    ``arch`` names a baseline network instead (its own layers; ``backbone`` and ``stem`` unused)."""
    net = NLOSNetConfig(background_subtract=True, backbone=backbone, stem=stem, pool_grid=pool_grid)
    return TrainConfig(name="seen-rooms", seed=seed, batch_size=batch, scenes_per_step=min(rooms, batch), lr=lr,
                       lr_schedule="cosine", patience=patience, holdout_every=10, net=net, device="auto",
                       arch=arch, policy=policy, sensor_noise=noise)


CHECKPOINT_SECONDS = 30.0
"""Least wall time between two resumable checkpoints of :func:`train_validated` (a network with its
optimizer is tens of MB; a short run validates every step). Checkpoints fall on validation steps, so
a kill loses at most this much training and one validation interval, and the resumed run replays it
to the same weights (its random state is in the checkpoint)."""


def resume_validated(tr: Trainer, out: Path) -> None:
    """Continue ``tr`` from ``out``/checkpoint.pt where a run left one, and drop the validation rows
    after it (:func:`train_validated` validates those steps again)."""
    if (out / "checkpoint.pt").exists():
        tr.load(out / "checkpoint.pt")
    truncate_log(out / "validation.csv", tr.step)


def train_validated(tr: Trainer, out: Path, progress: bool = False) -> int:
    """Train ``tr`` to its last step (or early stop), validating when due and checkpointing then
    (``out``/checkpoint.pt, at most every :data:`CHECKPOINT_SECONDS`, and at the end: a finished
    run's checkpoint holds its last weights); returns the steps taken and leaves ``tr`` holding the
    best weights (``out``/best.pt) where validation kept any."""
    import time

    from .loop import _validation_pass

    stop, saved = tr.stopped_early, time.monotonic()
    while tr.step < tr.total_steps and not stop:
        tr.train_step()
        if tr.validation_due:
            stop = _validation_pass(tr, out)
            if time.monotonic() - saved >= CHECKPOINT_SECONDS:
                tr.save(out / "checkpoint.pt")
                saved = time.monotonic()
            if progress:
                print(f"  {out.name}: step {tr.step}/{tr.total_steps} best val {tr.best_val:.3f}", flush=True)
    tr.save(out / "checkpoint.pt")
    steps = tr.step
    if (out / "best.pt").exists():
        tr.load(out / "best.pt")
    return steps


def run_seen(cfg: TrainConfig, rooms: list[RoomSplit], n: int, out: Path, epochs: float,
             progress: bool = False, min_steps: int = 0, keep_model: Path | None = None,
             ien_state: dict | None = None, spots: list[int] | None = None) -> SeenResult:
    """Train ``cfg`` on the first ``n`` pool people of every room for about ``epochs`` passes (more
    where that is fewer than ``min_steps`` steps: small N), then score.

    Resumable: a finished run's ``result.json`` is returned as is; an interrupted one resumes from
    its checkpoint. Validation every epoch, or every 1/25 of the run where epochs are shorter, picks
    the best weights (patience from ``cfg``, counted in validation passes).

    ``keep_model``: also write the best weights there as a checkpoint ``nlos predict`` reads, and
    ``heldout.npz`` (``score``'s ``per_person`` and ``photos``) beside ``result.json``.
    ``ien_state``: a trained IEN's weights to keep in the checkpoint (policy 'ien'), untrained here;
    ``spots``: each room's spot face, fixed (``nlos fit --policy ien``: that IEN's choice).
    """
    import time

    out.mkdir(parents=True, exist_ok=True)
    done = out / "result.json"
    if done.exists():
        return SeenResult(**json.loads(done.read_text()))
    t0 = time.perf_counter()
    epochs = max(epochs, min_steps * cfg.batch_size / (n * len(rooms)))
    train = [r.pool.subset(torch.arange(min(n, r.pool.num_samples))) for r in rooms]
    per_epoch = max(1, sum(t.num_samples for t in train) // cfg.batch_size)
    steps = max(1, round(epochs * per_epoch))
    every = max(per_epoch, steps // 25)  # small N: an epoch is a few steps; validate ~25 times a run
    cfg = dataclasses.replace(cfg, steps=steps, eval_every=every, ckpt_every=every, log_every=every)
    (out / "config.json").write_text(json.dumps({"train": cfg.to_dict(), "people_per_room": n,
                                                 "epochs": epochs}, indent=1))
    tr = Trainer(cfg, train, out, val_scenes=[r.val for r in rooms])
    resume_validated(tr, out)
    if ien_state is not None:
        tr.ien.load_state_dict(ien_state)
    if spots is not None:
        from ..lighting.base import Illumination

        tr.fixed = [Illumination("spot", int(f)) for f in spots]
    steps = train_validated(tr, out, progress)
    if keep_model is not None:
        tr.save(keep_model)
    from ..evaluate.seen import mean_answer_cm, score

    res = score(tr, rooms, cfg.sensor_noise, cfg.seed)
    per_person, photos = res.pop("per_person"), res.pop("photos")
    if keep_model is not None:  # what a report draws: every test person, one photograph per posture
        from ..data.store import atomic_npz

        atomic_npz(out / "heldout.npz", **per_person, **{f"photo_{k}": v for k, v in (photos or {}).items()})
    result = SeenResult(**res, mean_answer_cm=mean_answer_cm(rooms), people_per_room=n, steps=steps,
                        seconds=time.perf_counter() - t0, unstored_choices=getattr(tr, "unstored_choices", 0))
    tmp = done.with_name(".result.json.tmp")
    tmp.write_text(json.dumps(dataclasses.asdict(result), indent=1))
    os.replace(tmp, done)
    for name in ("checkpoint.pt", "best.pt"):  # only the scores are kept: runs are many and cheap
        (out / name).unlink(missing_ok=True)
    return result


__all__ = ["RoomSplit", "SeenResult", "run_seen", "seen_config", "split_masks", "split_room", "resume_validated",
           "train_validated"]
