"""``data/static.py``: the one reader of a stored room's ``static.npz``."""

import numpy as np
import pytest

from nlos_spotlight.data.static import read_static, static_path
from nlos_spotlight.errors import NlosError


def test_reads_named_arrays_and_names_each_problem(tmp_path):
    with pytest.raises(NlosError, match=r"static\.npz: missing"):
        read_static(tmp_path)
    np.savez(static_path(tmp_path), aim_points=np.eye(3), spot_landed=np.array([True, False, True]))
    got = read_static(tmp_path, "aim_points")
    assert list(got) == ["aim_points"] and np.array_equal(got["aim_points"], np.eye(3))
    assert sorted(read_static(tmp_path)) == ["aim_points", "spot_landed"]
    with pytest.raises(NlosError, match="no 'direct'.*generate the room again"):
        read_static(tmp_path, "direct")
    static_path(tmp_path).write_bytes(static_path(tmp_path).read_bytes()[:40])  # torn
    with pytest.raises(NlosError, match="unreadable"):
        read_static(tmp_path, "aim_points")


def test_a_pickled_array_is_refused(tmp_path):
    """A shared room runs no code: object arrays (pickles) are not loaded."""
    np.savez(static_path(tmp_path), aim_points=np.array([{"x": 1}], dtype=object))
    with pytest.raises(NlosError, match="unreadable"):
        read_static(tmp_path, "aim_points")
