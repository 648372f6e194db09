"""The fused (torch.compile) pair kernels against the eager ones they replace, values and gradients."""

from __future__ import annotations

import warnings

import pytest
import torch


@pytest.fixture(scope="module")
def pair(glossy_corner_pair):
    return glossy_corner_pair(64, "float32", fuse=True)


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
