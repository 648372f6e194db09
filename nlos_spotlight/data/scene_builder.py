"""Build one dataset scene: the room, its LOS mesh and candidates, per-scene images, and its samples.

Besides the spot candidates, every scene is also rendered under the flash of Tancik et al. 2018
(:mod:`.flash`): a second :class:`Renderer` on a copy of the scene whose projector is a wide beam
at the camera, aimed at its ``look_at``, with the projector's total flux. Its one "candidate"
gives ``flash_direct`` (static.npz) and, per sample, ``flash_nlos``.

Two sample kinds (docs/dataset-format.md). The first ``transport_samples_per_scene`` people of a
room (all by default) store the full light transport (every candidate spot): the spot policies
learn and are scored on those. Then the room's stored spots are chosen from them (``spots.json``:
the best candidates by NLOS SNR and the fixed policies' spots), and every further person is an
*image sample* (``images/<k>.npz``): only its light under those K spots (demo preset: about 10x
smaller on disk and 4-7x faster to render), for training the NLOS network on many people.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import torch

from ..errors import NlosError
from ..render.camera import camera_frame
from ..render.person import Person
from ..render.surface import StaticSurfaces
from ..render.transport import Renderer, RenderSettings
from ..scene.format import TriMesh
from ..scene.los import los_mesh
from ..scene.io import save_scene
from .config import DatasetConfig
from .flash import FLASH_SPOT_SAMPLES, flash_scene
from .static import read_static, static_path
from .store import atomic_json, atomic_npz, f16_encode, file_digest
from .trajectories import walking_trajectory


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

    def __init__(self, cfg: DatasetConfig, plan, out: Path, fuse: bool = False, device: str = "cpu"):
        self.cfg, self.plan, self.out, self.fuse, self.device = cfg, plan, Path(out), fuse, device
        self.dir = self.out / "scenes" / plan.id

    def build(self, advance, part: tuple[int, int] = (0, 1)) -> None:
        """Build (or resume) the scene. ``part`` = (i, n): of the image samples, render only those
        whose index is i mod n, so n processes can share one room (``nlos fit``); every part first
        makes sure the room, its full-transport samples and ``spots.json`` exist (run part 0 alone
        first so the others find them), and whichever part finds every file there writes ``done.json``."""
        from .config import footprint_draw, sample_count, transport_count

        n = sample_count(self.cfg, self.plan.split)
        m = transport_count(self.cfg, self.plan.split)
        if (self.dir / "done.json").exists():
            if self._intact():
                advance(n)
                return
        scene, family = self._room()
        self.dir.mkdir(parents=True, exist_ok=True)
        if not (self.dir / "scene.json").exists():  # written last: its meshes are complete (parts share them)
            save_scene(scene, self.dir)
        surfaces = StaticSurfaces(scene)
        los = los_mesh(surfaces.mesh, surfaces.engine, scene.camera, self.cfg.los_vertices)
        settings = self.cfg.render_settings(fuse=self.fuse, device=self.device)
        renderer = Renderer(scene, settings, aim_points=los.centroids())
        flash = Renderer(flash_scene(scene), dataclasses.replace(settings, spot_samples=settings.spot_samples
                                                                 * FLASH_SPOT_SAMPLES),
                         aim_points=scene.camera.look_at[None])
        if not _readable(static_path(self.dir), "flash_direct"):
            self._write_static(renderer, flash, los, family)
        (self.dir / "samples").mkdir(exist_ok=True)
        specs = self._specs(scene)
        floor_z = scene.hidden_region.floor_z
        for k, spec in enumerate(specs[:m]):
            path = self.dir / "samples" / f"{k:05d}.npz"
            if not _readable(path, "flash_nlos"):
                atomic_npz(path, **self._sample(renderer, flash, spec, floor_z, footprint_draw(self.cfg, k)))
            advance()
        if m < n:
            spots = self._stored_spots(len(los.faces))
            (self.dir / "images").mkdir(exist_ok=True)
            i, parts = part
            for k, spec in enumerate(specs[m:], start=m):
                path = self.dir / "images" / f"{k:05d}.npz"
                if k % parts == i and not _readable(path, "nlos_spots"):
                    atomic_npz(path, **self._image_sample(renderer, flash, spec, floor_z, spots,
                                                          footprint_draw(self.cfg, k)))
                advance()
            if any(not (self.dir / "images" / f"{k:05d}.npz").exists() for k in range(m, n)):
                return  # another part is still rendering; the last one to finish writes done.json
        expected = {f"samples/{k:05d}.npz" for k in range(m)} | {f"images/{k:05d}.npz" for k in range(m, n)}
        for p in [*self.dir.glob("samples/*.npz"), *self.dir.glob("images/*.npz")]:
            if str(p.relative_to(self.dir)) not in expected:  # a stray file is not part of the scene
                p.unlink()
        digests = {str(p.relative_to(self.dir)): file_digest(p)
                   for p in sorted(self.dir.rglob("*")) if p.is_file() and p.name != "done.json"}
        atomic_json(self.dir / "done.json", {"samples": n, "transport_samples": m, "digests": digests})

    def _intact(self) -> bool:
        """A finished scene's files match their digests; otherwise the bad ones and ``done.json``
        are deleted (the build then renders them again) and a line says which."""
        from ..console import console
        from .verify import STRAY, digest_problems

        bad = digest_problems(self.dir)
        for path, why in bad:
            console.print(f"{path}: {why}; {'removed' if why == STRAY else 'rendering it again'}")
            path.unlink(missing_ok=True)
            if (path.suffix in (".ply", ".obj") or path.name == "scene.json") and path.parent == self.dir:
                (self.dir / "scene.json").unlink(missing_ok=True)  # the room's files are written again
        if bad:
            (self.dir / "done.json").unlink(missing_ok=True)
        return not bad

    def room_scene(self):
        """The room's scene without a person (what ``world`` in :meth:`rerender` departs from)."""
        return self._room()[0]

    def _room(self):
        """The scene without a person and its family: the config's given room, else a procedural one."""
        if self.cfg.room:
            from ..scene.io import load_scene
            from .config import ROOM_FAMILY, room_dir

            scene = load_scene(room_dir(self.out, self.cfg.room))
            if scene.hidden_region is None:
                raise NlosError(f"{self.cfg.room}: the room has no hidden_region (where people are placed)")
            scene.human = None
            return scene, ROOM_FAMILY
        from ..world.rooms import generate_room

        room = generate_room(self.plan.seed, self._room_config())
        return room.scene, room.family

    def _room_config(self):
        from ..world.rooms import RoomConfig

        return RoomConfig(resolution=self.cfg.resolution, families=[self.plan.family])

    def _write_static(self, r: Renderer, flash: Renderer, los: TriMesh, family: str) -> None:
        h, w = r.shape
        fwd, right, up = camera_frame(r.scene.camera)
        pose = np.eye(4)
        pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, up, -fwd, r.scene.camera.position
        atomic_npz(static_path(self.dir), los_vertices=los.vertices, los_faces=los.faces,
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
        on_scan = bool(self.cfg.room)  # a scan's walls have holes: people stand on its floor
        pos = person_positions(scene, rng, m, floor=on_scan)
        specs = [{"params": sample_body_params(rng, POSTURES[p]), "position": pos[k], "trajectory": -1, "frame": -1}
                 for k, p in enumerate(postures)]
        from .config import trajectory_count

        walks = trajectory_count(self.cfg, self.plan.split)
        if walks > 0:
            valid = person_positions(scene, rng, 2000, floor=on_scan)
            for j in range(walks):
                hr = scene.hidden_region
                path = walking_trajectory(rng, valid, self.cfg.trajectory_frames, self.cfg.frame_rate_hz,
                                          bounds=(np.asarray(hr.min), np.asarray(hr.max)))
                base = sample_body_params(rng, POSTURES[rng.integers(5)])  # a named posture per walk
                for f, (x, y, heading) in enumerate(path):
                    params = _with(base, facing_deg=float(heading), pose_seed=int(base.pose_seed + f))
                    specs.append({"params": params, "position": np.array([x, y]), "trajectory": j, "frame": f})
        return specs

    def _stored_spots(self, num_candidates: int) -> list[int]:
        """The room's stored spots from ``spots.json``, chosen (and written) once the full-transport
        samples exist; image samples left from a run without a readable record are deleted."""
        path = self.dir / "spots.json"
        rec = read_spots(path, num_candidates)
        if rec is None:
            for old in (self.dir / "images").glob("*.npz"):
                old.unlink()
            rec = choose_spots(self.cfg, self.plan, self.dir)
            atomic_json(path, rec)
        return rec["spots"]

    def rerender(self, indices: list[int], settings: RenderSettings, aim: np.ndarray,
                 components: tuple[str, ...] = ("nlos", "nlos_ambient"),
                 relay_offsets: list[float] | None = None, world=None,
                 one_footprint: bool = False) -> dict[str, np.ndarray]:
        """Samples ``indices`` of this room rendered again, lit by one spot aimed at ``aim`` (3,), with
        other ``settings`` or components (convergence and robustness studies): component name ->
        (len(indices), H, W, 3) float64. The people are the dataset's (the same seeded draws);
        ``relay_offsets``: each one's ``nlos_shadow`` relay offset (``settings.relay_offset`` if None);
        with ``settings.footprint_jitter`` each is rendered with its own footprint draw, its sampling
        set (``config.sampling_set``: the draw the dataset renders it with, under that seed), or with
        ``one_footprint`` all with the seed's one draw (test photographs: one static visibility for
        the shadow's relay points instead of one per set);
        ``world``: a scene to render them in instead of the room (``world.mismatch``: the room as it
        differs from its scan), the same people at the same places."""
        room, specs = self._scan_people()
        scene = room if world is None else world
        r = Renderer(scene, settings, aim_points=np.asarray(aim, np.float64)[None])
        y = r.spot_vector(0)
        out = {c: [] for c in components}
        offsets = [None] * len(indices) if relay_offsets is None else list(relay_offsets)
        if len(offsets) != len(indices):
            raise ValueError(f"relay_offsets: {len(offsets)} for {len(indices)} samples")
        from .config import sampling_set

        for k, off in zip(indices, offsets):
            _, person, t = self._person(specs[k], scene.hidden_region.floor_z)
            draw = sampling_set(k) if settings.footprint_jitter and not one_footprint else None
            res = r.render(y, person, torch.as_tensor(t), components, relay_offset=off, footprint_draw=draw)
            for c in components:
                out[c].append(res[c].double().cpu().numpy())
        return {c: np.stack(v) for c, v in out.items()}

    def _scan_people(self):
        """The room's scene and every sample's person drawn in it (kept: a fit's shadow step asks once
        per world). People are drawn in the scan: a world's own draw would place others."""
        if getattr(self, "_people_cache", None) is None:
            room = self._room()[0]
            self._people_cache = (room, self._specs(room))
        return self._people_cache

    def _person(self, spec: dict, floor_z: float):
        from ..world.body import posed_body

        p = spec["params"]
        body = posed_body(p, target_faces=self.cfg.body_faces)
        person = Person.sampled(body, p.albedo, self.cfg.render)
        return body, person, np.array([spec["position"][0], spec["position"][1], floor_z])

    @staticmethod
    def _labels(spec: dict) -> dict:
        from ..world.body import POSTURES

        p = spec["params"]
        return {"position": np.asarray(spec["position"], np.float64),
                "posture": np.int64(POSTURES.index(p.posture)), "facing_deg": np.float64(p.facing_deg),
                "height_m": np.float64(p.height_m), "albedo": np.asarray(p.albedo, np.float64),
                "trajectory": np.int64(spec["trajectory"]), "frame": np.int64(spec["frame"])}

    def _sample(self, r: Renderer, flash: Renderer, spec: dict, floor_z: float, draw: int | None = None) -> dict:
        body, person, t = self._person(spec, floor_z)
        # every candidate, the flash and nlos_ambient through one person -> pixel pass
        f = r.transport_images(person, t, also=(flash,), nlos_ambient=True, footprint_draw=draw)
        u, v, err = low_rank(f[:r.num_spots], self.cfg.transport_rank)
        flash_nlos, amb = f[r.num_spots], f[r.num_spots + 1]
        return {"transport_u": u, "transport_v": v, "transport_error": np.float64(err),
                "nlos_ambient": amb.float().numpy(), "flash_nlos": flash_nlos.float().numpy(),
                **self._labels(spec),
                "body_vertices": (body.vertices + t).astype(np.float32), "body_faces": body.faces.astype(np.int32)}

    def _image_sample(self, r: Renderer, flash: Renderer, spec: dict, floor_z: float, spots: list[int],
                      draw: int | None = None) -> dict:
        """The person's light under the K stored spots only (their columns of F, traced alone),
        float16 with power-of-two scales (``store.f16_encode``); no body mesh. ``draw``: its
        footprint draw (``config.footprint_draw``)."""
        _, person, t = self._person(spec, floor_z)
        # the K spots, the flash and nlos_ambient through one person -> pixel pass
        f = r.transport_images(person, t, spots, also=(flash,), nlos_ambient=True,
                               footprint_draw=draw).double().numpy()
        k = len(spots)
        out = {}
        for name, a, per_spot in (("nlos_spots", f[:k], True), ("flash_nlos", f[k], False),
                                  ("nlos_ambient", f[k + 1], False)):
            out[name], out[f"{name}_scale"] = f16_encode(a, per_spot)
        return {**out, **self._labels(spec)}


RANDOM_POLICY_SEEDS = (0, 1, 2)
"""Training seeds whose Random-policy spot a room stores for its image samples (``nlos evaluate
--seeds 3`` trains seeds 0-2): the draw of ``train.loop.fixed_illuminations``, key [seed, i]."""

STORED_POLICIES = ("adaptive", "center", "random")
"""Fixed policies whose spots a room stores for its image samples, besides the top SNR ones."""


def split_position(cfg: DatasetConfig, index: int) -> int:
    """The scene's position in its split's list (what ``load_split`` returns, the trainer's i)."""
    split = cfg.split_of(index)
    return index - {"train": 0, "val": cfg.train_scenes, "test": cfg.train_scenes + cfg.val_scenes}[split]


def choose_spots(cfg: DatasetConfig, plan, scene_dir: Path) -> dict:
    """The stored spots of a room whose full-transport samples exist (``spots.json``'s record).

    The ``stored_spots_top`` landed candidates of highest mean NLOS SNR over the full-transport
    samples (``lighting.snr.candidate_snr``), and the spots of the fixed policies
    :data:`STORED_POLICIES` as the trainer draws them (Random: one per :data:`RANDOM_POLICY_SEEDS`).
    ``spots`` is their sorted union: slot k of an image sample holds candidate ``spots[k]``.
    """
    from ..lighting import POLICIES, policy_rng
    from ..lighting.oracle import by_snr
    from ..lighting.snr import candidate_snr
    from .tensors import load_scene_tensors

    scene_dir = Path(scene_dir)
    snr = np.asarray(candidate_snr(scene_dir), np.float64)
    landed = np.asarray(read_static(scene_dir, "spot_landed")["spot_landed"], bool)
    top = by_snr(snr, landed)[:cfg.stored_spots_top]
    s = load_scene_tensors(scene_dir, [], samples="transport")
    i = split_position(cfg, plan.index)
    policies: dict = {}
    for name in STORED_POLICIES:
        seeds = RANDOM_POLICY_SEEDS if name == "random" else (0,)
        picks = []
        for seed in seeds:
            try:
                ill = POLICIES[name](s, scene_dir, policy_rng(seed, i))
            except NlosError:  # e.g. no landed candidate in front of the camera: nothing to store
                ill = None
            picks.append(int(ill.face) if ill is not None and ill.mode == "spot" else None)
        policies[name] = {str(k): p for k, p in zip(seeds, picks)} if name == "random" else picks[0]
    chosen = set(top) | {p for v in policies.values() for p in (v.values() if isinstance(v, dict) else [v])
                         if p is not None}
    chosen |= {int(t) for t in cfg.extra_spots if 0 <= int(t) < len(landed) and landed[int(t)]}
    if not chosen:
        raise NlosError(f"{scene_dir}: no spot to store for image samples (no candidate lands)")
    return {"spots": sorted(chosen), "snr_top": top, "snr_top_values": [float(snr[t]) for t in top],
            "policies": policies, "num_candidates": int(len(landed)),
            "random_key": "numpy default_rng([training seed, position of the room in its split])"}


def read_spots(path: Path, num_candidates: int) -> dict | None:
    """``spots.json`` if it exists and is well formed, else None."""
    import json

    try:
        rec = json.loads(Path(path).read_text())
        spots = rec["spots"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    ok = isinstance(spots, list) and spots and all(isinstance(t, int) and 0 <= t < num_candidates for t in spots) \
        and spots == sorted(set(spots))
    return rec if ok else None


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
