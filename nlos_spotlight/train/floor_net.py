"""FloorNet across rooms: its training, its reading of a room's photographs, and its checkpoint.

FloorNet (``models/floor_net.py``) reads the matched-filter backprojection of a photograph onto
the hidden floor (``data/backprojection.py``), whose meaning is the same in every room, so one
network trained on many rooms' people reads rooms it never saw: 46.2 cm on 40 unseen rooms
against 88.6 cm for the image networks (docs/results.md, Tables 1-3). Training draws a few rooms a
step, a spot each, and a few people each, with the default capture's sensor noise drawn afresh
every step (Gaussian in luminance, the empty-room frame's included), and keeps the weights of the
lowest validation error.

    nlos train --method floor-net default --data DATA --out RUN      (RUN/floor_net.pt, floor_net.json)

A checkpoint is the state dict (read as data only: ``train.checkpoint.read_checkpoint``) and a
JSON beside it with the training config, the training rooms' mean position and the validation
curve. Runs of experiments/backprojection-across-rooms/backprojection_net.py (``run.json``
instead) load too.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np
import torch

from ..errors import NlosError

CAPTURES = ("photo", "spot")
"""What the filter reads. 'photo': the photograph minus the empty-room one (the networks' input: the
person's light from the spot and from the room's ambient light). 'spot': also a projector-off
photograph with the person and one without, so that (on - off with) - (on - off without) leaves the
person's light from the spot alone, at the noise of four frames."""
MASKS = ("placement", "free")
"""Floor cells a person may stand in (``data.backprojection.FloorGrid.mask``)."""


@dataclass
class FloorNetTraining:
    """How FloorNet is trained across rooms (the published run: 200 rooms, 3,000 steps, seeds 0-2)."""

    rooms: int = 200
    """Training rooms (the first of the dataset's train split)."""
    steps: int = 3000
    """Optimizer steps (one-cycle learning rate)."""
    rooms_per_step: int = 4
    """Rooms drawn per step, a stored spot each."""
    people_per_room: int = 16
    """People drawn per room and step."""
    lr: float = 2e-3
    """Peak learning rate (AdamW, weight decay 1e-4)."""
    templates: int = 1
    """1: the spot's matched filter; 2: also the filter of a person lit evenly (its ambient light)."""
    capture: str = "photo"
    """What the filter reads (:data:`CAPTURES`)."""
    mask: str = "placement"
    """Floor cells a person may stand in (:data:`MASKS`)."""
    posture_weight: float = 0.3
    """Weight of the posture cross-entropy beside the position error (m)."""
    validate_every: int = 250
    """Steps between validation errors (the best weights are kept)."""
    seed: int = 0
    """Noise, room, spot and people draws."""
    name: str = "default"
    """Preset or config file name."""

    def check(self) -> "FloorNetTraining":
        """Itself, or a one-line :class:`NlosError` naming the first bad field."""
        for k in ("rooms", "steps", "rooms_per_step", "people_per_room", "validate_every"):
            if not isinstance(getattr(self, k), int) or getattr(self, k) < 1:
                raise NlosError(f"floor-net: {k} must be a positive integer, got {getattr(self, k)!r}")
        if not 0 < self.lr < 1:
            raise NlosError(f"floor-net: lr must be in (0, 1), got {self.lr}")
        if self.templates not in (1, 2):
            raise NlosError(f"floor-net: templates must be 1 or 2, got {self.templates}")
        if self.capture not in CAPTURES or self.mask not in MASKS:
            raise NlosError(f"floor-net: capture must be one of {CAPTURES} and mask one of {MASKS}")
        return self


PRESETS = {
    "default": FloorNetTraining(),
    # tests and a first look: a few rooms, tens of steps
    "tiny": FloorNetTraining(name="tiny", rooms=4, steps=20, rooms_per_step=2, people_per_room=4, validate_every=10),
}


