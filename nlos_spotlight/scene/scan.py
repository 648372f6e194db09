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


def rotation_to_z(up: np.ndarray) -> np.ndarray:
    """(3, 3) the smallest rotation taking the unit vector ``up`` to +z (Rodrigues)."""
    u = np.asarray(up, np.float64) / np.linalg.norm(up)
    c = float(u[2])
    if c > 1 - 1e-12:
        return np.eye(3)
    if c < -1 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])  # half a turn about x
    v = np.cross(u, [0.0, 0.0, 1.0])
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1 + c)


def load_scan_z_up(path: Path, up: str | None = None) -> tuple[TriMesh, np.ndarray]:
    """A bare mesh cleaned and turned z up by the smallest rotation (the file's horizontal axes and
    height kept, so coordinates a user reads off the scan stay meaningful; ``nlos spotlight`` and
    ``nlos fit``), and its (4, 4) file_to_world. :func:`load_scan` instead normalizes the frame."""
    from .orient import detect_up_axis

    if up is not None and up not in UP_AXES:
        raise NlosError(f"--up: unknown axis {up!r} (use one of {', '.join(UP_AXES)})")
    mesh = clean_mesh(load_mesh(path))
    rot = rotation_to_z(detect_up_axis(mesh) if up is None else np.array(UP_AXES[up], np.float64))
    t = np.eye(4)
    t[:3, :3] = rot
    return TriMesh(mesh.vertices @ rot.T, mesh.faces, mesh.vertex_colors, mesh.face_colors), t
