"""Load a real room scan ready for the pipeline: read, clean, z up, decimate."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import NlosError
from .clean import clean_mesh
from .decimate import decimate
from .format import TriMesh
from .meshio import load_mesh
from .orient import to_z_up

UP_AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1), "-x": (-1, 0, 0), "-y": (0, -1, 0), "-z": (0, 0, -1)}
"""Names accepted for the ``up`` argument of :func:`load_scan`."""


def load_scan(path: str | Path, up: str | None = None, target_vertices: int | None = None) -> TriMesh:
    """Read a PLY/OBJ scan (meters) and return it cleaned, z up with the floor at
    z = 0, and optionally decimated.

    Args:
        path: mesh file.
        up: the file's up axis ('x', 'y', 'z', '-x', '-y', '-z'); None detects it
            (:func:`nlos_spotlight.scene.orient.detect_up_axis`).
        target_vertices: decimate to about this many vertices; None keeps all.
    """
    if up is not None and up not in UP_AXES:
        raise NlosError(f"unknown up axis {up!r} (use one of {', '.join(UP_AXES)})")
    mesh = clean_mesh(load_mesh(path))
    mesh, _ = to_z_up(mesh, None if up is None else np.array(UP_AXES[up], dtype=np.float64))
    return mesh if target_vertices is None else decimate(mesh, target_vertices)
