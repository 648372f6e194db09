"""``nlos train``: end-to-end training of the IEN and the NLOS network through the image formation.

Spot choice: straight-through Gumbel-softmax. The forward pass uses the one-hot spot of
argmax(logits + Gumbel noise), so every training image is a single-spot image as at inference; the
backward pass uses the gradient of the tempered softmax. Because the image is exactly linear in y
(stored transport), d loss / d y_t = <d loss / d image, image_t> is exact for every candidate t;
the estimator's only bias is the softmax relaxation. We chose it over REINFORCE because that
exact per-candidate gradient is available for free here, and its variance is far lower.

Runs on CPU or one GPU; under ``torchrun`` it trains data-parallel (``torch.distributed``,
gloo on CPU, nccl on GPU) with each rank drawing different scenes. Checkpoints carry the models,
the optimizer, every RNG state, the config and package versions, and resume bit-exactly.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import os
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from ..errors import NlosError
from ..models.ien import IEN
from ..models.registry import build_network
from ..render.sensor import SensorConfig
from ..world.body import clothing_albedo
from .config import TrainConfig
from .imaging import capture
from ..data.tensors import SceneTensors, load_split, room_samples


CHECKPOINT_FORMAT = "nlos-checkpoint/1"


def fixed_illuminations(cfg: TrainConfig, scenes: list[SceneTensors]):
    """Per-scene illumination of a fixed policy (None for the learned 'ien' policy)."""
    if cfg.policy == "ien":
        return None
    from ..lighting import policy_rng
    from ..lighting.learned import policy_named

    try:
        fn = policy_named(cfg.policy)
    except NlosError as exc:
        raise NlosError(f"config: {exc}") from None
    return [fn(s, Path(s.scene_dir), policy_rng(cfg.seed, i)) for i, s in enumerate(scenes)]


def spot_snr_targets(cfg: TrainConfig, scenes: list[SceneTensors]) -> list[torch.Tensor | None] | None:
    """Per scene (T,) candidate NLOS SNR over its best (``lighting.snr``), for ``snr_weight > 0``."""
    if cfg.snr_weight <= 0 and cfg.spot_steps <= 0:
        return None
    from ..lighting.snr import candidate_snr

    out = []
    for s in scenes:
        if not s.scene_dir:  # scenes built in memory carry no stored transport to measure
            out.append(None)
            continue
        snr = torch.as_tensor(candidate_snr(s.scene_dir, cfg.holdout_every, cfg.sensor), dtype=torch.float32,
                              device=s.x.device)
        out.append(snr / snr.max().clamp(min=1e-30))
    return out


def straight_through_spot(logits: torch.Tensor, landed: torch.Tensor, tau: float,
                          generator: torch.Generator | None) -> torch.Tensor:
    """One-hot y (T,) in the forward pass, softmax((logits + g) / tau) gradient in the backward pass."""
    logits = logits.masked_fill(~landed, float("-inf"))
    u = torch.rand(logits.shape, generator=generator, device=logits.device).clamp(1e-10, 1 - 1e-10)
    soft = torch.softmax((logits - torch.log(-torch.log(u))) / tau, dim=0)
    hard = F.one_hot(soft.argmax(), len(soft)).to(soft.dtype)
    return hard + soft - soft.detach()


def room_prior_of(scenes: list[SceneTensors]) -> tuple[torch.Tensor, torch.Tensor]:
    """The nuisance projection's prior (``models.nuisance.room_prior``) from the one room's static
    layers: a network that projects the capture variation out reads one room (a room model)."""
    from ..models.nuisance import room_prior

    rooms = {s.scene_dir for s in scenes}
    if len(rooms) != 1 or scenes[0].layers is None:
        raise NlosError("net.project_nuisance: needs one room with its static layers (nlos fit), got "
                        f"{len(rooms)} room(s){'' if scenes[0].layers is not None else ' without layers'}")
    return room_prior(scenes[0].layers)


class Trainer:
    """State and steps of one run (see module docstring)."""

    def __init__(self, cfg: TrainConfig, scenes: list[SceneTensors], out: Path, sensor: SensorConfig | None = None,
                 val_scenes: list[SceneTensors] | None = None):
        self.cfg, self.out = cfg, out
        self.val_scenes = [s.to(self.device_for(cfg)) for s in val_scenes] if val_scenes else None
        self.best_val, self.bad_evals = float("inf"), 0
        self.rank = int(os.environ.get("RANK", 0))
        self.world = int(os.environ.get("WORLD_SIZE", 1))
        self.device = self.device_for(cfg)
        self.scenes = [s.to(self.device) for s in scenes]
        h, w = scenes[0].ambient.shape[:2]
        self.sensor = sensor or SensorConfig.at((h, w), cfg.sensor)
        torch.manual_seed(cfg.seed)
        ien_cfg = dataclasses.replace(cfg.ien, in_features=scenes[0].x.shape[1])
        self.ien, self.net = IEN(ien_cfg).to(self.device), build_network(cfg.arch, cfg.net).to(self.device)
        self.net.set_targets(torch.cat([s.target for s in self.scenes]))
        from ..render.variation import preset

        variation = preset(cfg.variation)
        self.variation = None if variation.is_ideal else variation  # ideal: the dataset's own photographs
        if cfg.net.project_nuisance:
            self.net.nuisance.set_prior(*room_prior_of(self.scenes))
        self.image_shape = (h, w)
        self.fixed = fixed_illuminations(cfg, scenes)
        self.spot_snr = spot_snr_targets(cfg, self.scenes) if self.fixed is None else None
        self.ien_ddp, self.net_ddp = self.ien, self.net
        if self.world > 1:
            from torch.nn.parallel import DistributedDataParallel as DDP

            self.ien_ddp, self.net_ddp = DDP(self.ien), DDP(self.net)
        groups = [{"params": self.net.parameters(), "lr": cfg.lr}]
        if self.fixed is None:  # a fixed policy leaves the IEN untrained
            groups.insert(0, {"params": self.ien.parameters(), "lr": cfg.lr * cfg.ien_lr_scale})
        self.opt = torch.optim.Adam(groups,
                                    lr=cfg.lr, weight_decay=cfg.weight_decay)
        self.base_lrs = [g["lr"] for g in self.opt.param_groups]
        self.gen = torch.Generator(device=self.device).manual_seed(cfg.seed * 1000 + self.rank)
        self.step = 0
        self.val_lights = None  # per validation scene Illumination: validation rooms of their own

    @staticmethod
    def device_for(cfg: TrainConfig) -> torch.device:
        cuda = cfg.device == "cuda" or (cfg.device == "auto" and torch.cuda.is_available())
        return torch.device(f"cuda:{int(os.environ.get('LOCAL_RANK', 0))}" if cuda else "cpu")

    @property
    def total_steps(self) -> int:
        """Stage 1 (two-stage only) plus the network's steps."""
        return self.cfg.spot_steps + self.cfg.steps

    @property
    def in_spot_stage(self) -> bool:
        return self.step < self.cfg.spot_steps

    @property
    def validation_due(self) -> bool:
        """A validation pass follows this step: every ``eval_every`` network steps and at the last."""
        net_step = self.step - self.cfg.spot_steps
        return self.val_scenes is not None and net_step > 0 and \
            (net_step % self.cfg.eval_every == 0 or self.step == self.total_steps)

    @property
    def stopped_early(self) -> bool:
        """``patience`` validation passes in a row brought no improvement (also true of a resumed run)."""
        return self.cfg.patience > 0 and self.bad_evals >= self.cfg.patience

    def freeze_spots(self) -> None:
        """End of stage 1: each room keeps the IEN's most probable spot (what inference picks).

        Rooms whose people are image samples hold only their stored spots: there the choice is the
        most probable stored spot, and ``unstored_choices`` counts the rooms where the IEN's own
        first choice was not stored (so a report can say how often that restriction bit).
        """
        from ..lighting.base import Illumination

        self.ien.eval()
        with torch.no_grad():
            logits = self.ien_logits(self.scenes)
        self.fixed, self.unstored_choices = [], 0
        for s, lg in zip(self.scenes, logits):
            lg = lg.masked_fill(~s.landed, float("-inf"))
            stored = s.stored if s.stored is not None else torch.ones_like(s.landed)
            best = int(lg.masked_fill(~stored, float("-inf")).argmax())
            self.unstored_choices += int(best != int(lg.argmax()))
            self.fixed.append(Illumination("spot", best))
        self.spot_snr = None

    def set_learning_rate(self) -> None:
        """Cosine decay over the network's steps (a pure function of the step, so resume is exact)."""
        if self.cfg.lr_schedule != "cosine":
            return
        t = min(max(self.step - self.cfg.spot_steps, 0) / max(self.cfg.steps, 1), 1.0)
        factor = 0.01 + 0.99 * 0.5 * (1 + np.cos(np.pi * t))
        for g, base in zip(self.opt.param_groups, self.base_lrs):
            g["lr"] = base * factor

    # ------------------------------------------------------------ one step
    def ien_logits(self, scenes: list[SceneTensors]) -> list[torch.Tensor]:
        """Per scene (T,) IEN logits, from one forward pass over the disjoint union of their graphs.

        One pass keeps DistributedDataParallel to one forward per backward; FeaStConv and the face
        head are local, so the union gives each scene exactly its own logits.
        """
        xs, edges, faces, offset = [], [], [], 0
        for s in scenes:
            xs.append(s.x)
            edges.append(s.edge_index + offset)
            faces.append(s.faces + offset)
            offset += len(s.x)
        prior = torch.cat([s.face_prior for s in scenes]) if all(s.face_prior is not None for s in scenes) else None
        logits = self.ien_ddp(torch.cat(xs), torch.cat(edges, dim=1), torch.cat(faces), prior)
        return list(logits.split([len(s.faces) for s in scenes]))

    def illuminations(self, scenes: list[SceneTensors], train: bool) -> list[tuple]:
        """Per scene (spot vector y (T,) or None, mode, IEN logits or None)."""
        if train and self.cfg.spot_augment and not self.in_spot_stage:
            return [(self.random_stored_spot(s), "spot", None) for s in scenes]
        if self.fixed is not None:
            fixed = [self.fixed[self.scene_index(s)] for s in scenes]
            return [(ill.spot_vector(len(s.faces), self.device), ill.mode, None) for s, ill in zip(scenes, fixed)]
        out = []
        for s, logits in zip(scenes, self.ien_logits(scenes)):
            if train:
                y = straight_through_spot(logits, s.landed, self.cfg.tau, self.gen)
            else:
                y = F.one_hot(logits.masked_fill(~s.landed, float("-inf")).argmax(), len(logits)).float()
            out.append((y, "spot", logits))
        return out

    def random_stored_spot(self, s: SceneTensors) -> torch.Tensor:
        """One-hot y (T,) on a landed candidate whose light every sample of ``s`` holds, uniformly."""
        ok = s.landed if s.stored is None else s.landed & s.stored
        cand = torch.nonzero(ok).flatten()
        pick = cand[torch.randint(len(cand), (1,), generator=self.gen, device=self.device)]
        return F.one_hot(pick[0], len(s.landed)).float()

    def spot_loss(self, s: SceneTensors, logits: torch.Tensor | None) -> torch.Tensor:
        """Auxiliary loss: cross-entropy of the IEN's spot distribution to q = softmax(SNR / max / snr_tau).

        A cross-entropy, not the expected SNR -sum_t p_t SNR_t: its logit gradient p - q never
        vanishes, while the expected SNR's p_t (SNR_t - E_p SNR) dies once p settles on any one
        candidate, which trapped the IEN on dark spots (small preset, 16 rooms).
        """
        target = self.spot_snr[self.scene_index(s)] if self.spot_snr is not None else None
        if logits is None or target is None:
            return torch.zeros((), device=self.device)
        q = torch.softmax((target / self.cfg.snr_tau).masked_fill(~s.landed, float("-inf")), dim=0)
        log_p = torch.log_softmax(logits.masked_fill(~s.landed, float("-inf")), dim=0)
        return -(q * log_p.masked_fill(~s.landed, 0.0)).sum()

    def scene_index(self, s: SceneTensors) -> int:
        return next(i for i, t in enumerate(self.scenes) if t is s)

    def loss_on(self, s: SceneTensors, idx: torch.Tensor, train: bool = True) -> dict:
        """Loss and metrics of samples ``idx`` of scene ``s``."""
        return self.loss_on_many([(s, idx)], train)

    def loss_on_many(self, parts: list[tuple[SceneTensors, torch.Tensor]], train: bool = True) -> dict:
        """Loss and metrics of one batch made of samples ``idx`` of each scene ``s`` in ``parts``.

        The network sees the whole batch in one pass, so its batch-norm statistics mix rooms as
        at test time; each scene is lit by its own spot.
        """
        scenes = [s for s, _ in parts]
        ills = self.illuminations(scenes, train)
        photos = []
        for (s, idx), (y, mode, _) in zip(parts, ills):
            albedo = clothing_albedo(len(idx), self.gen, self.device, self.cfg.clothing) \
                if train and self.cfg.albedo_augment else None
            photos.append(capture(s, idx, y, mode, self.sensor, self.gen, self.cfg.sensor_noise, self.cfg.net,
                                  albedo, self.variation))
        cat = lambda name: torch.cat([getattr(p, name) for p in photos]) if getattr(photos[0], name) is not None \
            else None
        aux_loss = torch.zeros((), device=self.device)
        if self.cfg.aux_weight > 0:
            pos, post, aux = self.net_ddp(cat("images"), cat("background"), cat("clipped"), cat("geometry"),
                                          with_aux=True)
            if any(s.nuisance is None for s, _ in parts):
                raise NlosError("aux_weight: the dataset stores no facing and height labels (regenerate it)")
            aux_loss = F.mse_loss(aux, torch.cat([s.nuisance[idx] for s, idx in parts]))
        else:
            pos, post = self.net_ddp(cat("images"), cat("background"), cat("clipped"), cat("geometry"))
        target = torch.cat([s.target[idx] for s, idx in parts])
        posture = torch.cat([s.posture[idx] for s, idx in parts])
        pos_loss = F.mse_loss(pos, target)
        cls_loss = F.cross_entropy(post, posture)
        err = (pos - target).norm(dim=1)
        spot_loss = torch.stack([self.spot_loss(s, logits) for s, (_, _, logits) in zip(scenes, ills)]).mean()
        y = ills[0][0]
        return {"loss": self.cfg.position_weight * pos_loss + self.cfg.posture_weight * cls_loss
                + self.cfg.snr_weight * spot_loss + self.cfg.aux_weight * aux_loss, "spot_loss": spot_loss,
                "pos_loss": pos_loss, "cls_loss": cls_loss, "err_cm": 100 * err.mean(),
                "acc": (post.argmax(1) == posture).float().mean(),
                "spot": y.argmax() if y is not None else torch.tensor(-1),
                "pred": pos, "logits": post}

    def spot_step(self) -> dict:
        """Stage 1 of two-stage training: the IEN's cross-entropy to its rooms' SNR targets, no images."""
        self.ien.train()
        picks = [int(torch.randint(len(self.scenes), (1,), generator=self.gen, device=self.device))
                 for _ in range(self.cfg.scenes_per_step)]
        scenes = [self.scenes[i] for i in picks]
        if self.spot_snr is None or any(self.spot_snr[i] is None for i in picks):
            raise NlosError("two-stage training: stage 1 needs every room's stored transport (its SNR target)")
        loss = torch.stack([self.spot_loss(s, lg) for s, lg in zip(scenes, self.ien_logits(scenes))]).mean()
        self.opt.zero_grad()
        loss.backward()
        self.opt.step()
        self.step += 1
        if self.step == self.cfg.spot_steps:
            self.freeze_spots()
        nan = float("nan")
        return {"loss": float(loss.detach()), "spot_loss": float(loss.detach()), "pos_loss": nan, "cls_loss": nan,
                "err_cm": nan, "acc": nan, "spot": -1, "scene": picks[0]}

    def train_step(self) -> dict:
        if self.in_spot_stage:
            return self.spot_step()
        self.set_learning_rate()
        self.ien.train()
        self.net.train()
        k = self.cfg.scenes_per_step
        picks, parts = [], []
        for j in range(k):  # for k = 1 the draws are those of one scene per step
            picks.append(int(torch.randint(len(self.scenes), (1,), generator=self.gen, device=self.device)))
            s = self.scenes[picks[-1]]
            n = self.cfg.batch_size // k + (j < self.cfg.batch_size % k)
            parts.append((s, torch.randint(s.num_samples, (n,), generator=self.gen, device=self.device)))
        out = self.loss_on_many(parts)
        self.opt.zero_grad()
        out["loss"].backward()
        self.opt.step()
        self.step += 1
        return {k: float(v.detach()) for k, v in out.items() if k not in ("pred", "logits")} | {"scene": picks[0]}

    def validate(self, batch: int = 64) -> dict:
        """Mean loss, error and accuracy on the validation people of the training rooms, each room under
        the spot the run would use there, with the same sensor noise at every pass. With
        ``val_lights`` (one Illumination per validation scene) the validation scenes are rooms of
        their own (unseen-room validation), each under its given light."""
        self.ien.eval()
        self.net.eval()
        gen = torch.Generator(device=self.device).manual_seed(self.cfg.seed * 1000 + 999)
        tot = {"loss": 0.0, "err_cm": 0.0, "acc": 0.0}
        n = 0
        with torch.no_grad():
            for i, v in enumerate(self.val_scenes):
                if self.val_lights is not None:
                    y, mode = self.val_lights[i].spot_vector(len(v.faces), self.device), self.val_lights[i].mode
                else:
                    (y, mode, _), = self.illuminations([self.scenes[i]], train=False)
                for a in range(0, v.num_samples, batch):
                    idx = torch.arange(a, min(a + batch, v.num_samples), device=self.device)
                    ph = capture(v, idx, y, mode, self.sensor, gen, self.cfg.sensor_noise, self.cfg.net,
                                 variation=self.variation)
                    pos, post = self.net(ph.images, ph.background, ph.clipped, ph.geometry)
                    loss = self.cfg.position_weight * F.mse_loss(pos, v.target[idx], reduction="sum") / 2 \
                        + self.cfg.posture_weight * F.cross_entropy(post, v.posture[idx], reduction="sum")
                    tot["loss"] += float(loss)
                    tot["err_cm"] += float(100 * (pos - v.target[idx]).norm(dim=1).sum())
                    tot["acc"] += float((post.argmax(1) == v.posture[idx]).sum())
                    n += len(idx)
        return {k: v / max(n, 1) for k, v in tot.items()}

    # ------------------------------------------------------------ checkpoints
    def state(self) -> dict:
        from ..data.generate import versions

        return {"step": self.step, "ien": self.ien.state_dict(), "net": self.net.state_dict(),
                "opt": self.opt.state_dict(), "gen": self.gen.get_state(), "torch_rng": torch.get_rng_state(),
                "config": self.cfg.to_dict(), "versions": versions(), "in_features": self.ien.cfg.in_features,
                "image_shape": list(self.image_shape), "format": CHECKPOINT_FORMAT,
                "best_val": float(self.best_val), "bad_evals": int(self.bad_evals)}

    def save(self, path: Path) -> None:
        if self.rank != 0:
            return
        tmp = path.with_name(f".{path.name}.tmp")
        torch.save(self.state(), tmp)
        os.replace(tmp, path)

    def load(self, path: Path) -> None:
        from .checkpoint import read_checkpoint

        st = read_checkpoint(path, self.device)
        try:
            self.ien.load_state_dict(st["ien"])
            self.net.load_state_dict(st["net"])
            self.opt.load_state_dict(st["opt"])
        except Exception as exc:  # torch raises many types on torn or foreign files
            raise NlosError(f"{path}: corrupted or incompatible checkpoint ({type(exc).__name__})") from None
        self.gen.set_state(st["gen"])
        torch.set_rng_state(st["torch_rng"])  # numpy's and Python's global RNGs are never drawn from: not stored
        self.step = st["step"]
        self.best_val, self.bad_evals = st.get("best_val", float("inf")), st.get("bad_evals", 0)
        if self.cfg.spot_steps > 0 and self.step >= self.cfg.spot_steps:
            self.freeze_spots()