def room_arrays(d: Path, faces: list[int] | None, samples: str, capture: str = "photo",
                mask: str = "placement") -> dict:
    """What training and reading need of one room: its templates' parts, and its people's photographs
    (luminance, background-subtracted, noise-free; ``capture`` of :data:`CAPTURES`) and noise variance
    under each spot of ``faces`` (None: the room's stored spots); ``samples``: 'images' or 'transport'."""
    from ..data.backprojection import FloorGrid, candidate_spot_factor, room_backprojector
    from ..data.tensors import load_scene_tensors
    from ..render.sensor import SensorConfig
    from .imaging import form_images, radiance_variance

    s = load_scene_tensors(d, [], samples=samples)
    grid = FloorGrid(mask=mask)
    bp, _ = room_backprojector(str(d), grid)
    sensor = SensorConfig.at(tuple(s.ambient.shape[:2]))
    faces = faces if faces is not None else [int(f) for f in torch.nonzero(s.stored).flatten()]
    hit = torch.as_tensor(bp.hit.ravel())
    imgs, var, spots = [], [], []
    idx = torch.arange(s.num_samples)
    for f in faces:
        y = torch.zeros(len(s.faces))
        y[f] = 1.0
        with torch.no_grad():
            img, pf = form_images(s, idx, y, "spot")
        v = 2 * radiance_variance(pf, pf, sensor)  # photograph and empty-room frame
        person = img - pf
        if capture == "spot":  # the two projector-off frames, at the same exposure
            v = v + 2 * radiance_variance(s.ambient, pf, sensor)
            person = person - s.nlos_ambient
        imgs.append(person.mean(-1).reshape(len(idx), -1)[:, hit])
        var.append((v.sum(-1) / 9).reshape(-1)[hit])
        spots.append(candidate_spot_factor(str(d), f, grid))
    return dict(kernel=torch.as_tensor(bp.kernel, dtype=torch.float32), valid=torch.as_tensor(bp.valid),
                cells=torch.as_tensor(bp.cells, dtype=torch.float32), heights=bp.heights,
                spots=torch.as_tensor(np.stack(spots), dtype=torch.float32), images=torch.stack(imgs, 1).float(),
                var=torch.stack(var).float(), target=s.target, posture=s.posture, faces=faces,
                trajectory=s.trajectory)


def heat(room: dict, k: int, people: torch.Tensor, gen: torch.Generator | None, templates: int = 1):
    """(B, M Z, G, G) noise-weighted matched filters of ``people`` under the room's k-th spot (fresh
    noise from ``gen``; None: noise-free): the spot's templates, and with ``templates`` 2 the kernel
    alone (a person lit evenly); the spot templates' norms (G, G)."""
    from ..data.backprojection import matched_filter

    w = 1.0 / room["var"][k]
    x = room["images"][people, k]
    if gen is not None:
        x = x + torch.randn(x.shape, generator=gen) * room["var"][k].sqrt()
    n = int(round(len(room["cells"]) ** 0.5))
    hs, strength = [], None
    for t in [room["spots"][k][:, None] * room["kernel"], room["kernel"]][:templates]:  # (P, C)
        hs.append(matched_filter(x, t, w).reshape(len(people), -1, n, n))
        if strength is None:
            strength = ((t * t) @ w).sqrt().reshape(room["heights"], n, n).amax(0)
    return torch.cat(hs, 1), strength


def argmax_cell(room: dict, h: torch.Tensor) -> torch.Tensor:
    """(B, 2) the valid cell where the spot's filter (the first Z channels of ``h``) peaks: the
    matched filter's own answer."""
    m = h[:, : room["heights"]].amax(1).reshape(len(h), -1).masked_fill(~room["valid"][None], -torch.inf)
    return room["cells"][m.argmax(1)]


def predict(net, room: dict, k: int, people: torch.Tensor, gen) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """FloorNet on ``people`` of ``room`` under its k-th spot: position (B, 2) m, posture logits
    (B, P), and the matched filter's peak cell (B, 2)."""
    h, strength = heat(room, k, people, gen, net.cfg.templates)
    n = h.shape[-1]
    valid = room["valid"].reshape(n, n)
    pos, logits, _ = net(h, valid.expand(len(h), -1, -1), strength.expand(len(h), -1, -1), room["cells"])
    return pos, logits, argmax_cell(room, h)


