"""Baseline NLOS networks (docs/baselines.md); each maps (B, H, W, 3) -> ((B, 2), (B, 6))."""

BASELINES: dict = {}
