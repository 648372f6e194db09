"""Footprint sampling (``RenderSettings.pixel_footprint``): the person's light integrated over each
pixel from n x n sub-samples that share out the body samples (and the shadow's static points).

It is an unbiased estimator of the brute-force n x n render (every sub-sample seeing every body
sample): each pair (sub-sample, source) is drawn with probability 1 / n^2 and counted n^2 times.
Checked as a statistical property: over pixel offsets drawn with other seeds, the mean tends to
the brute-force image as 1 / sqrt(draws); and the compiled loops agree with the torch kernels.
The n x n brute-force render is itself biased (its sub-samples sit at the cells' centres); with
``footprint_jitter`` each sub-sample lies anywhere in its cell and the mean over draws tends to
the pixel's exact mean instead, checked against a 12 x 12 brute-force render.
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


def _draws(sc, person, settings, component, draws):
    """One renderer, the image of each footprint draw in turn (``Renderer.use_footprint``)."""
    r = Renderer(sc, settings, aim_points=SPOT_TARGET[None])
    with torch.no_grad():
        return np.stack([r.render(r.spot_vector(0), person, components=(component,), footprint_draw=d)[component].numpy()
                         for d in draws])


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


@pytest.mark.parametrize("component", ["nlos", "nlos_shadow"])
def test_jittered_footprint_tends_to_the_pixel_mean(setup, component):
    """The cells' centres converge to the 3 x 3 brute-force render, 7-12% from the pixel's mean here;
    jittered sub-samples converge to the mean itself (the 12 x 12 render, about 2% from it)."""
    sc, person = setup
    fine = _render(sc, person, dataclasses.replace(BASE, transport_pixel_samples=12), components=(component,))[component]
    brute3 = _render(sc, person, BASE, components=(component,))[component]
    fp = dataclasses.replace(BASE, pixel_footprint=3)
    grid = _draws(sc, person, fp, component, range(16))
    jit = _draws(sc, person, dataclasses.replace(fp, footprint_jitter=True), component, range(16))
    bias = _rel(brute3, fine)
    assert bias > 0.05
    assert _rel(grid.mean(0), fine) > 0.8 * bias  # the centres' bias stays however many draws
    single = np.mean([_rel(d, fine) for d in jit])
    assert _rel(jit.mean(0), fine) < 0.45 * single  # 1 / sqrt(16) = 0.25, and the 12 x 12 render's own bias
    assert _rel(jit.mean(0), fine) < 0.5 * bias


def test_footprint_draws_are_reproducible(setup):
    """A draw is a function of the seed and its number, whatever came before; None is the fixed set."""
    sc, person = setup
    fp = dataclasses.replace(BASE, pixel_footprint=3, footprint_jitter=True)
    a = _draws(sc, person, fp, "nlos_shadow", [None, 3, 5, 3, None])
    assert _rel(a[1], a[3]) < 1e-12 and _rel(a[0], a[4]) < 1e-12
    assert _rel(a[1], a[2]) > 1e-3 and _rel(a[0], a[1]) > 1e-3
    fixed = _render(sc, person, fp, components=("nlos_shadow",))["nlos_shadow"]
    assert _rel(a[0], fixed) < 1e-12
    grid = _render(sc, person, dataclasses.replace(fp, footprint_jitter=False), components=("nlos_shadow",))["nlos_shadow"]
    assert _rel(a[0], grid) > 1e-3  # jittered: other sub-samples than the centres


def test_jittered_camera_rays_stay_in_their_cells():
    """``pixel_rays`` with jitter: every sub-sample's film point inside its own cell of its pixel."""
    from nlos_spotlight.render.camera import camera_frame, pixel_rays

    sc = corner_scene("diffuse_corner", 8)
    cam, n = sc.camera, 3
    jit = np.random.default_rng(0).random((cam.height, cam.width, n, n, 2))
    d, _ = pixel_rays(cam, n, jit)
    fwd, right, up = camera_frame(cam)
    tan_x = np.tan(np.radians(cam.fov_deg) / 2)
    tan_y = tan_x * cam.height / cam.width
    z = d @ fwd
    col = ((d @ right) / z / tan_x + 1) / 2 * cam.width  # continuous pixel coordinates
    row = (1 - (d @ up) / z / tan_y) / 2 * cam.height
    cells = np.arange(n)
    want_col = np.arange(cam.width)[None, :, None, None] + (cells[None, None, None, :] + jit[..., 0]) / n
    want_row = np.arange(cam.height)[:, None, None, None] + (cells[None, None, :, None] + jit[..., 1]) / n
    assert np.allclose(col.reshape(want_col.shape), want_col, atol=1e-9)
    assert np.allclose(row.reshape(want_row.shape), want_row, atol=1e-9)
    with pytest.raises(ValueError, match="jitter"):
        pixel_rays(cam, n, np.ones((cam.height, cam.width, n, n, 2)))