@dataclass
class FloorNetRun:
    """A trained FloorNet and what scoring it needs."""

    net: torch.nn.Module
    """FloorNet, in eval mode."""
    mean_xy: torch.Tensor
    """(2,) the training rooms' mean position (the mean answer, in the region frame)."""
    config: FloorNetTraining
    """How it was trained."""
    curve: list
    """[(step, validation error cm)]."""
    best_cm: float
    """The kept weights' validation error (cm)."""


def validation_error(net, rooms: list[dict], seed: int = 12345) -> float:
    """Mean position error (cm) over every person and stored spot of ``rooms``, one noise draw."""
    g = torch.Generator().manual_seed(seed)
    was = net.training
    net.eval()
    errs = []
    with torch.no_grad():
        for r in rooms:
            for k in range(len(r["faces"])):
                pos, _, _ = predict(net, r, k, torch.arange(len(r["target"])), g)
                errs.append((pos - r["target"]).norm(dim=1))
    net.train(was)
    return float(torch.cat(errs).mean()) * 100


def train_floor_net(cfg: FloorNetTraining, train: list[dict], val: list[dict], log=None) -> FloorNetRun:
    """FloorNet trained on the rooms ``train`` (:func:`room_arrays`), the weights of its lowest
    validation error on ``val`` kept (``train`` itself when ``val`` is empty)."""
    from ..models.floor_net import FloorNet, FloorNetConfig

    cfg.check()
    if not train:
        raise NlosError("floor-net: no training rooms with people")
    val = val or train
    torch.manual_seed(cfg.seed)
    mean_xy = torch.cat([r["target"] for r in train]).mean(0)
    net = FloorNet(FloorNetConfig(heights=train[0]["heights"], templates=cfg.templates))
    opt = torch.optim.AdamW(net.parameters(), lr=cfg.lr, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, cfg.lr, total_steps=cfg.steps)
    gen = torch.Generator().manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    curve, best, best_state = [], float("inf"), None
    for step in range(1, cfg.steps + 1):
        loss = 0.0
        picked = rng.choice(len(train), min(cfg.rooms_per_step, len(train)), replace=False)
        for i in picked:
            r = train[i]
            k = int(rng.integers(len(r["faces"])))
            people = torch.as_tensor(rng.choice(len(r["target"]), min(cfg.people_per_room, len(r["target"])),
                                                replace=False))
            pos, logits, _ = predict(net, r, k, people, gen)
            loss = loss + (pos - r["target"][people]).norm(dim=1).mean() \
                + cfg.posture_weight * torch.nn.functional.cross_entropy(logits, r["posture"][people])
        opt.zero_grad()
        (loss / len(picked)).backward()
        opt.step()
        sched.step()
        if step % cfg.validate_every == 0 or step == cfg.steps:
            e = validation_error(net, val)
            curve.append((step, e))
            if e < best:
                best, best_state = e, {k: v.clone() for k, v in net.state_dict().items()}
            if log is not None:
                log(f"step {step}: validation {e:.1f} cm (best {best:.1f})")
    net.load_state_dict(best_state)
    return FloorNetRun(net.eval(), mean_xy, cfg, curve, best)


WEIGHTS = "floor_net.pt"
"""The state dict in a run directory."""
META = "floor_net.json"
"""Its training config, mean position and validation curve."""


def save_floor_net(run: FloorNetRun, out: Path, extra: dict | None = None) -> Path:
    """Write ``out/floor_net.pt`` and ``out/floor_net.json`` atomically; returns the weights' path."""
    from ..data.store import atomic_json

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / f".{WEIGHTS}.tmp"
    torch.save(run.net.state_dict(), tmp)
    tmp.replace(out / WEIGHTS)
    atomic_json(out / META, {"format": "nlos-floor-net/1", "training": asdict(run.config),
                             "heights": run.net.cfg.heights, "mean_xy": run.mean_xy.tolist(),
                             "validation_cm": run.curve, "best_validation_cm": run.best_cm, **(extra or {})})
    return out / WEIGHTS


