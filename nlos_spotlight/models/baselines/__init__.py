"""Baseline NLOS networks (docs/baselines.md); each maps (B, H, W, 3) -> ((B, 2), (B, 6)).

chandran: Chandran & Jayasuriya 2019; tancik: Tancik et al. 2018; dlnlos: He et al. 2022.
Every constructor takes a :class:`~nlos_spotlight.models.nlos_net.NLOSNetConfig`.
"""

from .chandran import ChandranCNN
from .dlnlos import DLNLOS
from .tancik import TancikNet

BASELINES: dict = {"chandran": ChandranCNN, "tancik": TancikNet, "dlnlos": DLNLOS}
"""Network name -> constructor, merged into ``models.registry.NETWORKS``."""

__all__ = ["BASELINES", "DLNLOS", "ChandranCNN", "TancikNet"]