def check_config(cfg: TrainConfig) -> None:
    """One-line errors for settings no run can use."""
    if not 1 <= cfg.scenes_per_step <= cfg.batch_size:
        raise NlosError(f"config: scenes_per_step must be in 1..batch_size ({cfg.batch_size}), "
                        f"got {cfg.scenes_per_step}")
    for name in ("holdout_every", "val_every"):
        if getattr(cfg, name) == 1 or getattr(cfg, name) < 0:
            raise NlosError(f"config: {name} must be 0 (none) or at least 2, got {getattr(cfg, name)}")
    for name in ("steps", "eval_every"):
        if getattr(cfg, name) < 1:
            raise NlosError(f"config: {name} must be at least 1, got {getattr(cfg, name)}")
    for name in ("spot_steps", "patience"):
        if getattr(cfg, name) < 0:
            raise NlosError(f"config: {name} must be at least 0, got {getattr(cfg, name)}")
    from ..world.body import CLOTHING_RANGES

    if cfg.clothing not in CLOTHING_RANGES:
        raise NlosError(f"config: clothing must be one of {', '.join(CLOTHING_RANGES)}, got {cfg.clothing!r}")
    if cfg.select not in ("loss", "metrics", "last"):
        raise NlosError(f"config: select must be 'loss', 'metrics' or 'last', got {cfg.select!r}")
    if cfg.lr_schedule not in ("constant", "cosine"):
        raise NlosError(f"config: lr_schedule must be 'constant' or 'cosine', got {cfg.lr_schedule!r}")
    if cfg.spot_steps > 0 and cfg.policy != "ien":
        raise NlosError(f"config: spot_steps (two-stage training) trains the IEN; policy is '{cfg.policy}'")
    if cfg.aux_weight > 0 and not cfg.net.aux_head:
        raise NlosError("config: aux_weight needs the network's auxiliary head (net.aux_head: true)")
    if cfg.spot_augment and cfg.policy == "ien" and cfg.spot_steps == 0:
        raise NlosError("config: spot_augment lights training rooms by random stored spots, so the IEN gets no "
                        "task gradient: use a fixed policy or two-stage training (spot_steps > 0)")


