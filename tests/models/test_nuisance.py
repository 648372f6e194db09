"""The nuisance projection (models/nuisance.py): the known answer on a synthetic case, its slow
reference, drift estimates against the capture variation that made them, checkpoints."""

from __future__ import annotations

import math

import pytest
import torch

from nlos_spotlight.models.nuisance import (NuisanceProjection, noise_weights, nuisance_basis, project_out,
                                            project_out_reference, room_prior)
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
