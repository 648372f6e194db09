"""Load a trained run for inference: the IEN, the NLOS network, their config and the image size.

A checkpoint (``RUN/final.pt`` or ``RUN/checkpoint.pt``, written by ``nlos train``) holds the
models, the optimizer and RNG states, the resolved :class:`TrainConfig`, package versions, the
IEN's input width and the training image shape (H, W). Any unreadable or foreign file is one
:class:`NlosError` naming the file.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import torch
from torch import nn

from ..errors import NlosError
from ..models.ien import IEN
from ..models.registry import build_network
from .config import TrainConfig


@dataclass
class TrainedModels:
    """A trained run, in eval mode."""

    ien: IEN
    """The Illumination Estimation Network (meaningful when ``config.policy == 'ien'``)."""
    net: nn.Module
    """The NLOS network: images (B, H, W, 3) -> position (B, 2) m, posture logits (B, 6)."""
    config: TrainConfig
    """The run's resolved training config."""
    image_shape: tuple[int, int]
    """(H, W) of the training images; inputs are resized to it."""
    path: Path
    """The checkpoint file."""
    step: int
    """Optimizer steps trained."""


def resolve_checkpoint(path: str | Path) -> Path:
    """A checkpoint file, or a run directory (its final.pt, else its checkpoint.pt)."""
    p = Path(path)
    if p.is_dir():
        for name in ("final.pt", "checkpoint.pt"):
            if (p / name).is_file():
                return p / name
        raise NlosError(f"{p}: no final.pt or checkpoint.pt in this run directory")
    if not p.is_file():
        raise NlosError(f"{p}: checkpoint not found")
    return p


def load_trained(path: str | Path, device: str | torch.device = "cpu") -> TrainedModels:
    """Load models for inference from a checkpoint file or run directory."""
    p = resolve_checkpoint(path)
    try:
        st = torch.load(p, map_location=device, weights_only=False)
    except Exception as exc:  # torch raises many types on torn or foreign files
        raise NlosError(f"{p}: corrupted or not a checkpoint ({type(exc).__name__})") from None
    if not isinstance(st, dict) or not {"ien", "net", "config"} <= set(st):
        raise NlosError(f"{p}: not an nlos-spotlight checkpoint (missing models or config)")
    try:
        cfg = TrainConfig.from_dict(st["config"])
        ien = IEN(dataclasses.replace(cfg.ien, in_features=int(st.get("in_features", 3))))
        ien.load_state_dict(st["ien"])
        net = build_network(cfg.arch, cfg.net)
        net.load_state_dict(st["net"])
    except NlosError:
        raise
    except Exception as exc:
        raise NlosError(f"{p}: incompatible checkpoint ({type(exc).__name__}: {str(exc).splitlines()[0][:120]})") \
            from None
    shape = tuple(int(v) for v in st.get("image_shape", (32, 32)))
    return TrainedModels(ien.to(device).eval(), net.to(device).eval(), cfg, shape, p, int(st.get("step", 0)))
