"""``nlos_bounce`` (``render/bounce.py``): the person's light over one more static bounce, against
Mitsuba 3's fifth bounce (the person minus a black person at ``max_depth`` 5 minus the same at 4,
same seeds), and its compiled second leg against the torch one."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from nlos_spotlight.render.person import Person
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene

pytestmark = pytest.mark.usefixtures("one_thread")
RES = 16
SETTINGS = RenderSettings(pixel_samples=2, transport_pixel_samples=2, spot_samples=64, person_samples=512,
                          shadow_samples=2048, dtype="float64")


def _render(settings, components=("nlos", "nlos_bounce")):
    sc = corner_scene("diffuse_corner", RES)
    r = Renderer(sc, settings, aim_points=SPOT_TARGET[None])
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, settings.person_samples)
    with torch.no_grad():
        out = r.render(r.spot_vector(0), person, components=components)
    return sc, {c: out[c].numpy() for c in components}


@pytest.mark.mitsuba
@pytest.mark.slow
def test_bounce_is_mitsubas_fifth_bounce():
    """Ours: 85% of Mitsuba's extra light in this scene (the rest mostly the body's light onto
    itself, left out, and the near field the relay legs' distance floor bounds), the same pattern
    over 4 x 4 blocks."""
    mi_ref = pytest.importorskip("nlos_spotlight.render.mitsuba_ref")
    sc, ours = _render(SETTINGS)
    d4 = mi_ref.mitsuba_nlos(sc, SPOT_TARGET, 16384, seed=3, max_depth=4, protocol="scatter", integrator="ptracer")
    d5 = mi_ref.mitsuba_nlos(sc, SPOT_TARGET, 16384, seed=3, max_depth=5, protocol="scatter", integrator="ptracer")
    extra = d5 - d4
    assert 0.1 < extra.sum() / d4.sum() < 0.3  # the fifth bounce matters: 20% here
    assert 0.75 < ours["nlos_bounce"].sum() / extra.sum() < 1.02
    blocks = lambda x, k=4: x.sum(-1).reshape(RES // k, k, RES // k, k).mean((1, 3)).ravel()
    assert np.corrcoef(blocks(ours["nlos_bounce"]), blocks(extra))[0, 1] > 0.97


def test_bounce_loops_equal_the_torch_leg_and_scale_with_albedo(monkeypatch):
    """The compiled legs (CPU, static visibility cached) and body <-> relay exchange, in one block
    and in blocks of a few body samples, against the torch ones; and the term is linear in the
    body's albedo (each path meets the body once)."""
    from nlos_spotlight.render import bounce

    _, loops = _render(SETTINGS, ("nlos_bounce",))
    monkeypatch.setattr(bounce, "LOOP_PAIRS", 5 * SETTINGS.shadow_samples)
    _, blocks = _render(SETTINGS, ("nlos_bounce",))
    _, dense = _render(dataclasses.replace(SETTINGS, pair_loops=False), ("nlos_bounce",))
    b = dense["nlos_bounce"]
    for a in (loops["nlos_bounce"], blocks["nlos_bounce"]):
        assert np.linalg.norm(a - b) <= 1e-9 * np.linalg.norm(b) and b.sum() > 0
    sc = corner_scene("diffuse_corner", RES)
    r = Renderer(sc, SETTINGS, aim_points=SPOT_TARGET[None])
    imgs = []
    for k in (1.0, 0.5):
        person = Person.from_mesh(sc.human.mesh, sc.human.albedo * k, SETTINGS.person_samples)
        with torch.no_grad():
            imgs.append(r.render(r.spot_vector(0), person, components=("nlos_bounce",))["nlos_bounce"].numpy())
    np.testing.assert_allclose(imgs[1], 0.5 * imgs[0], rtol=1e-9, atol=1e-15)


def test_a_coarser_body_averages_to_the_bounce():
    """``bounce_body_samples``: the bounce through n stratified body samples at the relay points'
    offset is the same term rendered with that resampled body; over eight offsets it averages to the
    fine body's bounce (the body's own face quadrature, 2,000 samples) within 1.5%, a single draw
    within 10%; and the resampled body keeps the mesh's area and its face normals."""
    sc = corner_scene("diffuse_corner", RES)
    fine = Person.from_mesh(sc.human.mesh, sc.human.albedo, 2000, "faces")
    r = Renderer(sc, SETTINGS, aim_points=SPOT_TARGET[None])
    y = r.spot_vector(0)
    bounce = lambda rr, p, off=0.5: rr.render(y, p, components=("nlos_bounce",), relay_offset=off)["nlos_bounce"].numpy()
    with torch.no_grad():
        ref = bounce(r, fine)
        coarse = Renderer(sc, dataclasses.replace(SETTINGS, bounce_body_samples=128), aim_points=SPOT_TARGET[None])
        for off in (0.5, 0.25):
            wired = bounce(coarse, fine, off)
            by_hand = bounce(Renderer(sc, SETTINGS, aim_points=SPOT_TARGET[None]), fine.resampled(128, off), off)
            np.testing.assert_allclose(wired, by_hand, rtol=1e-12, atol=1e-12 * np.abs(by_hand).max())
        draws = [bounce(r, fine.resampled(128, (k + 0.5) / 8)) for k in range(8)]
    err = lambda x: np.linalg.norm(x - ref) / np.linalg.norm(ref)
    assert err(np.mean(draws, 0)) < 0.015
    assert max(err(d) for d in draws) < 0.10
    p = fine.resampled(128, 0.3)
    assert len(p) == 128 and np.isclose(p.area.sum(), sc.human.mesh.face_areas().sum(), rtol=1e-12)
    assert np.allclose(np.linalg.norm(p.normal, axis=1), 1) and p.closed == fine.closed


def test_bounce_and_shadow_loops_on_two_threads_equal_one():
    """The parallel loops (``pair_loops.relay_exchange``'s blocks of body samples, each adding to its
    own copy of the relay light; ``relayed``, ``cross_groups``, ``shadow_legs`` over groups) give
    the serial twins' sums."""
    from nlos_spotlight.render import pair_loops

    if pair_loops.numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba runs one thread here: the parallel loops cannot be told from the serial ones")
    settings = dataclasses.replace(SETTINGS, pixel_footprint=2)  # depth 4: the later relays sum in float32
    before = torch.get_num_threads()
    out = {}
    try:
        for n in (1, 2):
            torch.set_num_threads(n)
            _, out[n] = _render(settings, ("nlos_bounce", "nlos_shadow"))
            assert pair_loops.loops() is (pair_loops.SERIAL if n == 1 else pair_loops.PARALLEL)
    finally:
        torch.set_num_threads(before)
    for c in ("nlos_bounce", "nlos_shadow"):
        assert np.abs(out[1][c]).max() > 0
        np.testing.assert_allclose(out[2][c], out[1][c], rtol=1e-9, atol=1e-12 * np.abs(out[1][c]).max())
