"""Renderer structure: linearity in y, exact gradients, batching, and the slow reference."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.render.person import Person
from nlos_spotlight.render.reference import reference_person_terms
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene
from nlos_spotlight.scene.format import Ambient

TINY = RenderSettings(pixel_samples=2, transport_pixel_samples=1, spot_samples=8, person_samples=24,
                      dtype="float64", device="cpu")


@pytest.fixture(scope="module")
def setup():
    sc = corner_scene("furniture", resolution=8)
    sc.materials["paint"].specular[:] = 0.3  # a glossy relay wall exercises the GGX paths too
    sc.ambient = Ambient(np.zeros(3), np.full(3, 0.05))
    aims = np.stack([SPOT_TARGET, SPOT_TARGET + [0.25, 0, 0.1], SPOT_TARGET + [-0.3, 0, -0.2]])
    r = Renderer(sc, TINY, aim_points=aims)
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, TINY.person_samples)
    return sc, r, person


def test_linear_in_spot_vector(setup):
    _, r, person = setup
    comps = ("direct", "interreflection", "nlos")
    y1 = torch.tensor([1.0, 0.0, 0.5], dtype=torch.float64)
    y2 = torch.tensor([0.0, 2.0, 0.25], dtype=torch.float64)
    a = r.render(y1 + 3 * y2, person, components=comps)
    b, c = r.render(y1, person, components=comps), r.render(y2, person, components=comps)
    for k in comps:
        assert float(a[k].abs().max()) > 0
        assert torch.allclose(a[k], b[k] + 3 * c[k], rtol=1e-10, atol=1e-16)


def test_interreflection_cache_equals_the_direct_sum(setup):
    """The per-candidate interreflection images (kept on first use) sum to the direct pair sum."""
    _, r, _ = setup
    y = torch.tensor([0.7, 0.0, 1.3], dtype=torch.float64)
    want = r._interreflection_sum(y)
    assert float(want.abs().max()) > 0
    for _ in range(2):  # the second call reads the cache
        got = r.render(y, None, components=("interreflection",))["interreflection"]
        assert torch.allclose(got, want, rtol=1e-10, atol=1e-16)
    assert {0, 2} <= set(r._inter_cache)
    yg = y.clone().requires_grad_(True)  # with a gradient: summed directly, still equal
    assert torch.allclose(r.render(yg, None, components=("interreflection",))["interreflection"], want, rtol=1e-10)


def test_spot_changes_the_image(setup):
    _, r, person = setup
    imgs = [r.render(r.spot_vector(i), person, components=("nlos",))["nlos"] for i in range(3)]
    assert not torch.allclose(imgs[0], imgs[1]) and not torch.allclose(imgs[0], imgs[2])


def test_gradcheck_spot_vector(setup):
    _, r, person = setup
    y = torch.tensor([0.6, 0.3, 0.1], dtype=torch.float64, requires_grad=True)
    fn = lambda y: r.render(y, person, translation=[0.05, -0.02], components=("direct", "nlos")).image
    assert torch.autograd.gradcheck(fn, (y,), eps=1e-6, atol=1e-9, rtol=1e-5)


def test_gradcheck_person_translation(setup):
    _, r, person = setup
    t = torch.tensor([0.03, -0.04], dtype=torch.float64, requires_grad=True)
    y = r.spot_vector(0)
    fn = lambda t: r.render(y, person, translation=t, components=("nlos", "nlos_ambient")).image
    # visibility is a fixed mask under autograd; a 1e-6 m step does not cross a shadow edge here
    assert torch.autograd.gradcheck(fn, (t,), eps=1e-6, atol=1e-9, rtol=1e-4)


def test_batched_people_equal_single_renders(setup):
    _, r, person = setup
    ts = torch.tensor([[0.0, 0.0], [0.2, 0.3], [-0.1, 0.5]], dtype=torch.float64)
    y = r.spot_vector(0)
    batch = r.render(y, person, translation=ts)
    assert batch.image.shape == (3, 8, 8, 3)
    for i in range(3):
        one = r.render(y, person, translation=ts[i])
        assert torch.allclose(batch.image[i], one.image, rtol=1e-12)
    assert not torch.allclose(batch["nlos"][0], batch["nlos"][1])


def test_fast_kernel_matches_slow_reference_values_and_gradients(setup):
    sc, r, person = setup
    y = torch.tensor([0.7, 0.2, 0.1], dtype=torch.float64)
    t1 = torch.tensor([0.04, 0.02], dtype=torch.float64, requires_grad=True)
    t2 = torch.tensor([0.04, 0.02], dtype=torch.float64, requires_grad=True)
    fast = r.render(y, person, translation=t1, components=("nlos", "nlos_ambient"))
    slow = reference_person_terms(r, y, person, t2)
    for k in ("nlos", "nlos_ambient"):
        assert float(slow[k].detach().abs().max()) > 0
        assert torch.allclose(fast[k], slow[k], rtol=1e-9, atol=1e-18), k
    w = torch.rand(8, 8, 3, dtype=torch.float64)
    g1, = torch.autograd.grad((fast["nlos"] * w).sum(), t1)
    g2, = torch.autograd.grad((slow["nlos"] * w).sum(), t2)
    assert torch.allclose(g1, g2, rtol=1e-8) and float(g1.abs().max()) > 0


def test_person_occludes_its_own_light(monkeypatch):
    """Self-occlusion matters: ignoring the body in shadow rays lets light through limbs and torso."""
    from nlos_spotlight.render import transport

    sc = corner_scene("posed_body", 8)
    r = Renderer(sc, TINY, aim_points=SPOT_TARGET[None])
    p = Person.from_mesh(sc.human.mesh, sc.human.albedo, 64)
    occluded = r.render(r.spot_vector(0), p, components=("nlos",))["nlos"].sum()
    static_only = transport.SceneRays
    monkeypatch.setattr(transport, "SceneRays", lambda static, person: static_only(static, None))
    unoccluded = r.render(r.spot_vector(0), p, components=("nlos",))["nlos"].sum()
    assert unoccluded > occluded * 1.01


def test_transport_images_are_the_columns_of_f(setup):
    _, r, person = setup
    t = torch.tensor([0.05, 0.1], dtype=torch.float64)
    f = r.transport_images(person, t)
    assert f.shape == (3, 8, 8, 3)
    y = torch.tensor([0.3, 1.2, 0.5], dtype=torch.float64)
    expect = r.render(y, person, translation=t, components=("nlos",))["nlos"]
    assert torch.allclose(torch.einsum("thwc,t->hwc", f, y), expect, rtol=1e-10)
