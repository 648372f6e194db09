"""The LOS mesh: the faces of a room's static mesh that the camera sees, cleaned and decimated.

It is what a scan from the camera's side holds, the graph the IEN reads and whose faces are the
spot candidates. One function builds it for dataset generation (the IEN's training input), for
``nlos fit`` and for ``nlos spotlight`` (its input in a user's room), so the IEN meets meshes made
the same way in training and in use. Visible faces are found with 2 x 2 rays per pixel of the
camera, widened to at least ``min_width`` pixels across: ``nlos spotlight`` reads fine scans whose
small faces a 32-pixel camera's 64 rays would miss (``apps.spotlight.VISIBILITY_WIDTH``); datasets
keep the camera's own width (their rooms' faces are large), as every stored dataset was built.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import NlosError
from .format import Camera, TriMesh


def los_mesh(mesh: TriMesh, engine, camera: Camera, target_vertices: int, min_width: int = 0) -> TriMesh:
    """The faces of ``mesh`` (traced by ``engine``, a ``render.rays.RayEngine`` of it) that ``camera``
    sees, cleaned (``scene.clean``) and quadric-decimated to about ``target_vertices`` vertices."""
    from ..render.camera import pixel_rays
    from .clean import clean_mesh
    from .decimate import decimate

    cam = camera
    if cam.width < min_width:
        cam = dataclasses.replace(cam, width=min_width, height=max(1, round(min_width * cam.height / cam.width)))
    dirs, origin = pixel_rays(cam, 2)
    flat = dirs.reshape(-1, 3)
    h = engine.first_hit(np.broadcast_to(origin, flat.shape), flat)
    faces = np.unique(h.face[h.hit])
    if len(faces) < 2:
        raise NlosError(f"the camera at {np.round(cam.position, 3).tolist()} looking at "
                        f"{np.round(cam.look_at, 3).tolist()} sees {'no' if not len(faces) else 'one'} "
                        "face of the mesh")
    sub = clean_mesh(TriMesh(mesh.vertices, mesh.faces[faces]))
    return decimate(sub, int(target_vertices)) if len(sub.vertices) > target_vertices else sub


__all__ = ["los_mesh"]
