"""The nuisance projection (models/nuisance.py): the known answer on a synthetic case, its slow
reference, drift estimates against the capture variation that made them, checkpoints."""

from __future__ import annotations

import math

import pytest
import torch

from nlos_spotlight.models.nuisance import (NuisanceProjection, noise_weights, nuisance_basis,
                                            person_light_basis, project_out, project_out_reference, room_prior)
from nlos_spotlight.render.variation import StaticLayers, draw_captures, preset

F, H, W = 8, 16, 16


def smooth_room(seed: int = 0) -> StaticLayers:
    """A room-like static light: a bright spot (Gaussian) on textured walls. The texture is what tells a
    camera shift (everything moves) from a spot drift (the spot alone moves)."""
    g = torch.Generator().manual_seed(seed)
    ys = (torch.arange(H * F, dtype=torch.float64) + 0.5) / F
    xs = (torch.arange(W * F, dtype=torch.float64) + 0.5) / F
    yy, xx = torch.meshgrid(ys, xs, indexing="ij")
    spot = 50 * torch.exp(-((xx - 9.3) ** 2 + (yy - 6.1) ** 2) / (2 * 2.0 ** 2))
    tint = 0.5 + torch.rand(3, generator=g, dtype=torch.float64)
    amb = (1 + 0.5 * torch.sin(1.3 * xx) * torch.cos(1.1 * yy))[..., None] * tint  # textured walls
    proj = spot[..., None] * tint
    pan = spot * (xx - 9.3) / 2.0 ** 2  # the spot moving right by one output pixel per radian
    tilt = spot * (yy - 6.1) / 2.0 ** 2  # ... and down
    aim = torch.stack([pan[..., None] * tint, tilt[..., None] * tint])
    return StaticLayers(proj, aim, amb, F, 20.0, 2.0)


def prior(L: StaticLayers):
    return room_prior(L)


def test_known_answer():
    """A difference that is exactly M c (plus a vector orthogonal to M under W) gives back c and
    that vector."""
    L = smooth_room()
    frac, rel = prior(L)
    b = sum(L.nominal())[None].expand(2, -1, -1, -1)
    m = nuisance_basis(b, frac, rel)
    w = noise_weights(b, None)
    c = torch.tensor([[3e-3, -2e-3, 1e-3, -5e-4, 2e-5, 1e-4, -1e-4], [0, 1e-2, 0, 0, 0, 0, 0]], dtype=torch.float64)
    person = torch.randn(b.shape, generator=torch.Generator().manual_seed(2), dtype=torch.float64) * 1e-3
    person = project_out(person, m, w)[0]  # its part along M removed: the residual is W-orthogonal to M
    resid, got, _ = project_out(torch.einsum("bk,bkhwc->bhwc", c, m) + person, m, w)
    assert torch.allclose(got, c, rtol=1e-6, atol=1e-10)  # the solve's 1e-9 ridge
    assert torch.allclose(resid, person, atol=1e-5 * float(person.abs().max()))


def test_matches_the_slow_reference():
    L = smooth_room(1)
    frac, rel = prior(L)
    g = torch.Generator().manual_seed(3)
    b = sum(L.nominal())[None] * (1 + 0.01 * torch.rand(3, 1, 1, 1, generator=g, dtype=torch.float64))
    d = torch.randn(b.shape, generator=g, dtype=torch.float64)
    clipped = torch.zeros(3, H, W, dtype=torch.bool)
    clipped[:, 6, 9] = True
    m, w = nuisance_basis(b, frac, rel), noise_weights(b, clipped)
    r1, c1, se = project_out(d, m, w)
    r2, c2 = project_out_reference(d, m, w)
    assert torch.allclose(c1, c2, rtol=1e-5, atol=1e-9)  # the solve's 1e-9 ridge
    assert torch.allclose(r1, r2, atol=1e-6 * float(r2.abs().max()))


