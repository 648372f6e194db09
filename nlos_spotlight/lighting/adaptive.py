"""Adaptive Lighting (Chandran & Jayasuriya, BMVC 2019): a radiosity score per candidate spot.

The policy knows the room's geometry (the scan), the projector and the camera, but neither the
materials nor the person. Like the paper's algorithm it assumes every surface Lambertian with
one albedo rho and scores each LOS patch by the light that can go projector -> patch -> hidden
region -> camera-visible LOS surfaces -> camera, with form factors and ray-traced visibility
(Embree, :class:`~nlos_spotlight.render.rays.RayEngine`). The spot goes to the best landed patch.

Model (docs/baselines.md gives the reasons for each choice):

* **Light on the patch.** Candidate t's spot is ``spot_rays`` projector rays in its cutoff cone
  (the renderer's Fibonacci quadrature, :mod:`nlos_spotlight.render.spot`), ray j carrying flux
  ``Phi_j = f(theta_j) dOmega`` (unit on-axis intensity: the projector is the same for every t).
  Where ray j first hits the static mesh is the lit point x_j, normal n_j turned toward the
  projector; a Lambertian patch reflects rho Phi_j, so ``L_j dA_j = rho Phi_j / pi``.
* **The hidden region.** A person is stood in for by vertical prisms: at every point of a
  ``grid x grid`` floor grid over the hidden region and at each of ``heights`` above the floor,
  ``normals`` one-sided elements with horizontal normals n_k (a closed body lights and shows
  only its outward side), area a each.
* **Back to the camera.** The camera-visible LOS points x_p are the first hits of a
  ``receivers x receivers`` grid of camera rays, normals turned toward the camera; the image is
  the mean over them.

With ``G+(a, b) = max(0, n_a.w) max(0, n_b.(-w)) / |a - b|^2`` (w the unit direction a -> b, zero
where a surface faces away) and V the visibility through the static mesh,

    score_t = (rho / pi)^3 a / P  sum_{j in t} Phi_j  sum_{m, k} G+(x_j, o_mk) V(x_j, o_m)
                                                               * sum_p G+(o_mk, x_p) V(o_m, x_p)

which is the three-bounce radiance a uniform-albedo room would send to the camera, averaged over
the pixels and summed over the stand-in person (rho only scales every score alike). The return
term ``R[m, k] = sum_p G+(o_mk, x_p) V`` does not depend on the spot, so one pass over
(body element, receiver) pairs and one over (spot ray, body element) pairs give every score.

Shapes: aim points (T, 3) -> scores (T,).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import NlosError
from ..render.camera import pixel_rays
from ..render.rays import RayEngine
from ..render.spot import cone_directions, spot_profile
from ..scene.format import Camera
from .base import Illumination


@dataclass(frozen=True)
class AdaptiveConfig:
    """Discretization of the Adaptive Lighting score."""

    grid: int = 5
    """Floor grid points per side of the hidden region (cell centers)."""
    heights: tuple[float, ...] = (0.3, 0.9, 1.5)
    """Heights above the floor of the stand-in body elements, m (legs, torso, shoulders and head)."""
    normals: int = 8
    """Horizontal outward normals per body point (an octagonal prism)."""
    spot_rays: int = 8
    """Projector rays per candidate spot."""
    receivers: int = 32
    """Camera rays per side for the camera-visible LOS points."""
    albedo: float = 0.5
    """The uniform Lambertian albedo assumed everywhere (scales every score alike)."""
    chunk: int = 512
    """Spot rays per block of the pair computation (bounds memory)."""


@dataclass
class Points:
    """Surface or body points with unit normals (numpy, world frame)."""

    pos: np.ndarray
    """(N, 3) positions, m."""
    normal: np.ndarray
    """(N, 3) unit normals."""


def _face_normals(engine: RayEngine, face: np.ndarray) -> np.ndarray:
    tri = engine.vertices[engine.faces[face]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)


def _first_hits(engine: RayEngine, origin: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, Points]:
    """Hit mask (N,) and the hit points with normals turned toward ``origin``."""
    h = engine.first_hit(np.broadcast_to(origin, dirs.shape).copy(), dirs)
    pos = origin + dirs[h.hit] * h.t[h.hit, None]
    n = _face_normals(engine, h.face[h.hit])
    n = n * np.sign(np.einsum("ij,ij->i", n, origin - pos))[:, None]  # two-sided: the side facing the origin
    return h.hit, Points(pos, n)


def spot_points(engine: RayEngine, projector, aim_points: np.ndarray, k: int):
    """Where each candidate's K spot rays land: (points, owner (J,), flux (J,)) for the J hits."""
    pos, own, flux = [], [], []
    for t, aim in enumerate(np.atleast_2d(aim_points)):
        d, theta, domega = cone_directions(aim - projector.position, projector.cutoff_deg, k)
        w = spot_profile(theta, projector.beam_width_deg, projector.cutoff_deg) * domega
        pos.append(d)
        own.append(np.full(k, t))
        flux.append(w)
    dirs, owner, flux = np.concatenate(pos), np.concatenate(own), np.concatenate(flux)
    hit, pts = _first_hits(engine, np.asarray(projector.position, np.float64), dirs)
    return pts, owner[hit], flux[hit]


