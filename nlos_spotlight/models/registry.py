"""NLOS networks by name, so configs, checkpoints and the evaluation can pick an architecture.

Every network maps images (B, H, W, 3) in radiance units to (position (B, 2) in meters,
posture logits (B, 6)), so the trainer, ``nlos predict`` and ``nlos evaluate`` treat them alike.
"""

from __future__ import annotations

from typing import Callable

from torch import nn

from ..errors import NlosError
from .nlos_net import NLOSNet, NLOSNetConfig

NETWORKS: dict[str, Callable[[NLOSNetConfig], nn.Module]] = {"resnet18": NLOSNet}
"""Architecture name -> constructor taking an :class:`NLOSNetConfig` (baselines register below)."""

try:  # the baselines of docs/baselines.md
    from .baselines import BASELINES

    NETWORKS.update(BASELINES)
except ImportError:  # pragma: no cover - while the baselines package is being written
    pass


def build_network(arch: str, cfg: NLOSNetConfig | None = None) -> nn.Module:
    """A freshly initialized network of architecture ``arch``."""
    if arch not in NETWORKS:
        raise NlosError(f"network: unknown architecture '{arch}' (choose from {', '.join(NETWORKS)})")
    return NETWORKS[arch](cfg or NLOSNetConfig())
