"""The IEN behind the same interface as the fixed spot policies."""

from __future__ import annotations

import dataclasses
import types

import numpy as np
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


def test_ien_prior_weight_adds_the_log_prior_to_every_logit():
    """``prior_weight`` w: logits = the network's + w x face prior (natural log of score / best,
    floored four decades down); a dominant prior makes the IEN choose the prior's best face."""
    from nlos_spotlight.data.tensors import face_log_prior

    torch.manual_seed(0)
    x, faces = torch.randn(6, 3), torch.tensor([[0, 1, 2], [1, 3, 2], [1, 4, 3], [4, 5, 3]])
    edges = torch.tensor([[0, 1, 1, 2, 1, 3, 3, 4, 4, 5], [1, 0, 2, 1, 3, 1, 4, 3, 5, 4]])
    scores = np.array([0.5, 5.0, 5e-3, 0.0])
    prior = face_log_prior(scores)
    np.testing.assert_allclose(prior.numpy(), [np.log(0.1), 0.0, np.log(1e-3), -4 * np.log(10)], rtol=1e-6)
    plain = IEN(IENConfig()).eval()
    biased = IEN(IENConfig(prior_weight=2.0)).eval()
    biased.load_state_dict(plain.state_dict())
    with torch.no_grad():
        torch.testing.assert_close(biased(x, edges, faces, prior) - plain(x, edges, faces), 2.0 * prior)
        strong = IEN(IENConfig(prior_weight=1e4)).eval()
        assert int(strong(x, edges, faces, prior).argmax()) == 1
    with pytest.raises(ValueError, match="face prior"):
        biased(x, edges, faces)
