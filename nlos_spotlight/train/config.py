"""Typed training configuration with named presets; the resolved config is saved beside every run."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from ..errors import NlosError
from ..models.ien import IENConfig
from ..models.nlos_net import NLOSNetConfig


@dataclass
class TrainConfig:
    """Everything that determines a training run (with the data and the code version)."""

    name: str = "tiny"
    """Preset or file name."""
    seed: int = 0
    """Seed of initialization, batch order, Gumbel noise and sensor noise."""
    steps: int = 40
    """Optimizer steps."""
    batch_size: int = 8
    """Samples per step, split evenly over ``scenes_per_step`` scenes."""
    scenes_per_step: int = 1
    """Scenes (rooms) per step, each under its own spot; more than one gives batch norm a mix of rooms."""
    lr: float = 1e-3
    """Adam learning rate (the paper: 1e-2)."""
    weight_decay: float = 1e-5
    """Adam weight decay (the paper's value)."""
    ien_lr_scale: float = 10.0
    """Learning-rate multiplier for the IEN (10: the IEN at the paper's 1e-2 while the CNN uses 1e-3)."""
    tau: float = 0.5
    """Gumbel-softmax temperature of the straight-through spot choice."""
    sensor_noise: bool = True
    """Simulate the camera (metering, shot/read/quantization noise, clipping) on every image, afresh each step."""
    sensor: dict = field(default_factory=dict)
    """Capture settings over the default camera (``render.sensor.SensorConfig`` fields, e.g. burst_frames)."""
    position_weight: float = 1.0
    """Weight of the position MSE (m^2) in the loss."""
    posture_weight: float = 1.0
    """Weight of the posture cross-entropy."""
    arch: str = "resnet18"
    """NLOS network architecture (``models.registry.NETWORKS``: resnet18, or a baseline)."""
    policy: str = "ien"
    """Spot policy: 'ien' (learned end to end) or a fixed one of ``lighting.POLICIES`` (IEN not trained)."""
    snr_weight: float = 0.0
    """Weight of the auxiliary spot loss: cross-entropy to softmax(SNR / max SNR / snr_tau) (0: task loss only)."""
    snr_tau: float = 0.05
    """Temperature of that target: candidates 0.05 below the best SNR (relative) get e^-1 of its weight."""
    holdout_every: int = 0
    """Hold every n-th static sample of each training room out of training (the seen-rooms test; 0: none)."""
    spot_steps: int = 0
    """Two-stage training: steps of stage 1 (the IEN on its SNR target alone) before the network trains
    under the IEN's frozen spots for ``steps`` more; 0 trains end to end."""
    val_every: int = 0
    """Validation: every n-th trained-on static sample of each training room is held out of the gradient
    and scored every ``eval_every`` steps; the best-scoring weights become final.pt (0: none)."""
    eval_every: int = 100
    """Steps between validation passes."""
    patience: int = 0
    """Stop after this many validation passes without improvement (0: never stop early)."""
    select: str = "loss"
    """Best weights by validation 'loss', by 'metrics' (posture errors + localization error in m) or
    the 'last' ones: noise-free, the loss rises with overconfidence while accuracy still improves."""
    lr_schedule: str = "constant"
    """'constant' or 'cosine' (from lr down to lr / 100 over the network's steps)."""
    aux_weight: float = 0.0
    """Weight of the auxiliary nuisance loss, the MSE of (cos, sin) facing and height (m) (needs
    ``net.aux_head``; 0: none): the arms change the walls' light much as facing and height do."""
    spot_augment: bool = False
    """Training only: each room lit by one of its stored, landed spots drawn afresh every step (for a
    network that reads the lit channel, ``net.geometry``); validation and tests use the policy's spot."""
    albedo_augment: bool = False
    """Training only: every drawn person is dressed afresh in a clothing albedo from the dataset's own
    distribution (``world.body.clothing_albedo``), exact because the person's light is linear in it."""
    clothing: str = "dataset"
    """The albedo distribution of ``albedo_augment`` (``world.body.CLOTHING_RANGES``): 'dataset' (the
    rendered people's own) or 'camera' (black to white fabric)."""
    variation: str = "ideal"
    """Capture variation (a ``render.variation`` preset: ideal, tripod, rough) in every training and
    validation photograph: the person capture and its empty-room capture differ as real ones do
    (camera motion, projector, spot and ambient drift; needs the room's static layers)."""
    ien_features: list[str] = field(default_factory=lambda: ["normals"])
    """Extra IEN vertex features besides coordinates: 'normals'."""
    ien: IENConfig = field(default_factory=IENConfig)
    """IEN architecture."""
    net: NLOSNetConfig = field(default_factory=NLOSNetConfig)
    """NLOS network architecture."""
    ckpt_every: int = 20
    """Steps between checkpoints."""
    log_every: int = 5
    """Steps between metric rows."""
    device: str = "auto"
    """'cpu', 'cuda' or 'auto'."""

    def __post_init__(self) -> None:
        for k in ("steps", "batch_size", "scenes_per_step", "eval_every", "ckpt_every", "log_every"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise NlosError(f"config: {k} must be an integer of at least 1, got {v!r}")
        for k in ("seed", "spot_steps", "patience", "holdout_every", "val_every"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise NlosError(f"config: {k} must be a non-negative integer, got {v!r}")
        for k in ("lr", "tau", "snr_tau"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < float("inf"):
                raise NlosError(f"config: {k} must be a positive number, got {v!r}")
        for k in ("weight_decay", "ien_lr_scale", "position_weight", "posture_weight", "snr_weight", "aux_weight"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 <= v < float("inf"):
                raise NlosError(f"config: {k} must be a non-negative number, got {v!r}")

        from ..render.variation import preset

        preset(self.variation)  # a one-line error for an unknown name

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "TrainConfig":
        d = dict(d)
        ien, net = IENConfig(**d.pop("ien", {})), NLOSNetConfig(**d.pop("net", {}))
        return cls(**d, ien=ien, net=net)


PRESETS = {
    "tiny": TrainConfig(),
    "demo": TrainConfig(name="demo", steps=150, batch_size=16, scenes_per_step=4, ckpt_every=50, log_every=10,
                        snr_weight=1.0, holdout_every=6, net=NLOSNetConfig(background_subtract=True)),
    "small": TrainConfig(name="small", steps=600, batch_size=16, scenes_per_step=4, ckpt_every=100, log_every=20,
                         snr_weight=1.0, holdout_every=6, net=NLOSNetConfig(background_subtract=True)),
    "paper": TrainConfig(name="paper", steps=20000, batch_size=64, scenes_per_step=4, lr=1e-2, ien_lr_scale=1.0,
                         ckpt_every=1000, log_every=100, snr_weight=1.0, holdout_every=6,
                         net=NLOSNetConfig(background_subtract=True)),
}


def load_train_config(spec: str) -> TrainConfig:
    """A preset name or a YAML file of TrainConfig fields (optionally ``base: PRESET``); nested
    ``ien`` and ``net`` take mappings of their fields (``config_file.load_config_file``)."""
    from ..config_file import load_config_file

    return load_config_file(spec, PRESETS)[0]
