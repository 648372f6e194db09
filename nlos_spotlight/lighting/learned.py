"""The learned spot policy: a trained IEN's choice, behind the same interface as the fixed ones.

A fixed policy of :data:`lighting.POLICIES` is a function ``(SceneTensors, scene_dir, rng) ->
Illumination``; :class:`IENPolicy` is one too, holding the IEN. :func:`policy_named` gives either
by name, so evaluation, the unseen-room benchmark and ``nlos fit`` pick spots the same way for
every policy. Training is where the IEN differs (it learns end to end or on its SNR target:
``train.loop``), not choosing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import torch

from ..errors import NlosError
from .base import Illumination, PolicyFn


@dataclass
class IENPolicy:
    """The most probable candidate of a trained IEN among those whose spot lands (and whose light a
    room of image samples stores: ``SceneTensors.stored``)."""

    ien: torch.nn.Module
    """A trained ``models.ien.IEN`` (evaluated without gradient)."""

    def logits(self, s) -> torch.Tensor:
        """(T,) logits, -inf where the candidate cannot be used."""
        ok = s.landed if s.stored is None else s.landed & s.stored
        with torch.no_grad():
            return self.ien(s.x, s.edge_index, s.faces, s.face_prior).masked_fill(~ok, float("-inf"))

    def __call__(self, s, scene_dir: Path | None = None, rng=None) -> Illumination:
        return Illumination("spot", int(self.logits(s).argmax()))


def require_learned(models) -> None:
    """One line when a run's IEN was never trained (it used a fixed policy)."""
    if models.config.policy != "ien":
        raise NlosError(f"{models.path}: this run used the fixed '{models.config.policy}' spot policy, so its IEN "
                        "was never trained; use a run trained with policy 'ien'")


def policy_named(name: str, ien: torch.nn.Module | None = None) -> PolicyFn:
    """The policy ``name``: 'ien' (needs ``ien``) or a fixed one of ``lighting.POLICIES``."""
    from . import POLICIES

    if name == "ien":
        if ien is None:
            raise NlosError("spot policy 'ien' needs a trained IEN")
        return IENPolicy(ien)
    if name not in POLICIES:
        raise NlosError(f"unknown spot policy '{name}' (choose from ien, {', '.join(POLICIES)})")
    return POLICIES[name]


__all__ = ["IENPolicy", "policy_named", "require_learned"]
