"""The geometry-, oracle- and flash-based spot policies of DESIGN section 9, by name.

Each lives in its own module; this one collects them for :data:`nlos_spotlight.lighting.POLICIES`.
"""

from __future__ import annotations

from .adaptive import adaptive_spot
from .base import PolicyFn
from .center import center_spot
from .flash import flash_illumination
from .oracle import SNR_RANKS, oracle_spot, ranked_oracle

EXTRA_POLICIES: dict[str, PolicyFn] = {
    "center": center_spot,
    "oracle": oracle_spot,
    "adaptive": adaptive_spot,
    "flash": flash_illumination,
    **{f"oracle-{k}": ranked_oracle(k) for k in SNR_RANKS},
}
"""center: middle of the camera view; oracle: best SNR with the true materials (upper bound);
oracle-K: the K-th best SNR (K = 2..6, the runners-up a dataset stores by default);
adaptive: Adaptive Lighting radiosity score (Chandran & Jayasuriya 2019); flash: wide beam from
the camera (Tancik et al. 2018)."""