def split_validation(s: SceneTensors, every: int) -> tuple[SceneTensors, SceneTensors | None]:
    """A training room's samples -> (trained on, validation): every n-th static sample validates."""
    if every <= 0:
        return s, None
    k = torch.arange(s.num_samples, device=s.posture.device)
    val = (s.trajectory[:, 0] < 0) & (k % every == every - 1)
    return s.subset(torch.nonzero(~val).flatten()), s.subset(torch.nonzero(val).flatten())


def selection_score(row: dict, select: str, step: int) -> float:
    """What a validation pass minimizes to pick the best weights (``TrainConfig.select``): the loss;
    'metrics': posture error rate + localization error in m (1 cm weighs as one point of accuracy);
    'last': the latest weights."""
    if select == "metrics":
        return (1.0 - row["acc"]) + row["err_cm"] / 100.0
    if select == "last":
        return -float(step)
    return row["loss"]


def _validation_pass(tr: Trainer, out: Path) -> bool:
    """Score the validation people; keep the best weights in best.pt. Returns True to stop early."""
    row = tr.validate()
    path = out / "validation.csv"
    if tr.rank == 0:
        new = not path.exists()
        with path.open("a", newline="") as f:
            w = csv.writer(f)
            if new:
                w.writerow(["step", "loss", "err_cm", "acc"])
            w.writerow([tr.step, row["loss"], row["err_cm"], row["acc"]])
    score = selection_score(row, tr.cfg.select, tr.step)
    if score < tr.best_val:
        tr.best_val, tr.bad_evals = score, 0
        tr.save(out / "best.pt")
    else:
        tr.bad_evals += 1
    return tr.stopped_early


