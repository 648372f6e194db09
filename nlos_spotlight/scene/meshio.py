"""Mesh files (PLY, OBJ) to and from :class:`TriMesh`, through trimesh."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ..errors import NlosError
from .format import TriMesh

SUFFIXES = (".ply", ".obj")


def load_mesh(path: str | Path, where: str | None = None) -> TriMesh:
    """Read a triangle mesh with optional per-vertex or per-face colors; validate it."""
    import trimesh

    path = Path(path)
    where = where or str(path)
    if not path.is_file():
        raise NlosError(f"{where}: mesh file not found: {path}")
    if path.suffix.lower() not in SUFFIXES:
        raise NlosError(f"{where}: unsupported mesh type '{path.suffix}' (use .ply or .obj)")
    # trimesh logs (not raises) on a missing .mtl; that is the behaviour we want, quietly.
    logging.getLogger("trimesh").setLevel(logging.ERROR)
    try:
        tm = trimesh.load(path, force="mesh", process=False, skip_materials=True)
    except Exception as exc:  # trimesh raises many types on corrupt files
        raise NlosError(f"{where}: cannot read mesh {path.name}: {exc}".splitlines()[0]) from None
    if not isinstance(tm, trimesh.Trimesh):
        raise NlosError(f"{where}: {path.name} holds no triangle mesh")
    if len(tm.faces) == 0:
        _no_faces(path, where)
    vertices = np.asarray(tm.vertices, dtype=np.float64)
    faces = np.asarray(tm.faces, dtype=np.int64)
    vcol = fcol = None
    kind = getattr(tm.visual, "kind", None)
    if kind == "vertex":
        vcol = np.asarray(tm.visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0
    elif kind == "face":
        fcol = np.asarray(tm.visual.face_colors, dtype=np.float64)[:, :3] / 255.0
    mesh = TriMesh(vertices, faces, vcol, fcol)
    validate_mesh(mesh, where)
    return mesh


def _no_faces(path: Path, where: str) -> None:
    """Refuse a file without triangles, saying whether it is a point cloud (a scan not yet meshed)."""
    import trimesh

    try:
        raw = trimesh.load(path, process=False, skip_materials=True)
        points = len(raw.vertices) if isinstance(raw, trimesh.PointCloud) else 0
    except Exception:
        points = 0
    if points:
        raise NlosError(f"{where}: {path.name} is a point cloud ({points} points, no triangles); mesh the scan "
                        "first (e.g. Poisson surface reconstruction) and give the triangle mesh")
    raise NlosError(f"{where}: {path.name} holds no triangles")


def validate_mesh(mesh: TriMesh, where: str) -> None:
    """Raise :class:`NlosError` on empty meshes, non-finite vertices or bad indices."""
    if mesh.vertices.ndim != 2 or mesh.vertices.shape[1] != 3 or len(mesh.vertices) == 0:
        raise NlosError(f"{where}: mesh has no vertices")
    if mesh.faces.ndim != 2 or mesh.faces.shape[1] != 3 or len(mesh.faces) == 0:
        raise NlosError(f"{where}: mesh has no triangles")
    if not np.all(np.isfinite(mesh.vertices)):
        bad = int(np.flatnonzero(~np.isfinite(mesh.vertices).all(axis=1))[0])
        raise NlosError(f"{where}: vertex {bad} has a non-finite coordinate")
    if mesh.faces.min() < 0 or mesh.faces.max() >= len(mesh.vertices):
        raise NlosError(f"{where}: face index out of range (mesh has {len(mesh.vertices)} vertices)")
    if np.abs(mesh.vertices).max() > 1e4:
        raise NlosError(f"{where}: coordinates up to {np.abs(mesh.vertices).max():.3g} m; expected meters")
    if float(mesh.face_areas().sum()) <= 0.0:
        raise NlosError(f"{where}: mesh has zero surface area")
    for name, col in (("vertex", mesh.vertex_colors), ("face", mesh.face_colors)):
        if col is not None and (not np.all(np.isfinite(col)) or col.min() < 0 or col.max() > 1):
            raise NlosError(f"{where}: {name} colors outside [0, 1]")


def save_mesh(mesh: TriMesh, path: str | Path) -> None:
    """Write a mesh (binary PLY keeps float64 positions and colors)."""
    import trimesh

    kwargs = {}
    if mesh.vertex_colors is not None:
        kwargs["vertex_colors"] = np.round(mesh.vertex_colors * 255).astype(np.uint8)
    elif mesh.face_colors is not None:
        kwargs["face_colors"] = np.round(mesh.face_colors * 255).astype(np.uint8)
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False, **kwargs)
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(tm.export(file_type=path.suffix.lstrip(".").lower()) if path.suffix.lower() == ".ply"
                    else tm.export(file_type="obj").encode())
    tmp.replace(path)
