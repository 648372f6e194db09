"""The graph the Illumination Estimation Network reads (DESIGN section 8).

Nodes are mesh vertices, edges are mesh edges (both directions, the PyTorch
Geometric convention), and the faces ride along because the IEN scores faces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..errors import NlosError
from .format import TriMesh


@dataclass
class MeshGraph:
    """A triangle mesh as tensors for the IEN.

    Shapes (V vertices, E directed edges, F faces):

    - ``pos``: (V, 3) float32 vertex positions, m, in the graph's frame (the
      camera frame when :func:`mesh_to_graph` got one), *not* normalized; see
      :func:`normalize_positions`.
    - ``edge_index``: (2, E) int64; every undirected mesh edge appears once in
      each direction, no self loops, no duplicates, sorted by (source, target).
    - ``faces``: (F, 3) int64 vertex indices.
    - ``normals``: (V, 3) float32 unit area-weighted vertex normals (zero for a
      vertex whose faces cancel or that no face uses).
    - ``face_normals``: (F, 3) float32 unit face normals (right-hand winding).
    - ``face_centroids``: (F, 3) float32, m, same frame as ``pos``.
    - ``colors``: (V, 3) float32 in [0, 1], or None. A mesh with face colors
      only gets the area-weighted mean of its faces' colors per vertex.
    """

    pos: torch.Tensor
    edge_index: torch.Tensor
    faces: torch.Tensor
    normals: torch.Tensor
    face_normals: torch.Tensor
    face_centroids: torch.Tensor
    colors: torch.Tensor | None = None

    @property
    def num_vertices(self) -> int:
        return int(self.pos.shape[0])

    @property
    def num_faces(self) -> int:
        return int(self.faces.shape[0])


def mesh_edges(faces: np.ndarray, num_vertices: int) -> np.ndarray:
    """(2, E) int64 directed edges of (F, 3) faces: both directions, unique, no
    self loops, sorted by (source, target). Vectorized (no loop over faces)."""
    f = np.asarray(faces, np.int64)
    e = f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    e = np.concatenate([e, e[:, ::-1]])
    e = e[e[:, 0] != e[:, 1]]
    keys = np.unique(e[:, 0] * num_vertices + e[:, 1])  # sorted: source-major order
    return np.stack([keys // num_vertices, keys % num_vertices])


def _check_frame(frame: np.ndarray) -> np.ndarray:
    m = np.asarray(frame, dtype=np.float64)
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise NlosError(f"graph frame must be a finite 4x4 matrix, got shape {m.shape}")
    if not np.allclose(m[3], [0, 0, 0, 1]) or abs(np.linalg.det(m[:3, :3])) < 1e-12:
        raise NlosError("graph frame must be an invertible affine 4x4 transform (last row 0 0 0 1)")
    return m


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return np.where(n > 1e-30, v / np.maximum(n, 1e-30), 0.0)


def mesh_to_graph(mesh: TriMesh, frame: np.ndarray | None = None) -> MeshGraph:
    """Build the IEN graph of ``mesh``.

    Args:
        mesh: (V, 3) vertices in m, (F, 3) faces, optional colors.
        frame: optional (4, 4) world -> camera transform applied to positions
            (``p' = A p + t``) and normals (by the inverse transpose of ``A``,
            renormalized; for a rigid transform that is ``A`` itself).

    Returns:
        A :class:`MeshGraph`.
    """
    v = np.asarray(mesh.vertices, np.float64)
    f = np.asarray(mesh.faces, np.int64)
    if frame is not None:
        m = _check_frame(frame)
        v = v @ m[:3, :3].T + m[:3, 3]
    # Computed after the transform so winding-based normals stay consistent with positions
    # (a reflection in `frame` flips the winding's handedness together with them).
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # |cross| = 2 * area
    vn = np.zeros_like(v)
    for k in range(3):  # three vectorized scatters, not a loop over faces
        np.add.at(vn, f[:, k], cross)
    if frame is not None and np.linalg.det(m[:3, :3]) < 0:
        cross, vn = -cross, -vn  # keep normals equal to the transformed original normals
    colors = _vertex_colors(mesh, cross)
    as32 = (lambda a: torch.as_tensor(np.ascontiguousarray(a), dtype=torch.float32))
    return MeshGraph(
        pos=as32(v),
        edge_index=torch.as_tensor(mesh_edges(f, len(v))),
        faces=torch.as_tensor(f.copy()),
        normals=as32(_unit(vn)),
        face_normals=as32(_unit(cross)),
        face_centroids=as32(v[f].mean(axis=1)),
        colors=None if colors is None else as32(colors),
    )


def _vertex_colors(mesh: TriMesh, cross: np.ndarray) -> np.ndarray | None:
    """(V, 3) vertex colors; from face colors by area-weighted averaging."""
    if mesh.vertex_colors is not None:
        return mesh.vertex_colors
    if mesh.face_colors is None:
        return None
    w = 0.5 * np.linalg.norm(cross, axis=1)
    acc, tot = np.zeros((len(mesh.vertices), 3)), np.zeros(len(mesh.vertices))
    for k in range(3):
        np.add.at(acc, mesh.faces[:, k], mesh.face_colors * w[:, None])
        np.add.at(tot, mesh.faces[:, k], w)
    return np.clip(acc / np.maximum(tot, 1e-30)[:, None], 0.0, 1.0)


def normalize_positions(pos: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Center at the vertex centroid and divide by the RMS distance to it.

    The IEN reads unit-free coordinates (DESIGN section 8): the result is the
    same for ``pos`` and ``s * pos + t`` (any translation t, any scale s > 0),
    and has zero mean and unit RMS norm. The camera frame's orientation is kept.

    Args:
        pos: (V, 3) float positions.

    Returns:
        (pos - center) / scale (V, 3), center (3,), scale () (RMS distance, m).
    """
    if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] == 0:
        raise NlosError(f"normalize_positions: expected (V, 3) positions, got {tuple(pos.shape)}")
    center = pos.mean(dim=0)
    scale = (pos - center).pow(2).sum(dim=1).mean().sqrt()
    if not torch.isfinite(scale) or scale <= 0:
        raise NlosError("normalize_positions: all vertices coincide (zero spread)")
    return (pos - center) / scale, center, scale


def to_pyg(graph: MeshGraph):
    """A ``torch_geometric.data.Data`` with PyG's names: ``pos`` (V, 3),
    ``edge_index`` (2, E), ``face`` (3, F) (PyG stores faces transposed), ``norm``
    (V, 3) (as ``GenerateMeshNormals`` names it), ``face_normal`` (F, 3),
    ``face_centroid`` (F, 3) and ``color`` (V, 3) when present."""
    from torch_geometric.data import Data

    data = Data(pos=graph.pos, edge_index=graph.edge_index, face=graph.faces.t().contiguous(),
                norm=graph.normals, face_normal=graph.face_normals, face_centroid=graph.face_centroids,
                num_nodes=graph.num_vertices)
    if graph.colors is not None:
        data.color = graph.colors
    return data
