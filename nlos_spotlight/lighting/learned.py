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
from typing import TYPE_CHECKING

import torch

from ..errors import NlosError
from .base import Illumination, PolicyFn

if TYPE_CHECKING:
    from ..scene.format import Camera, TriMesh
    from ..train.checkpoint import TrainedModels


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


def ien_logits(models: "TrainedModels", los: "TriMesh", camera: "Camera", scene=None) -> torch.Tensor:
    """(F,) IEN logits of the LOS mesh's faces, read in the camera frame with every input its
    training read (``load_scene_tensors``): for an IEN trained with ``ien_features`` 'region' the
    mesh in the hidden region's frame, for 'adaptive' or a ``prior_weight`` the Adaptive Lighting
    score of each face aimed at its centroid (as a room stores its candidates). Those need
    ``scene`` with a hidden region; a bare mesh gives one line saying so. The one path from a mesh
    to the IEN's choice (``nlos spotlight``, ``nlos fit --policy ien``)."""
    from ..data.tensors import face_log_prior, graph_inputs, region_frame
    from ..render.camera import camera_to_world

    feats = list(models.config.ien_features)
    weight = float(models.ien.cfg.prior_weight)
    needs = [f for f in feats if f in ("region", "adaptive")] + (["a face prior"] if weight else [])
    if needs and (scene is None or scene.hidden_region is None):
        raise NlosError(f"{models.path}: this IEN reads {', '.join(needs)} of the hidden region; give a scene "
                        "with a hidden_region (an nlos-scene/1 directory), not a bare mesh")
    pose = camera_to_world(camera)
    region = region_frame(scene.hidden_region, pose) if "region" in feats else None
    scores = None
    if "adaptive" in feats or weight:
        from ..lighting.adaptive import adaptive_scores

        scores = adaptive_scores(scene, los.centroids())
    x, edges = graph_inputs(los, pose, feats, region, scores)
    if x.shape[1] != models.ien.cfg.in_features:
        raise NlosError(f"{models.path}: the IEN expects {models.ien.cfg.in_features} input features per vertex, "
                        f"features {models.config.ien_features} give {x.shape[1]}")
    device = next(models.ien.parameters()).device
    prior = face_log_prior(scores).to(device) if weight else None
    with torch.no_grad():
        return models.ien(x.to(device), edges.to(device),
                          torch.as_tensor(los.faces, dtype=torch.long, device=device), prior).cpu()
