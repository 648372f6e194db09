"""Footprint sampling (``RenderSettings.pixel_footprint``): the person's light integrated over each
pixel from n x n sub-samples that share out the body samples (and the shadow's static points).

It is an unbiased estimator of the brute-force n x n render (every sub-sample seeing every body
sample): each pair (sub-sample, source) is drawn with probability 1 / n^2 and counted n^2 times.
Checked as a statistical property: over pixel offsets drawn with other seeds, the mean tends to
the brute-force image as 1 / sqrt(draws); and the compiled loops agree with the torch kernels.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from nlos_spotlight.render.person import Person
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.format import Ambient
from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene

pytestmark = pytest.mark.usefixtures("one_thread")

BASE = RenderSettings(pixel_samples=1, transport_pixel_samples=3, spot_samples=32, person_samples=256,
                      shadow_samples=512, dtype="float64")


@pytest.fixture(scope="module")
def setup():
    sc = corner_scene("diffuse_corner", 8)
    sc.ambient = Ambient(np.full(3, 0.01), np.array([0.02, 0.03, 0.04]))  # the hidden light the body hides
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, 256)
    return sc, person


def _render(sc, person, settings, seed=None, components=("nlos", "nlos_ambient")):
    if seed is not None:
        settings = dataclasses.replace(settings, footprint_seed=seed)
    r = Renderer(sc, settings, aim_points=SPOT_TARGET[None])
    with torch.no_grad():
        out = r.render(r.spot_vector(0), person, components=components)
    return {c: out[c].numpy() for c in components}


def _rel(a, b):
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.mark.parametrize("component", ["nlos", "nlos_ambient", "nlos_shadow"])
def test_footprint_mean_tends_to_the_brute_force_render(setup, component):
    sc, person = setup
    brute = _render(sc, person, BASE, components=(component,))[component]
    fp = dataclasses.replace(BASE, pixel_footprint=3)
    draws = np.stack([_render(sc, person, fp, seed, (component,))[component] for seed in range(16)])
    single = np.mean([_rel(d, brute) for d in draws])
    mean = _rel(draws.mean(0), brute)
    assert 0 < single < 0.5  # a noisy estimate of the same image
    assert mean < 0.45 * single  # 1 / sqrt(16) = 0.25 for an unbiased estimator; a bias would stay
    assert abs(draws.sum() / len(draws) - brute.sum()) < 0.02 * abs(brute.sum())


def test_footprint_loops_match_torch_kernels(setup):
    sc, person = setup
    fp = dataclasses.replace(BASE, pixel_footprint=3)
    loops = _render(sc, person, fp)
    dense = _render(sc, person, dataclasses.replace(fp, pair_loops=False))
    for c in loops:
        assert _rel(loops[c], dense[c]) < 1e-9


def test_footprint_of_one_is_the_pixel_centre(setup):
    """n = 1: one sub-sample sees every body sample: the 1 x 1 brute-force render exactly."""
    sc, person = setup
    one = _render(sc, person, dataclasses.replace(BASE, transport_pixel_samples=1))
    fp = _render(sc, person, dataclasses.replace(BASE, pixel_footprint=1))
    for c in one:
        assert _rel(fp[c], one[c]) < 1e-12