def truncate_log(path: Path, step: int) -> None:
    """Drop the rows of a CSV log whose ``step`` is after ``step`` (a run killed between writing a
    row and its next checkpoint repeats those steps on resume); atomic."""
    if not path.exists():
        return
    with path.open(newline="") as f:
        rows = list(csv.reader(f))
    if not rows or "step" not in rows[0]:
        return
    col = rows[0].index("step")
    keep = [rows[0]] + [r for r in rows[1:] if len(r) > col and r[col].isdigit() and int(r[col]) <= step]
    if len(keep) == len(rows):
        return
    tmp = path.with_name(f".{path.name}.tmp")
    with tmp.open("w", newline="") as f:
        csv.writer(f).writerows(keep)
    os.replace(tmp, path)


def train(cfg: TrainConfig, data_dir: str | Path, out: str | Path, resume: bool = False,
          progress: bool = True) -> Trainer:
    """Train (or resume) a run in ``out``: config.json, metrics.csv, checkpoint.pt, final.pt
    (with validation also validation.csv and best.pt; final.pt then holds the best weights).

    metrics.csv's ``spot`` and ``scene`` columns name the first room of each step's batch.
    """
    from ..console import QUIET, console

    out = Path(out)
    distributed = int(os.environ.get("WORLD_SIZE", 1)) > 1
    if distributed and not torch.distributed.is_initialized():
        backend = "nccl" if torch.cuda.is_available() and cfg.device != "cpu" else "gloo"
        torch.distributed.init_process_group(backend)
    out.mkdir(parents=True, exist_ok=True)
    ckpt = out / "checkpoint.pt"
    if (out / "config.json").exists() and not resume and ckpt.exists():
        raise NlosError(f"{out} holds a run; pass --resume to continue it or choose another --out")
    check_config(cfg)
    keep = lambda s: room_samples(s, cfg.holdout_every, held=False)
    scenes = load_split(data_dir, "train", cfg.ien_features, keep=keep)
    parts = [split_validation(s, cfg.val_every) for s in scenes]
    val = [v for _, v in parts] if cfg.val_every > 0 else None
    tr = Trainer(cfg, [t for t, _ in parts], out, val_scenes=val)
    if resume and ckpt.exists():
        tr.load(ckpt)
        for log in ("metrics.csv", "validation.csv"):  # rows written after the checkpoint are redone
            truncate_log(out / log, tr.step)
    if tr.rank == 0:
        (out / "config.json").write_text(json.dumps({"train": cfg.to_dict(), "data": str(data_dir)}, indent=1))
    metrics = out / "metrics.csv"
    fields = ["step", "loss", "pos_loss", "cls_loss", "spot_loss", "err_cm", "acc", "spot", "scene", "seconds"]
    if tr.rank == 0 and (not metrics.exists() or tr.step == 0):
        with metrics.open("w", newline="") as f:
            csv.writer(f).writerow(fields)
    t0 = time.perf_counter()
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    cols = (TextColumn("train"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(), TextColumn("{task.description}"))
    stop = tr.stopped_early
    with Progress(*cols, console=console, disable=QUIET or not progress or tr.rank != 0) as bar:
        task = bar.add_task("", total=tr.total_steps, completed=tr.step)
        while tr.step < tr.total_steps and not stop:
            row = tr.train_step()
            bar.update(task, advance=1, description=f"loss {row['loss']:.3f} err {row['err_cm']:.0f} cm")
            if tr.rank == 0 and (tr.step % cfg.log_every == 0 or tr.step == tr.total_steps):
                with metrics.open("a", newline="") as f:
                    csv.writer(f).writerow([tr.step] + [row[k] for k in fields[1:-1]] + [time.perf_counter() - t0])
            if tr.validation_due:
                stop = _validation_pass(tr, out)
            if tr.step % cfg.ckpt_every == 0 or tr.step == tr.total_steps or stop:
                tr.save(ckpt)
    if val is not None and (out / "best.pt").exists():
        tr.load(out / "best.pt")
    tr.save(out / "final.pt")
    if distributed:
        torch.distributed.barrier()
    return tr
