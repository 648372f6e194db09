"""Load a trained run for inference: the IEN, the NLOS network, their config and the image size.

A checkpoint (``RUN/final.pt`` or ``RUN/checkpoint.pt``, written by ``nlos train``) holds the
models, the optimizer and RNG states, the resolved :class:`TrainConfig`, package versions, the
IEN's input width and the training image shape (H, W). Any unreadable or foreign file is one
:class:`NlosError` naming the file. Checkpoints are read as data only (:func:`read_checkpoint`):
loading one never runs code.
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


def _numpy_globals() -> list:
    """numpy's array and scalar constructors: data only (an object array's items still pass the same
    restricted unpickler), in checkpoints written before the numpy RNG state was stored as a list."""
    import numpy as np

    core = getattr(np, "_core", None) or np.core
    dtypes = [type(np.dtype(t)) for t in ("uint32", "int64", "float64", "float32", "bool")]
    return [np.ndarray, np.dtype, core.multiarray._reconstruct, core.multiarray.scalar, *dtypes]


def read_checkpoint(path: Path, device: str | torch.device = "cpu") -> dict:
    """A checkpoint's content, read so that it cannot run code: tensors and plain data only
    (``torch.load(weights_only=True)``; a room model is a file people share). A file holding
    anything else is refused in one :class:`NlosError` line, as is a torn or foreign one."""
    import pickle

    try:
        with torch.serialization.safe_globals(_numpy_globals()):
            st = torch.load(path, map_location=device, weights_only=True)
    except pickle.UnpicklingError as exc:
        import re

        found = re.search(r"Unsupported global: GLOBAL (\S+)", str(exc))
        if found:
            raise NlosError(f"{path}: refused: it holds Python objects ({found.group(1)}), not only tensors and "
                            "plain data (loading it could run code); not an nlos-spotlight checkpoint") from None
        raise NlosError(f"{path}: corrupted or not a checkpoint (UnpicklingError)") from None
    except Exception as exc:  # torch raises many types on torn or foreign files
        raise NlosError(f"{path}: corrupted or not a checkpoint ({type(exc).__name__})") from None
    if not isinstance(st, dict):
        raise NlosError(f"{path}: not an nlos-spotlight checkpoint (not a dictionary)")
    return st


def load_trained(path: str | Path, device: str | torch.device = "cpu") -> TrainedModels:
    """Load models for inference from a checkpoint file or run directory."""
    p = resolve_checkpoint(path)
    st = read_checkpoint(p, device)
    if not {"ien", "net", "config"} <= set(st):
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