def test_estimates_the_drift_that_was_drawn():
    """Captures drawn by the capture variation (rough) on textured walls: the projection reads every
    drift back (gains and shifts to 5%, roll and the spot's aim to 20%: the gains' cross terms
    and the bilinear x * y weight are all that the linear model leaves out) and removes at least
    99% of the change the drift made."""
    L = smooth_room(2)
    proj = NuisanceProjection()
    proj.set_prior(*[t.float() for t in prior(L)])
    g = torch.Generator().manual_seed(4)
    n = 64
    a = draw_captures(preset("rough"), n, 16, L.f_px, L.depth_m, g, dtype=torch.float64)
    base = sum(L.nominal())
    photo, empty = base + L.change(a), base[None].expand(n, -1, -1, -1)
    resid, c, _ = proj(photo.float() - empty.float(), empty.float())
    change = photo - empty
    assert float(resid.double().norm() / change.norm()) < 0.01
    truth = [a.projector * a.exposure - 1, a.ambient * a.exposure - 1, a.shift[:, 0], a.shift[:, 1], a.roll,
             a.aim[:, 0], a.aim[:, 1]]
    for k, (t, tol) in enumerate(zip(truth, (0.05, 0.05, 0.05, 0.05, 0.2, 0.2, 0.2))):
        err = (c[:, k].double() - t).abs().max() / t.abs().max()
        assert err < tol, (k, float(err))
    assert math.isfinite(float(c.abs().max()))


def test_checkpoint_round_trip():
    L = smooth_room()
    p = NuisanceProjection()
    p.set_prior(*[t.float() for t in prior(L)])
    q = NuisanceProjection()
    assert not q.ready
    q.load_state_dict(p.state_dict())
    assert q.ready and torch.equal(q.fraction, p.fraction) and torch.equal(q.relative, p.relative)
    with pytest.raises(ValueError, match="room prior"):
        q(torch.zeros(1, 4, 4, 3), torch.ones(1, 4, 4, 3))


def test_standard_errors_are_calibrated():
    """With noise of variance 1 / W (the weights' own model) the coefficients' errors over their
    standard errors are standard normal: z-scores of 400 draws have a standard deviation near 1."""
    L = smooth_room(5)
    frac, rel = prior(L)
    n = 400
    b = sum(L.nominal())[None].expand(n, -1, -1, -1)
    m, w = nuisance_basis(b, frac, rel), noise_weights(b, None)
    g = torch.Generator().manual_seed(6)
    c = 1e-3 * torch.randn(n, 7, generator=g, dtype=torch.float64)
    d = torch.einsum("bk,bkhwc->bhwc", c, m) + torch.randn(b.shape, generator=g, dtype=torch.float64) / w.sqrt()
    _, got, se = project_out(d, m, w)
    z = (got - c) / se
    assert torch.allclose(z.std(0), torch.ones(7, dtype=torch.float64), atol=0.1)
    assert float(z.mean(0).abs().max()) < 0.2


def people_light(L: StaticLayers, n: int, seed: int) -> torch.Tensor:
    """(n, H, W, 3) people-like light: two smooth blobs (a place the room lights, the body's own
    pattern), in random amounts, over the room's light; its mean lies partly along the ambient."""
    g = torch.Generator().manual_seed(seed)
    yy, xx = torch.meshgrid(torch.arange(H, dtype=torch.float64), torch.arange(W, dtype=torch.float64), indexing="ij")
    a = torch.exp(-((xx - 4) ** 2 + (yy - 11) ** 2) / 8)[..., None].expand(H, W, 3)
    b = (torch.exp(-((xx - 12) ** 2 + (yy - 3) ** 2) / 4) * torch.sin(xx))[..., None].expand(H, W, 3)
    amount = 1 + 0.5 * torch.rand(n, 2, generator=g, dtype=torch.float64)
    total = sum(L.nominal())
    return 1e-3 * total * (amount[:, 0, None, None, None] * a + 0.3 * amount[:, 1, None, None, None] * b)


