"""The fused (torch.compile) pair kernels against the eager ones they replace, values and gradients."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
import torch

from nlos_spotlight.render.person import Person
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene
from nlos_spotlight.scene.format import Ambient

SETTINGS = RenderSettings(pixel_samples=2, transport_pixel_samples=2, spot_samples=16, person_samples=64,
                          dtype="float32", device="cpu")


@pytest.fixture(scope="module")
def pair():
    sc = corner_scene("furniture", resolution=12)
    sc.materials["paint"].specular[:] = 0.3  # glossy receivers and spot samples: the GGX kernels too
    sc.ambient = Ambient(np.zeros(3), np.full(3, 0.05))
    aims = np.stack([SPOT_TARGET, SPOT_TARGET + [0.25, 0, 0.1], SPOT_TARGET + [-0.3, 0, -0.2]])
    eager = Renderer(sc, SETTINGS, aim_points=aims)
    fused = Renderer(sc, dataclasses.replace(SETTINGS, fuse=True), aim_points=aims)
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, SETTINGS.person_samples, "faces")
    return eager, fused, person


def _fused_or_skip(fn):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn()
    if any("fused kernels unavailable" in str(w.message) for w in caught):
        pytest.skip("torch.compile cannot build kernels on this machine (eager fallback taken)")
    return out


def test_fused_transport_equals_eager(pair):
    eager, fused, person = pair
    t = [0.05, -0.03]
    with torch.no_grad():
        want = eager.transport_images(person, t, nlos_ambient=True)
        got = _fused_or_skip(lambda: fused.transport_images(person, t, nlos_ambient=True))
    assert float(want.abs().max()) > 0
    assert torch.allclose(got, want, rtol=1e-4, atol=1e-6 * float(want.abs().max()))


def test_fused_render_equals_eager_and_keeps_gradients(pair):
    eager, fused, person = pair
    y = torch.tensor([0.2, 0.5, 0.3])
    comps = ("direct", "nlos", "nlos_ambient")
    with torch.no_grad():
        want = eager.render(y, person, translation=[0.02, 0.04], components=comps)
        got = _fused_or_skip(lambda: fused.render(y, person, translation=[0.02, 0.04], components=comps))
    for k in comps:
        scale = float(want[k].abs().max())
        assert scale > 0 and torch.allclose(got[k], want[k], rtol=1e-4, atol=1e-6 * scale)
    # a call that needs a gradient takes the eager kernels: same value and gradient as eager
    grads = []
    for r in (eager, fused):
        t = torch.tensor([0.02, 0.04], requires_grad=True)
        r.render(y, person, translation=t, components=("nlos",))["nlos"].sum().backward()
        grads.append(t.grad)
    assert float(grads[0].abs().max()) > 0 and torch.allclose(grads[1], grads[0], rtol=1e-5)
