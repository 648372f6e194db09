"""Per-pixel geometry of a room's visible surfaces, for the geometry-aware NLOS network.

A network that must work in rooms it never saw has to know which surface each pixel shows: where
it is relative to the hidden region, which way it faces, how bright its paint is, and whether the
spot lights it. All four are known before any person walks in (the scan the IEN reads, and the
spot's own image), so they are given to the network instead of being inferred from the light.

Channels (``GEOMETRY_CHANNELS`` = 10), in the region frame of the targets (``tensors.ground_frame``:
origin at the hidden region's floor center, axes along the camera's view on the floor, to its left,
up): position (3, m; height above the hidden region's floor), normal (3), albedo (3), and the
fraction of the illumination's brightest pixel that the person-free image under the current
illumination has there (1; 0 with the projector off).

Shapes:
    room (9, H, W); :func:`geometry_input` (B, 10, H, W) for B samples of one room under one light.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import torch

from ..errors import NlosError
from .tensors import SceneTensors, region_frame, region_points

GEOMETRY_CHANNELS = 10
"""Position (3), normal (3), albedo (3), lit fraction (1)."""


@functools.lru_cache(maxsize=None)
def _room_geometry(scene_dir: str) -> torch.Tensor:
    from ..render.gbuffer import render_gbuffer
    from ..scene.io import load_scene

    d = Path(scene_dir)
    scene = load_scene(d)  # NlosError on a broken scene
    from .static import read_static

    pose = read_static(d, "camera_to_world")["camera_to_world"]
    if scene.hidden_region is None:
        raise NlosError(f"{d}/scene.json: no hidden_region (the geometry's frame)")
    origin, fwd, floor_z = region_frame(scene.hidden_region, pose)
    g = render_gbuffer(scene)
    h, w = g.hit.shape
    pos = region_points(g.position.reshape(-1, 3), origin, fwd, floor_z).reshape(h, w, 3)
    nrm = region_points(g.normal.reshape(-1, 3), np.zeros(2), fwd, 0.0).reshape(h, w, 3)  # directions: no shift
    room = np.concatenate([pos, nrm, g.albedo], -1) * g.hit[..., None]  # misses: all zero
    return torch.as_tensor(room, dtype=torch.float32).permute(2, 0, 1).contiguous()


def room_geometry(s: SceneTensors) -> torch.Tensor:
    """(9, H, W) position, normal and albedo of what each pixel of room ``s`` shows (cached per room)."""
    if not s.scene_dir:
        raise NlosError("geometry-aware network: the room was built in memory, not read from a dataset")
    g = _room_geometry(str(Path(s.scene_dir).resolve()))
    if g.shape[1:] != s.ambient.shape[:2]:
        raise NlosError(f"{s.scene_dir}: scene camera {tuple(g.shape[1:])} does not match the stored images "
                        f"{tuple(s.ambient.shape[:2])}")
    return g.to(s.ambient.device)


def lit_fraction(person_free: torch.Tensor, projector_on: bool = True) -> torch.Tensor:
    """(H, W) luminance of the person-free image over its maximum (zeros with the projector off)."""
    if not projector_on:
        return torch.zeros(person_free.shape[:2], dtype=person_free.dtype, device=person_free.device)
    lum = person_free.mean(-1)
    return lum / lum.max().clamp(min=1e-20)


def geometry_input(s: SceneTensors, lit_image: torch.Tensor, batch: int, projector_on: bool = True) -> torch.Tensor:
    """(B, 10, H, W): room ``s``'s geometry and the lit fraction of ``lit_image`` (H, W, 3), the
    projector's person-free light without the ambient light."""
    lit = lit_fraction(lit_image, projector_on).unsqueeze(0)
    return torch.cat([room_geometry(s), lit], 0).unsqueeze(0).expand(batch, -1, -1, -1)


__all__ = ["GEOMETRY_CHANNELS", "geometry_input", "lit_fraction", "room_geometry"]
