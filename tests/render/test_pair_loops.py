"""The compiled pair loops (``render/pair_loops.py``) against the torch kernels they replace."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from nlos_spotlight.render import pair_loops
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.rays import pair_rays

@pytest.fixture(scope="module")
def pair(glossy_corner_pair):
    return glossy_corner_pair(300, "float64", pair_loops=True)


def _open(person: Person) -> Person:
    """The same samples as an open surface: light reaches both sides, no pair is skipped for it."""
    return dataclasses.replace(person, closed=False)


@pytest.mark.parametrize("shape", ["closed", "open"])
def test_transport_equals_torch(pair, shape):
    torch_r, loops_r, person = pair
    person = person if shape == "closed" else _open(person)
    assert person.closed == (shape == "closed")
    t = [0.05, -0.03]
    with torch.no_grad():
        want = torch_r.transport_images(person, t, nlos_ambient=True)
        got = loops_r.transport_images(person, t, nlos_ambient=True)
    assert float(want[:-1].abs().max()) > 0 and float(want[-1].abs().max()) > 0
    assert torch.allclose(got, want, rtol=1e-9, atol=1e-12 * float(want.abs().max()))


def test_render_equals_torch_and_keeps_gradients(pair):
    torch_r, loops_r, person = pair
    comps = ("nlos", "nlos_ambient")
    y = torch.tensor([0.2, 0.5, 0.3], dtype=torch.float64)
    with torch.no_grad():
        want = torch_r.render(y, person, translation=[0.02, 0.04], components=comps)
        got = loops_r.render(y, person, translation=[0.02, 0.04], components=comps)
    for k in comps:
        assert torch.allclose(got[k], want[k], rtol=1e-9, atol=1e-12 * float(want[k].abs().max())), k
    grads = []
    for r in (torch_r, loops_r):  # a gradient asked for: the loops step aside for the torch kernels
        yy = y.clone().requires_grad_(True)
        r.render(yy, person, translation=[0.02, 0.04], components=("nlos",))["nlos"].sum().backward()
        grads.append(yy.grad)
    assert float(grads[0].abs().max()) > 0
    assert torch.allclose(grads[1], grads[0], rtol=1e-9)


def test_shadow_rays_match_pair_rays():
    """The compacted rays are the rays ``rays.pair_rays`` builds for the needed pairs, in order."""
    rng = np.random.default_rng(0)
    pa, pb = rng.normal(size=(40, 3)), rng.normal(size=(30, 3)) + [0, 0, 2.0]
    na = rng.normal(size=(40, 3))
    nb = rng.normal(size=(30, 3))
    na /= np.linalg.norm(na, axis=1, keepdims=True)
    nb /= np.linalg.norm(nb, axis=1, keepdims=True)
    front = rng.choice([-1.0, 1.0], size=40)
    for closed in (True, False):
        d = pb[None] - pa[:, None]
        need = ((d * na[:, None]).sum(-1) * front[:, None] > 0) & (((d * nb[None]).sum(-1) < 0) | (not closed))
        keys = pair_loops.no_keys(len(pa), len(pb))
        start = pair_loops.pair_start(pair_loops.need_counts(pa, na, front, pb, nb, closed, *keys))
        org, dirs, length, idx = pair_loops.shadow_rays(pa, na, front, pb, nb, closed, *keys, start)
        assert start[-1] == need.sum() > 0
        assert np.array_equal(idx, np.nonzero(need)[1])
        t = [torch.as_tensor(x) for x in (pa, na, pb, nb)]
        want = pair_rays(*t, need=torch.as_tensor(need))
        for a, b in zip((org, dirs, length), want):
            assert np.allclose(a, b, atol=1e-6)


def test_group_runs():
    assert pair_loops.group_runs(np.array([0, 0, 3, 3, 3, 5])).tolist() == [0, 2, 5, 6]
    assert pair_loops.group_runs(np.zeros(4, np.int64)).tolist() == [0, 4]


def test_serial_twins_equal_the_parallel_loops(pair):
    """One thread runs the loops' serial twins (``pair_loops.SERIAL``): the same sums as the parallel ones."""
    _, loops_r, person = pair
    before = torch.get_num_threads()
    out = {}
    try:
        for n in (1, 2):
            torch.set_num_threads(n)
            with torch.no_grad():
                out[n] = loops_r.transport_images(person, [0.05, -0.03], nlos_ambient=True)
            one = min(n, pair_loops.numba.config.NUMBA_NUM_THREADS) == 1
            assert pair_loops.loops() is (pair_loops.SERIAL if one else pair_loops.PARALLEL)
    finally:
        torch.set_num_threads(before)
    assert float(out[1].abs().max()) > 0
    assert torch.allclose(out[1], out[2], rtol=1e-9, atol=1e-12 * float(out[2].abs().max()))
