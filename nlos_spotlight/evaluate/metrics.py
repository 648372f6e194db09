"""Posture accuracy and localization error, per class, and their mean and std over training seeds.

Tables 1-3 use the static samples (one person placement each); walking trajectories are kept
for the tracking figure.
"""

from __future__ import annotations

import numpy as np

from ..world.body import POSTURES
from .predictions import Predictions

COLUMNS = (*POSTURES, "all")
"""Table columns: the six postures, then all samples together."""


def static_mask(p: Predictions) -> np.ndarray:
    return p.arrays()["trajectory"][:, 0] < 0


def per_class(p: Predictions) -> dict[str, dict[str, float]]:
    """:func:`class_scores` over the static samples."""
    a = p.arrays()
    keep = static_mask(p)
    return class_scores(a["true_posture"][keep], a["probs"][keep].argmax(1), a["true_xy"][keep], a["pred_xy"][keep])


def class_scores(true: np.ndarray, pred: np.ndarray, true_xy: np.ndarray, pred_xy: np.ndarray) -> dict:
    """{'accuracy': {column: %}, 'error_cm': {column: mean cm}, 'people': {column: count}} of postures
    (N,) and positions (N, 2) m, per true posture and over all."""
    err = 100 * np.linalg.norm(pred_xy - true_xy, axis=1)
    acc, loc, n = {}, {}, {}
    for c, name in enumerate(COLUMNS):
        sel = true == c if name != "all" else np.ones(len(true), bool)
        acc[name] = float(100 * np.mean(pred[sel] == true[sel])) if sel.any() else float("nan")
        loc[name] = float(err[sel].mean()) if sel.any() else float("nan")
        n[name] = int(sel.sum())
    return {"accuracy": acc, "error_cm": loc, "people": n}


def aggregate(results: list[dict[str, dict[str, float]]]) -> dict[str, dict[str, tuple[float, float]]]:
    """Mean and sample std (0 for one seed) over seeds, per metric and column."""
    out = {}
    for metric in ("accuracy", "error_cm"):
        out[metric] = {}
        for col in COLUMNS:
            v = np.array([r[metric][col] for r in results], dtype=float)
            out[metric][col] = (float(np.mean(v)), float(np.std(v, ddof=1)) if len(v) > 1 else 0.0)
    return out


def fmt(ms: tuple[float, float], digits: int = 1) -> str:
    m, s = ms
    if not np.isfinite(m):
        return "n/a"
    return f"{m:.{digits}f} ± {s:.{digits}f}"
