"""Fixtures shared by the app tests (not a conftest.py: tests/conftest.py is imported by name)."""

from __future__ import annotations

import pytest
import torch


@pytest.fixture(scope="module", autouse=True)
def _one_thread():
    """Tiny 8x8 images and small graphs: on a shared 2-core machine, OpenMP threads that wait for
    each other cost far more than they parallelize (measured 1.1 s vs 0.04 s per forward under load)."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)
