"""Build one dataset scene: the room, its LOS mesh and candidates, per-scene images, and its samples.

Besides the spot candidates, every scene is also rendered under the flash of Tancik et al. 2018
(:mod:`.flash`): a second :class:`Renderer` on a copy of the scene whose projector is a wide beam
at the camera, aimed at its ``look_at``, with the projector's total flux. Its one "candidate"
gives ``flash_direct`` (static.npz) and, per sample, ``flash_nlos``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import torch

from ..render.camera import camera_frame, pixel_rays
from ..render.person import Person
from ..render.surface import StaticSurfaces
from ..render.transport import Renderer, RenderSettings
from ..scene.format import TriMesh
from ..scene.io import save_scene
from .config import DatasetConfig
from .flash import FLASH_SPOT_SAMPLES, flash_scene
from .store import atomic_json, atomic_npz, file_digest
from .trajectories import walking_trajectory


def los_mesh(surfaces: StaticSurfaces, camera, target_vertices: int) -> TriMesh:
    """The camera-visible static faces (what a scan from the camera side holds), cleaned and decimated."""
    from ..scene.clean import clean_mesh
    from ..scene.decimate import decimate

    dirs, origin = pixel_rays(camera, 2)
    flat = dirs.reshape(-1, 3)
    hit, surf = surfaces.trace(np.broadcast_to(origin, flat.shape), flat)
    faces = np.unique(surf.face)
    m = surfaces.mesh
    sub = clean_mesh(TriMesh(m.vertices, m.faces[faces]))
    return decimate(sub, target_vertices) if len(sub.vertices) > target_vertices else sub


def low_rank(f: torch.Tensor, rank: int) -> tuple[np.ndarray, np.ndarray, float]:
    """F (T, H, W, 3) -> U (T, r), V (r, H, W, 3) and the relative Frobenius error of U V."""
    t = f.shape[0]
    mat = f.reshape(t, -1).double()
    if rank <= 0 or rank >= min(mat.shape):
        return np.eye(t, dtype=np.float32), f.float().numpy(), 0.0
    u, s, vh = torch.linalg.svd(mat, full_matrices=False)
    u, v = u[:, :rank] * s[:rank], vh[:rank]
    err = float((mat - u @ v).norm() / mat.norm().clamp(min=1e-300))
    return u.float().numpy(), v.reshape(rank, *f.shape[1:]).float().numpy(), err


class SceneBuilder:
    """Deterministic construction of one scene directory; resumes at the first missing sample."""

    def __init__(self, cfg: DatasetConfig, plan, out: Path):
        self.cfg, self.plan = cfg, plan
        self.dir = out / "scenes" / plan.id

    def build(self, advance) -> None:
        from .generate import sample_count

        n = sample_count(self.cfg, self.plan.split)
        if (self.dir / "done.json").exists():
            advance(n)
            return
        from ..world.rooms import generate_room

        room = generate_room(self.plan.seed, self._room_config())
        scene = room.scene
        self.dir.mkdir(parents=True, exist_ok=True)
        save_scene(scene, self.dir)
        surfaces = StaticSurfaces(scene)
        los = los_mesh(surfaces, scene.camera, self.cfg.los_vertices)
        settings = RenderSettings(pixel_samples=self.cfg.pixel_samples,
                                  transport_pixel_samples=self.cfg.transport_pixel_samples,
                                  spot_samples=self.cfg.spot_samples, person_samples=self.cfg.person_samples,
                                  device="cpu")
        renderer = Renderer(scene, settings, aim_points=los.centroids())
        flash = Renderer(flash_scene(scene), dataclasses.replace(settings, spot_samples=settings.spot_samples
                                                                 * FLASH_SPOT_SAMPLES),
                         aim_points=scene.camera.look_at[None])
        if not _readable(self.dir / "static.npz", "flash_direct"):
            self._write_static(renderer, flash, los, room.family)
        (self.dir / "samples").mkdir(exist_ok=True)
        for k, spec in enumerate(self._specs(scene)):
            path = self.dir / "samples" / f"{k:05d}.npz"
            if not _readable(path, "flash_nlos"):
                atomic_npz(path, **self._sample(renderer, flash, spec, scene.hidden_region.floor_z))
            advance()
        digests = {str(p.relative_to(self.dir)): file_digest(p)
                   for p in sorted(self.dir.rglob("*")) if p.is_file() and p.name != "done.json"}
        atomic_json(self.dir / "done.json", {"samples": n, "digests": digests})

    def _room_config(self):
        from ..world.rooms import RoomConfig

        return RoomConfig(resolution=self.cfg.resolution, families=[self.plan.family])

    def _write_static(self, r: Renderer, flash: Renderer, los: TriMesh, family: str) -> None:
        h, w = r.shape
        fwd, right, up = camera_frame(r.scene.camera)
        pose = np.eye(4)
        pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, up, -fwd, r.scene.camera.position
        atomic_npz(self.dir / "static.npz", los_vertices=los.vertices, los_faces=los.faces,
                   aim_points=r.aim_points, spot_landed=r.spot_landed,
                   direct=r.D.reshape(h, w, r.num_spots, 3).permute(2, 0, 1, 3).float().numpy(),
                   ambient=r.ambient_image.float().numpy(), camera_to_world=pose, family=np.array(family),
                   flash_direct=flash.D[:, 0].reshape(h, w, 3).float().numpy())

    def _specs(self, scene) -> list[dict]:
        """Every sample's person: posture, position, facing, body parameters (deterministic)."""
        from ..world.body import POSTURES, sample_body_params
        from ..world.rooms import person_positions

        rng = np.random.default_rng([self.cfg.seed, self.plan.index, 1])
        m = self.cfg.samples_per_scene
        postures = rng.permutation(np.arange(m) % len(POSTURES))
        pos = person_positions(scene, rng, m)
        specs = [{"params": sample_body_params(rng, POSTURES[p]), "position": pos[k], "trajectory": -1, "frame": -1}
                 for k, p in enumerate(postures)]
        if self.plan.split == "test" and self.cfg.trajectories_per_test_scene > 0:
            valid = person_positions(scene, rng, 2000)
            for j in range(self.cfg.trajectories_per_test_scene):
                hr = scene.hidden_region
                path = walking_trajectory(rng, valid, self.cfg.trajectory_frames, self.cfg.frame_rate_hz,
                                          bounds=(np.asarray(hr.min), np.asarray(hr.max)))
                base = sample_body_params(rng, POSTURES[rng.integers(5)])  # a named posture per walk
                for f, (x, y, heading) in enumerate(path):
                    params = _with(base, facing_deg=float(heading), pose_seed=int(base.pose_seed + f))
                    specs.append({"params": params, "position": np.array([x, y]), "trajectory": j, "frame": f})
        return specs

    def _sample(self, r: Renderer, flash: Renderer, spec: dict, floor_z: float) -> dict:
        from ..world.body import POSTURES, posed_body

        p = spec["params"]
        body = posed_body(p, target_faces=self.cfg.body_faces)
        person = Person.from_mesh(body, p.albedo, self.cfg.person_samples)
        t = np.array([spec["position"][0], spec["position"][1], floor_z])
        f = r.transport_images(person, t)
        u, v, err = low_rank(f, self.cfg.transport_rank)
        # nlos_ambient does not depend on the emitter, and the flash renderer has the same camera
        # receivers: one render gives both it and the flash's nlos through a single person -> pixel
        # gather (the costly visibility pass) instead of two.
        under_flash = flash.render(flash.spot_vector(0), person, translation=t, components=("nlos", "nlos_ambient"))
        amb, flash_nlos = under_flash["nlos_ambient"], under_flash["nlos"]
        return {"transport_u": u, "transport_v": v, "transport_error": np.float64(err),
                "nlos_ambient": amb.float().numpy(), "flash_nlos": flash_nlos.float().numpy(),
                "position": np.asarray(spec["position"], np.float64),
                "posture": np.int64(POSTURES.index(p.posture)), "facing_deg": np.float64(p.facing_deg),
                "height_m": np.float64(p.height_m), "albedo": np.asarray(p.albedo, np.float64),
                "trajectory": np.int64(spec["trajectory"]), "frame": np.int64(spec["frame"]),
                "body_vertices": (body.vertices + t).astype(np.float32), "body_faces": body.faces.astype(np.int32)}


def _with(params, **changes):
    import dataclasses

    return dataclasses.replace(params, **changes)


def _readable(path: Path, key: str) -> bool:
    """``path`` loads and holds array ``key``; otherwise it is deleted, to be rebuilt.

    ``key`` is the newest array of the file, so a partial scene written by an older version
    (before the flash arrays) is rebuilt whole instead of mixing versions within a scene.
    """
    if not path.exists():
        return False
    try:
        with np.load(path) as z:
            z[key]
        return True
    except Exception:  # a torn or corrupt file is rebuilt, not trusted
        path.unlink(missing_ok=True)
        return False
