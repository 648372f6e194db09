"""Shading data at surface points of the static scene."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..scene.format import Scene
from .rays import RayEngine


@dataclass
class SurfacePoints:
    """N shading points (numpy float64, world frame)."""

    pos: np.ndarray
    """(N, 3) positions, m."""
    normal: np.ndarray
    """(N, 3) unit geometric normals (orientation arbitrary: materials are two-sided)."""
    kd: np.ndarray
    """(N, 3) diffuse albedo including vertex/face colors."""
    ks: np.ndarray
    """(N, 3) GGX lobe weight."""
    alpha: np.ndarray
    """(N,) GGX roughness."""
    emission: np.ndarray
    """(N, 3) emitted radiance."""
    face: np.ndarray
    """(N,) static face index."""

    def __len__(self) -> int:
        return len(self.pos)

    def subset(self, idx) -> "SurfacePoints":
        return SurfacePoints(*(getattr(self, f)[idx] for f in self.__dataclass_fields__))

    def torch(self, device, dtype) -> dict[str, torch.Tensor]:
        return {f: torch.as_tensor(getattr(self, f), device=device,
                                   dtype=torch.long if f == "face" else dtype)
                for f in self.__dataclass_fields__}

    @property
    def glossy(self) -> np.ndarray:
        return self.ks.max(axis=1) > 0


class StaticSurfaces:
    """The concatenated static mesh with per-face materials and its ray engine."""

    def __init__(self, scene: Scene):
        mesh, owner = scene.static_mesh()
        self.mesh = mesh
        mats = [scene.materials[s.material] for s in scene.shapes]
        self.face_kd = np.stack([mats[i].diffuse for i in owner]) * mesh.face_colors
        self.face_ks = np.stack([mats[i].specular for i in owner])
        self.face_alpha = np.array([mats[i].roughness for i in owner])
        self.face_emission = np.stack([mats[i].emission for i in owner])
        self.face_normal = mesh.face_normals()
        self.engine = RayEngine(mesh.vertices, mesh.faces)

    def shade(self, face: np.ndarray, bary: np.ndarray) -> SurfacePoints:
        """Surface points on ``face`` at barycentric weights ``bary`` (N, 3)."""
        tri = self.mesh.faces[face]
        pos = np.einsum("ij,ijk->ik", bary, self.mesh.vertices[tri])
        vcol = np.einsum("ij,ijk->ik", bary, self.mesh.vertex_colors[tri])
        return SurfacePoints(pos, self.face_normal[face], self.face_kd[face] * vcol, self.face_ks[face],
                             self.face_alpha[face], self.face_emission[face], face)

    def trace(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, SurfacePoints]:
        """First hits of rays; returns the (N,) hit mask and the shading points of the hits."""
        h = self.engine.first_hit(origins, directions)
        return h.hit, self.shade(h.face[h.hit], h.bary[h.hit])