def body_points(region, cfg: AdaptiveConfig) -> tuple[np.ndarray, np.ndarray]:
    """Stand-in body: positions (M, 3) on the floor grid x heights, and K horizontal normals (K, 3)."""
    lo, hi = np.asarray(region.min, np.float64), np.asarray(region.max, np.float64)
    cells = (np.arange(cfg.grid) + 0.5) / cfg.grid
    gx, gy, gz = np.meshgrid(lo[0] + cells * (hi[0] - lo[0]), lo[1] + cells * (hi[1] - lo[1]),
                             region.floor_z + np.asarray(cfg.heights, np.float64), indexing="ij")
    phi = 2 * np.pi * np.arange(cfg.normals) / cfg.normals
    normals = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=1)
    return np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1), normals


def receiver_points(engine: RayEngine, camera: Camera, n: int) -> Points:
    """First hits of an n x n grid of camera rays (the camera's field of view and aspect)."""
    probe = Camera(camera.position, camera.look_at, camera.up, camera.fov_deg, n,
                   max(1, round(n * camera.height / camera.width)))
    dirs, origin = pixel_rays(probe, 1)
    hit, pts = _first_hits(engine, origin, dirs.reshape(-1, 3))
    if not hit.any():
        raise NlosError("adaptive lighting: the camera sees no geometry")
    return pts


def _pair_terms(engine: RayEngine, surf: Points, body: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(N, M, K): max(0, n_s.w) max(0, n_k.(-w)) / r^2 * V(s, o) for surface points s and body points o.

    w is the unit direction s -> o; a shadow ray is cast only for pairs the surface side lets
    light through (n_s.w > 0), since the others carry nothing anyway.
    """
    d = body[None, :, :] - surf.pos[:, None, :]  # (N, M, 3)
    r2 = (d * d).sum(-1)
    w = d / np.sqrt(r2)[..., None]
    cos_s = np.einsum("nmc,nc->nm", w, surf.normal)
    need = cos_s > 0
    vis = np.zeros_like(cos_s)
    if need.any():
        i, j = np.nonzero(need)
        vis[i, j] = ~engine.occluded(surf.pos[i], body[j], surf.normal[i], None)
    cos_k = np.maximum(np.einsum("nmc,kc->nmk", -w, normals), 0.0)  # outward body side facing s
    return (np.maximum(cos_s, 0.0) * vis / r2)[..., None] * cos_k


def adaptive_scores(scene, aim_points: np.ndarray, cfg: AdaptiveConfig | None = None,
                    engine: RayEngine | None = None) -> np.ndarray:
    """(T,) Adaptive Lighting score of each candidate spot (module docstring); 0 where nothing returns.

    Uses the scene's geometry, camera, projector and hidden region only (never its materials or
    a person). ``engine`` may pass a prebuilt ray engine over the static mesh.
    """
    cfg = cfg or AdaptiveConfig()
    if scene.hidden_region is None:
        raise NlosError("adaptive lighting: the scene has no hidden_region to light")
    if engine is None:
        mesh, _ = scene.static_mesh()
        engine = RayEngine(mesh.vertices, mesh.faces)
    aim_points = np.atleast_2d(np.asarray(aim_points, np.float64))
    body, normals = body_points(scene.hidden_region, cfg)
    area = 1.0 / (len(body) * len(normals))  # the stand-in body's total area is 1 (a constant factor)
    recv = receiver_points(engine, scene.camera, cfg.receivers)
    # R[m, k]: light leaving body element (m, k) that the camera sees on the LOS surfaces
    ret = _pair_terms(engine, recv, body, normals).sum(0) / len(recv.pos)  # (M, K)
    src, owner, flux = spot_points(engine, scene.projector, aim_points, cfg.spot_rays)
    per_ray = np.zeros(len(owner))
    for a in range(0, len(owner), cfg.chunk):
        sl = slice(a, a + cfg.chunk)
        g = _pair_terms(engine, Points(src.pos[sl], src.normal[sl]), body, normals)  # (J, M, K)
        per_ray[sl] = flux[sl] * np.einsum("jmk,mk->j", g, ret)
    scores = np.bincount(owner, weights=per_ray, minlength=len(aim_points))
    return (cfg.albedo / math.pi) ** 3 * area * scores


def adaptive_spot(scene, scene_dir: Path, rng: np.random.Generator) -> Illumination:
    """The landed candidate with the highest Adaptive Lighting score (``rng`` unused)."""
    from ..scene import load_scene

    from ..data.static import read_static

    aims = read_static(scene_dir, "aim_points")["aim_points"]
    scores = adaptive_scores(load_scene(scene_dir), aims)
    landed = scene.landed.cpu().numpy().astype(bool)
    return Illumination("spot", int(np.argmax(np.where(landed, scores, -np.inf))))
