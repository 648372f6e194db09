"""Oracle policy: exhaustive search over every candidate with the true materials (the upper bound).

It tries every landed spot on the stored, physically rendered transport (which knows every
albedo, gloss and occluder, and the actual people) and keeps the one with the highest mean NLOS
SNR over the scene's static samples (:mod:`.snr`). No deployable method can know this; it bounds
what a spot policy can reach under the sensor model.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import NlosError
from .base import Illumination, PolicyFn
from .snr import candidate_snr


def oracle_spot(scene, scene_dir: Path, rng: np.random.Generator) -> Illumination:
    """argmax_t SNR_t over the landed candidates (``rng`` unused; ties go to the lowest index)."""
    return Illumination("spot", snr_order(scene, scene_dir)[0])


SNR_RANKS = range(2, 7)
"""The runner-up ranks with a policy 'oracle-K' (those a dataset stores by default, ``stored_spots_top``)."""


def snr_order(scene, scene_dir: Path) -> list[int]:
    """The landed candidates of a scene, highest mean NLOS SNR first (:func:`by_snr`)."""
    values = candidate_snr(scene_dir)
    landed = scene.landed.cpu().numpy().astype(bool)
    if len(values) != len(landed):
        raise NlosError(f"{scene_dir}: {len(values)} stored candidates, the scene tensors have {len(landed)}")
    return by_snr(values, landed)


def by_snr(values: np.ndarray, landed: np.ndarray) -> list[int]:
    """The landed candidates, highest SNR ``values`` first (ties: lowest index first)."""
    return [int(t) for t in np.argsort(-values, kind="stable") if landed[t]]


def ranked_oracle(rank: int) -> PolicyFn:
    """The policy 'oracle-RANK': the landed candidate of the RANK-th highest SNR (rank 1 is
    :func:`oracle_spot`). SNR is a proxy for the task; a runner-up spot may read posture better,
    which only training on it can tell (``experiments/unseen-room-fit/unseen_room_fit.py``'s task-chosen spot)."""

    def ranked(scene, scene_dir: Path, rng: np.random.Generator) -> Illumination:
        order = snr_order(scene, scene_dir)
        if len(order) < rank:
            raise NlosError(f"{scene_dir}: only {len(order)} candidates land, no spot of SNR rank {rank}")
        return Illumination("spot", order[rank - 1])

    ranked.__name__ = f"oracle_rank{rank}"
    return ranked
