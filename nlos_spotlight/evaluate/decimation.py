"""Figure 7: how the IEN's spot, and so the NLOS accuracy, holds up as the scanned mesh is decimated.

Per test scene, the camera-visible static surface (what a phone scan from the camera side holds)
is subdivided until it has at least ``DENSE_RANGE[0]`` vertices and quadric-decimated to
``DENSE_TARGET`` (the paper's meshes had 9k-11k vertices), then decimated to each ratio
0.1-1.0. The IEN picks a face on that mesh; the projector aims at its centroid, which we snap to
the nearest stored candidate aim point (the dataset holds transport for those only; the snap
distance is reported). The NLOS network then reads the resulting photographs.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..lighting import Illumination
from ..scene.format import TriMesh
from ..train.checkpoint import TrainedModels
from ..data.tensors import SceneTensors, face_log_prior, graph_inputs, region_floor

RATIOS = tuple(round(0.1 * k, 1) for k in range(1, 11))
"""Decimation ratios of the figure (fraction of the dense mesh's vertices kept)."""
DENSE_TARGET = 10_000
"""Vertex count of the dense scan stand-in."""
DENSE_RANGE = (9_000, 11_000)


@dataclass
class DecimatedChoice:
    """The IEN's spot on one scene at one decimation ratio."""

    ratio: float
    vertices: int
    """Vertices of the decimated mesh the IEN read."""
    candidate: int
    """Stored candidate nearest to the chosen face's centroid."""
    snap_m: float
    """Distance from the chosen centroid to that candidate's aim point, m."""


def dense_los_mesh(scene_dir: Path) -> TriMesh:
    """The camera-visible static faces of a dataset scene, subdivided and decimated to ~10k vertices."""
    import trimesh

    from ..scene.los import los_mesh
    from ..render.surface import StaticSurfaces
    from ..scene import load_scene
    from ..scene.decimate import decimate

    scene = load_scene(scene_dir)
    surf = StaticSurfaces(scene)
    m = los_mesh(surf.mesh, surf.engine, scene.camera, 10**9)
    v, f = m.vertices, m.faces
    while len(v) < DENSE_RANGE[0]:
        v, f = trimesh.remesh.subdivide(v, f)
    return decimate(TriMesh(np.asarray(v, float), np.asarray(f, np.int64)), DENSE_TARGET)


def choices(models: TrainedModels, s: SceneTensors, ratios=RATIOS) -> list[DecimatedChoice]:
    """The IEN's spot at every ratio, snapped to the stored candidates of ``s``."""
    from ..data.static import read_static
    from ..scene.decimate import decimate_ratio

    st = read_static(s.scene_dir, "camera_to_world", "aim_points", "spot_landed")
    pose, aims = st["camera_to_world"], st["aim_points"]
    ok = st["spot_landed"]
    dense = dense_los_mesh(Path(s.scene_dir))
    region = (s.origin_xy.numpy(), s.forward_xy.numpy(), region_floor(Path(s.scene_dir)))
    out = []
    for r in ratios:
        mesh = decimate_ratio(dense, r) if r < 1 else dense
        prior = None
        if "adaptive" in models.config.ien_features:
            from ..lighting.adaptive import adaptive_scores
            from ..scene import load_scene

            prior = adaptive_scores(load_scene(s.scene_dir), mesh.centroids())
        x, edges = graph_inputs(mesh, pose, models.config.ien_features, region, prior)
        with torch.no_grad():
            face = int(models.ien(x, edges, torch.as_tensor(mesh.faces, dtype=torch.long),
                                  face_log_prior(prior) if prior is not None else None).argmax())
        c = mesh.vertices[mesh.faces[face]].mean(0)
        d = np.where(ok, np.linalg.norm(aims - c, axis=1), np.inf)
        out.append(DecimatedChoice(r, len(mesh.vertices), int(d.argmin()), float(d.min())))
    return out


def as_illumination(c: DecimatedChoice) -> Illumination:
    return Illumination("spot", c.candidate)
