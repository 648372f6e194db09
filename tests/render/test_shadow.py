"""The ``nlos_shadow`` component's parts (its value is checked against Mitsuba in test_mitsuba.py)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.render.person import Person
from nlos_spotlight.render.shadow import segments_cross_box
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene


def test_segments_cross_box_equals_dense_sampling():
    rng = np.random.default_rng(0)
    a, b = rng.uniform(-2, 2, (40, 3)), rng.uniform(-2, 2, (50, 3))
    lo, hi = np.array([-0.5, -0.3, -0.4]), np.array([0.4, 0.6, 0.2])
    got = segments_cross_box(*(torch.as_tensor(x) for x in (a, b, lo, hi))).numpy()
    s = np.linspace(0, 1, 4001)[:, None, None, None]
    pts = a[None, :, None] + s * (b[None, None] - a[None, :, None])  # (S, 40, 50, 3)
    inside = ((pts >= lo) & (pts <= hi)).all(-1)
    # a segment that only grazes the box can fall between two dense samples: compare where the
    # samples agree with a slightly shrunk box too
    core = ((pts >= lo + 1e-3) & (pts <= hi - 1e-3)).all(-1)
    assert 200 < got.sum() < got.size - 200
    assert (got[core.any(0)]).all() and not got[~inside.any(0)].any()


def test_compiled_crossing_equals_the_torch_slab_test():
    from nlos_spotlight.render.pair_loops import segments_cross_box as loop

    rng = np.random.default_rng(1)
    a, b = rng.uniform(-2, 2, (300, 3)), rng.uniform(-2, 2, (200, 3))
    b[:20, 0] = a[0, 0]  # segments parallel to a slab
    lo, hi = np.array([-0.5, -0.3, -0.4]), np.array([0.4, 0.6, 0.2])
    want = segments_cross_box(*(torch.as_tensor(x) for x in (a, b, lo, hi))).numpy()
    got = loop(a, b, lo, hi)
    assert 1000 < want.sum() < want.size - 1000
    assert np.array_equal(got, want)


def test_shadow_needs_the_body_in_the_way():
    """No light is lost with the body far from every spot -> floor -> wall path, and some with it
    where its shadow falls on lit floor; the light lost never exceeds nlos's magnitude scale."""
    sc = corner_scene("diffuse_corner", 16)
    r = Renderer(sc, RenderSettings(pixel_samples=2, transport_pixel_samples=1, spot_samples=64, person_samples=256,
                                    shadow_samples=2048), aim_points=SPOT_TARGET[None])
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, 256)
    y = r.spot_vector(0)
    with torch.no_grad():
        near = r.render(y, person, components=("nlos", "nlos_shadow"))
        far = r.render(y, person, translation=[0.0, 0.0, 50.0], components=("nlos_shadow",))
    assert float(far["nlos_shadow"].abs().max()) == 0.0
    lost = float(near["nlos_shadow"].sum())
    assert lost < 0 and abs(lost) < 0.2 * float(near["nlos"].sum())


@pytest.mark.parametrize("footprint,depth", [(0, 4), (2, 4), (2, 10)])
def test_compiled_second_leg_equals_the_torch_one(monkeypatch, footprint, depth):
    """The shadow through the compiled legs of every group at once (``pair_loops.cross_groups``,
    ``shadow_legs`` and, past the first relay, ``relayed``), through the compiled leg group by group
    (``pair_loops.shadow_leg``) and through the torch one they replace on diffuse camera points (the
    reference), float64: the same image to 1e-9."""
    from nlos_spotlight.render.shadow import SpotShadow

    sc = corner_scene("diffuse_corner", 12)
    settings = RenderSettings(pixel_samples=2, transport_pixel_samples=1, pixel_footprint=footprint, spot_samples=32,
                              person_samples=128, shadow_samples=1024, dtype="float64", rays="embree",
                              shadow_depth=depth)
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, 128)
    used = []
    flat = SpotShadow.flat_groups
    monkeypatch.setattr(SpotShadow, "flat_groups", lambda self: used.append(flat(self)) or used[-1])

    def shadow(t):
        r = Renderer(sc, settings, aim_points=SPOT_TARGET[None])
        with torch.no_grad():
            return r.render(r.spot_vector(0), person, translation=t, components=("nlos_shadow",))["nlos_shadow"]

    paths = []
    for step in ("flat", "per group", "torch"):
        if step == "per group":
            assert used and all(u is not None for u in used)  # the one-call path ran
            monkeypatch.setattr(SpotShadow, "flat_groups", lambda self: None)
        if step == "torch":
            monkeypatch.setattr(SpotShadow, "_second_leg_loops", SpotShadow._second_leg)
        paths.append([shadow(t) for t in ([0.0, 0.0], [0.3, -0.2])])
    for got in paths[:2]:
        for g, w in zip(got, paths[2]):
            assert float(w.abs().max()) > 0
            assert torch.allclose(g, w, rtol=1e-9, atol=1e-12 * float(w.abs().max()))


def test_relay_offsets_are_draws_of_one_estimate():
    """A call's ``relay_offset`` is the renderer's setting for that call, and the relay sets of
    many offsets average toward the many-point shadow: their error is noise, not a fixed bias
    (statistical: the mean of 8 sets at most 0.6 of one set's error; 1/sqrt(8) = 0.35)."""
    sc = corner_scene("diffuse_corner", 8)
    base = RenderSettings(pixel_samples=1, transport_pixel_samples=1, spot_samples=32, person_samples=128,
                          shadow_samples=96, dtype="float64")
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, 128)

    def shadow(settings, offset=None):
        r = Renderer(sc, settings, aim_points=SPOT_TARGET[None])
        with torch.no_grad():
            return r.render(r.spot_vector(0), person, components=("nlos_shadow",), relay_offset=offset)[
                "nlos_shadow"].numpy()

    r = Renderer(sc, base, aim_points=SPOT_TARGET[None])
    with torch.no_grad():
        per_call = [r.render(r.spot_vector(0), person, components=("nlos_shadow",), relay_offset=o)["nlos_shadow"]
                    .numpy() for o in (0.3, 0.7, 0.3)]
    assert np.array_equal(per_call[0], per_call[2])
    assert np.array_equal(per_call[1], shadow(RenderSettings(**{**base.__dict__, "relay_offset": 0.7})))
    ref = shadow(RenderSettings(**{**base.__dict__, "shadow_samples": 96 * 64}))
    sets = [shadow(base, (k + 0.5) / 8) for k in range(8)]
    one = np.mean([np.linalg.norm(s - ref) for s in sets])
    mean = np.linalg.norm(np.mean(sets, 0) - ref)
    print(f"one set {one / np.linalg.norm(ref):.3f}, mean of 8 {mean / np.linalg.norm(ref):.3f}")
    assert 0.02 * np.linalg.norm(ref) < one and mean < 0.6 * one