def test_person_directions_span_the_people_light():
    """Light made of two patterns in varying amounts: the mean and one principal direction span
    it (what is left of any person's light over the room's is zero to float precision), and the
    first column is the normalized mean."""
    L = smooth_room(7)
    total = sum(L.nominal())
    light = people_light(L, 50, 8)
    q = person_light_basis(light, total, 2).double()
    rel = (light / total).reshape(50, -1)
    assert torch.allclose(q[0].reshape(-1), rel.mean(0) / rel.mean(0).norm(), atol=1e-6)
    qq = torch.linalg.qr(q.reshape(2, -1).T)[0]
    left = rel - (rel @ qq) @ qq.T
    assert float(left.norm() / rel.norm()) < 1e-6
    assert person_light_basis(light[:1], total, 8).shape == (1, H, W, 3)  # one person: the mean only


def test_randomized_directions_span_the_exact_ones(monkeypatch):
    """Above the full SVD's size the leading directions come from a randomized SVD: on people light
    of a fast-falling spectrum (four patterns and a little noise) they span the exact ones (their
    principal angles' cosines 1 to 1e-6), and the caller's random stream is left as it was (the
    range finder draws from a generator of its own)."""
    import nlos_spotlight.models.nuisance as nui

    g = torch.Generator().manual_seed(3)
    patterns = torch.randn(4, 600, generator=g, dtype=torch.float64)
    amounts = torch.randn(200, 4, generator=g, dtype=torch.float64) * torch.tensor([8.0, 4.0, 2.0, 1.0], dtype=torch.float64)
    x = amounts @ patterns + 1e-3 * torch.randn(200, 600, generator=g, dtype=torch.float64)
    x = x - x.mean(0)
    exact = nui.leading_directions(x, 4)
    monkeypatch.setattr(nui, "EXACT_SVD_ENTRIES", 0)
    torch.manual_seed(11)
    before = torch.rand(3)
    torch.manual_seed(11)
    fast = nui.leading_directions(x, 4)
    assert torch.equal(torch.rand(3), before)
    assert fast.shape == exact.shape == (4, 600)
    cosines = torch.linalg.svdvals(exact @ fast.T)
    assert float((1 - cosines).abs().max()) < 1e-6


def test_drift_fit_reads_the_room_not_the_person():
    """A difference made of known drift coefficients plus a person's light with a part along the
    room light: the network's projection takes the person for drift (a bias), the drift fit with
    the people's directions reads the coefficients that were drawn (noise-free: to the ridge)."""
    L = smooth_room(9)
    proj = NuisanceProjection()
    proj.set_prior(*[t.float() for t in prior(L)])
    total = sum(L.nominal())
    n = 6
    b = total[None].expand(n, -1, -1, -1)
    m = nuisance_basis(b, *prior(L))
    c = 1e-4 * torch.randn(n, 7, generator=torch.Generator().manual_seed(10), dtype=torch.float64)
    person = people_light(L, n, 11)
    diff = torch.einsum("bk,bkhwc->bhwc", c, m) + person
    biased = proj(diff.float(), b.float())[1].double()
    assert float((biased - c).abs().max() / c.abs().max()) > 0.2  # the person's light read as drift
    proj.set_person(person_light_basis(people_light(L, 40, 12), total, 2))
    got, se = proj.drift(diff.float(), b.float())
    assert torch.allclose(got.double(), c, atol=1e-4 * float(c.abs().max()))
    assert se.shape == (n, 7)


def test_room_models_without_person_directions_still_load():
    """A state dict from before the drift fit's person directions loads with none, and then the
    drift is the projection's own coefficients; with them it round-trips."""
    L = smooth_room()
    p = NuisanceProjection()
    p.set_prior(*[t.float() for t in prior(L)])
    old = {k: v for k, v in p.state_dict().items() if k != "person"}
    q = NuisanceProjection()
    q.load_state_dict(old)
    d = 1e-3 * torch.randn(2, H, W, 3, generator=torch.Generator().manual_seed(13))
    bg = sum(L.nominal()).float()[None].expand(2, -1, -1, -1)
    assert q.person.numel() == 0 and torch.equal(q.drift(d, bg)[0], q(d, bg)[1])
    p.set_person(person_light_basis(people_light(L, 10, 14), sum(L.nominal()), 3))
    r = NuisanceProjection()
    r.load_state_dict(p.state_dict())
    assert torch.equal(r.person, p.person)
    with pytest.raises(ValueError, match="person directions"):
        r.set_person(torch.zeros(2, 4, 4, 3))
