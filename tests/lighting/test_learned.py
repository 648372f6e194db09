"""The IEN behind the same interface as the fixed spot policies."""

from __future__ import annotations

import dataclasses
import types

import pytest
import torch

from nlos_spotlight.errors import NlosError
from nlos_spotlight.lighting import POLICIES, Illumination
from nlos_spotlight.lighting.learned import IENPolicy, policy_named, require_learned
from nlos_spotlight.models.ien import IEN, IENConfig


def test_ien_policy_is_the_best_usable_candidate(micro_scene):
    """Brute force over the IEN's logits: the most probable landed candidate; in a room of image
    samples, the most probable stored one, even when a better unstored one exists."""
    _, s = micro_scene
    torch.manual_seed(3)
    ien = IEN(IENConfig(in_features=s.x.shape[1])).eval()
    with torch.no_grad():
        raw = ien(s.x, s.edge_index, s.faces)
    best = max((t for t in range(len(raw)) if s.landed[t]), key=lambda t: float(raw[t]))
    assert policy_named("ien", ien)(s, None, None) == Illumination("spot", best)
    stored = s.landed.clone()
    stored[best] = False
    second = max((t for t in range(len(raw)) if stored[t]), key=lambda t: float(raw[t]))
    assert IENPolicy(ien)(dataclasses.replace(s, stored=stored)) == Illumination("spot", second) != \
        Illumination("spot", best)


def test_policies_by_name_and_one_line_errors():
    assert policy_named("center") is POLICIES["center"]
    with pytest.raises(NlosError, match="unknown spot policy 'nope'"):
        policy_named("nope")
    with pytest.raises(NlosError, match="needs a trained IEN"):
        policy_named("ien")
    run = types.SimpleNamespace(config=types.SimpleNamespace(policy="center"), path="runs/x/final.pt")
    with pytest.raises(NlosError, match="fixed 'center' spot policy, so its IEN was never trained"):
        require_learned(run)