def _meta(run_dir: Path) -> dict:
    """``floor_net.json``, or an experiment run's ``run.json`` in the same terms."""
    for name in (META, "run.json"):
        p = run_dir / name
        if p.is_file():
            try:
                d = json.loads(p.read_text())
            except (json.JSONDecodeError, UnicodeDecodeError):
                raise NlosError(f"{p}: corrupted (invalid JSON)") from None
            if not isinstance(d, dict):
                raise NlosError(f"{p}: not a FloorNet run record")
            if name == "run.json":  # backprojection_net.py: its arguments as strings
                a = d.get("args", {})
                known = {f.name for f in fields(FloorNetTraining)}
                tr = {k: type(getattr(FloorNetTraining(), k))(v) for k, v in a.items() if k in known and k != "name"}
                d = {"training": tr, "mean_xy": d.get("mean_xy"), "validation_cm": d.get("validation_cm", []),
                     "best_validation_cm": d.get("best_validation_cm", float("nan"))}
            return d
    raise NlosError(f"{run_dir}: no {META} (not a FloorNet run: nlos train --method floor-net writes one)")


def load_floor_net(run_dir: str | Path) -> FloorNetRun:
    """A FloorNet run directory (:func:`save_floor_net`) for reading, with one-line errors for a
    missing, torn or foreign checkpoint. The weights are read as data only."""
    from ..models.floor_net import FloorNet, FloorNetConfig
    from .checkpoint import read_checkpoint

    run_dir = Path(run_dir)
    if not (run_dir / WEIGHTS).is_file():
        raise NlosError(f"{run_dir}: no {WEIGHTS} (not a FloorNet run)")
    meta = _meta(run_dir)
    try:
        cfg = FloorNetTraining(**meta.get("training", {}))
        net = FloorNet(FloorNetConfig(heights=int(meta.get("heights", 3)), templates=cfg.templates))
        net.load_state_dict(read_checkpoint(run_dir / WEIGHTS))
    except NlosError:
        raise
    except Exception as exc:
        raise NlosError(f"{run_dir / WEIGHTS}: incompatible FloorNet checkpoint ({type(exc).__name__})") from None
    mean = meta.get("mean_xy")
    mean_xy = torch.as_tensor(mean if mean is not None else [0.0, 0.0], dtype=torch.float32)
    return FloorNetRun(net.eval(), mean_xy, cfg, [tuple(c) for c in meta.get("validation_cm", [])],
                       float(meta.get("best_validation_cm", float("nan"))))


TRANSPORT_SPOTS = 8
"""Spots a room with full-transport people only trains under: its candidates of highest SNR."""


def _training_room(d: Path, cfg: FloorNetTraining) -> dict:
    """A training room's arrays: its image samples under their stored spots, or where it holds only
    full-transport samples, those under its :data:`TRANSPORT_SPOTS` best candidates."""
    if any((Path(d) / "images").glob("*.npz")):
        return room_arrays(d, None, "images", cfg.capture, cfg.mask)
    from ..lighting.snr import candidate_snr

    best = np.argsort(-candidate_snr(Path(d)))[:TRANSPORT_SPOTS]
    return room_arrays(d, [int(f) for f in best], "transport", cfg.capture, cfg.mask)


def train_run(cfg: FloorNetTraining, data: Path, out: Path, log=None) -> FloorNetRun:
    """``nlos train --method floor-net``: FloorNet on the dataset's train split (its first
    ``cfg.rooms`` rooms), validated on its val split, saved in ``out`` with the run's record."""
    from ..data.generate import versions
    from ..data.tensors import finished_scene_dirs

    t0 = time.perf_counter()
    arrays = lambda dirs: [_training_room(d, cfg) for d in dirs]
    train = arrays(finished_scene_dirs(data, "train")[: cfg.rooms])
    val = arrays(finished_scene_dirs(data, "val"))
    if log is not None:
        log(f"{len(train)} training and {len(val)} validation rooms ready ({time.perf_counter() - t0:.0f} s)")
    run = train_floor_net(cfg, train, val, log)
    save_floor_net(run, out, {"data": str(Path(data).resolve()), "train_rooms": len(train), "val_rooms": len(val),
                              "seconds": time.perf_counter() - t0, "versions": versions()})
    return run


__all__ = ["CAPTURES", "FloorNetRun", "FloorNetTraining", "PRESETS", "argmax_cell", "heat", "load_floor_net",
           "predict", "room_arrays", "save_floor_net", "train_floor_net", "train_run", "validation_error"]
