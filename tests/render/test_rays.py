"""The reference ray engine (embreex): batches split over threads answer as one batch does."""

from __future__ import annotations

import numpy as np
import torch

from nlos_spotlight.render import rays
from nlos_spotlight.render.rays import RayEngine


def test_batches_on_two_threads_answer_as_one_thread_does(box, monkeypatch):
    """Over ``PARALLEL_MIN`` rays a query is split into slices run on a thread pool (``make test`` runs
    one thread a process, so this path needs its own test): the answers equal one thread's, and a
    segment between points outside a box is blocked iff the slab test says it crosses the box."""
    v, f = box.mesh([-1, -1, -1], [1, 1, 1])
    monkeypatch.setattr(rays, "PARALLEL_MIN", 1 << 12)  # several slices without millions of rays
    a, b = np.random.default_rng(5).uniform(-3, 3, (40000, 2, 3)).transpose(1, 0, 2)
    engine, threads = RayEngine(v, f), torch.get_num_threads()
    try:
        torch.set_num_threads(1)
        one = engine.occluded(a, b)
        torch.set_num_threads(2)
        assert rays._workers() == 2
        two = engine.occluded(a, b)
    finally:
        torch.set_num_threads(threads)
    assert np.array_equal(one, two) and 0.2 < one.mean() < 0.9
    clear, crosses = box.crossings(a, b)
    assert np.array_equal(two[clear], crosses[clear])
