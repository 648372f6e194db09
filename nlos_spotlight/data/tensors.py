"""A dataset split in memory as tensors: per scene the IEN graph and static images, per sample the transport.

Both sample kinds of a room (docs/dataset-format.md) stack into the same factors u (N, T, R),
v (N, R, H, W, 3): a full-transport sample is its stored factorization (rank r), an image sample
is u = the one-hot (T, K) map from stored candidate ``spots[k]`` to slot k and v = its K images,
so ``form_images`` gives its exact image for any y on the stored spots; R = max(r, K), the
shorter factors zero-padded (the einsum sums over R). ``stored`` and ``transport`` say which
spots and samples that is.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import torch

from ..errors import NlosError
from ..scene.format import TriMesh
from ..scene.graph import mesh_to_graph, normalize_positions


@dataclass
class SceneTensors:
    """One scene and its samples; T candidates, r transport rank, images (H, W, 3)."""

    x: torch.Tensor
    """(V, C) IEN vertex input: normalized camera-frame coordinates (+ normals)."""
    edge_index: torch.Tensor
    """(2, E) mesh edges, both directions."""
    faces: torch.Tensor
    """(T, 3) LOS mesh faces = spot candidates."""
    landed: torch.Tensor
    """(T,) bool, the candidate's spot reaches a surface."""
    direct: torch.Tensor
    """(T, H, W, 3) direct image per candidate."""
    ambient: torch.Tensor
    """(H, W, 3) ambient image."""
    u: torch.Tensor
    """(N, T, r) transport left factors of the N samples."""
    v: torch.Tensor
    """(N, r, H, W, 3) transport right factors."""
    nlos_ambient: torch.Tensor
    """(N, H, W, 3)."""
    target: torch.Tensor
    """(N, 2) floor position (m) relative to the hidden region's center, axes along the camera's view
    direction on the floor and to its left (the region frame: see :func:`region_frame`)."""
    posture: torch.Tensor
    """(N,) posture index."""
    trajectory: torch.Tensor
    """(N, 2) trajectory id and frame (-1 for static samples)."""
    camera_xy: torch.Tensor
    """(2,) camera floor position (m), world frame."""
    forward_xy: torch.Tensor
    """(2,) unit viewing direction on the floor, world frame."""
    origin_xy: torch.Tensor | None = None
    """(2,) world floor point of the target frame's origin (the hidden region's center)."""
    flash_direct: torch.Tensor | None = None
    """(H, W, 3) person-free image under the flash (datasets that store it), else None."""
    flash_nlos: torch.Tensor | None = None
    """(N, H, W, 3) the person's light under the flash, else None."""
    scene_dir: str = ""
    """Where the scene lives on disk ('' for scenes built in memory)."""
    stored: torch.Tensor | None = None
    """(T,) bool: the candidates whose light the image samples hold (its stored spots; all True for
    a room loaded without image samples); None (scenes built in memory): all."""
    transport: torch.Tensor | None = None
    """(N,) bool: the sample stores full transport (False: an image sample); None: all full."""
    face_prior: torch.Tensor | None = None
    """(T,) log Adaptive Lighting score of each candidate over the best (:func:`face_log_prior`), for
    an IEN with ``prior_weight``; None unless the IEN reads the 'adaptive' feature."""
    nuisance: torch.Tensor | None = None
    """(N, 3) cos and sin of the body's facing in the region frame and its height (m): what else
    changes the person's light (auxiliary targets); None where the dataset does not store them."""
    albedo: torch.Tensor | None = None
    """(N, 3) the body's albedo each sample was rendered with (the person's light is linear in it:
    ``train.imaging.form_images``' albedo augmentation); None for scenes built in memory."""
    shadow: torch.Tensor | None = None
    """(N, H, W, 3) the spot light each person's body blocks (``nlos_shadow``, negative) under the one
    spot ``shadow_spot`` (a room model's shadow step, ``fit/shadow.py``); None: left out."""
    shadow_spot: int = -1
    """The candidate ``shadow`` belongs to."""
    bounce: torch.Tensor | None = None
    """(N, H, W, 3) each person's light over one more static bounce (``nlos_bounce``) under
    ``shadow_spot``, at the albedo the person was rendered with; None: left out."""
    layers: object | None = None
    """The room's static light under its fixed spot at sub-pixel resolution
    (``render.variation.StaticLayers``): what the capture variation moves; None: ideal captures only."""

    def to(self, device) -> "SceneTensors":
        move = lambda v: v.to(device) if isinstance(v, torch.Tensor) or hasattr(v, "bin") else v
        return SceneTensors(**{k: move(getattr(self, k)) for k in self.__dataclass_fields__})

    @property
    def num_samples(self) -> int:
        return len(self.posture)

    def subset(self, idx: torch.Tensor) -> "SceneTensors":
        """The same room with only samples ``idx`` (room tensors shared, per-sample ones indexed)."""
        take = lambda k, v: v[idx] if k in PER_SAMPLE and v is not None else v
        return SceneTensors(**{k: take(k, getattr(self, k)) for k in self.__dataclass_fields__})

    def concat(self, other: "SceneTensors") -> "SceneTensors":
        """This room's samples followed by ``other``'s, people of the same room rendered apart (two
        datasets of one scan): the room tensors must agree; the stored spots are those both hold.

        An image sample's ``u`` maps every candidate to its own slot, so samples whose datasets
        store different spots (each chooses its own from its full-transport people, and may store
        more or fewer) stay exact: the fewer slots are padded with zeros, which add no light."""
        out = {}
        slots = max(self.u.shape[2], other.u.shape[2])
        pad = lambda x, dim: torch.cat([x, x.new_zeros(*x.shape[:dim], slots - x.shape[dim], *x.shape[dim + 1:])], dim)
        for k in self.__dataclass_fields__:
            a, b = getattr(self, k), getattr(other, k)
            if k in ("u", "v"):
                a, b = (pad(x, 2 if k == "u" else 1) for x in (a, b))
            if k in PER_SAMPLE:
                if (a is None) != (b is None) or (a is not None and a.shape[1:] != b.shape[1:]):
                    raise NlosError(f"concat: the two sets of people differ in {k!r} (other render settings)")
                out[k] = torch.cat([a, b]) if a is not None else None
            elif k == "stored":
                out[k] = a & b if a is not None and b is not None else (a if b is None else b)
            elif isinstance(a, torch.Tensor) or isinstance(b, torch.Tensor):
                if a is None or b is None or a.shape != b.shape or not torch.allclose(a, b, rtol=1e-5, atol=1e-7):
                    raise NlosError(f"concat: the two sets of people are not in the same room ({k!r} differs)")
                out[k] = a
            else:
                out[k] = a
        return SceneTensors(**out)


PER_SAMPLE = ("u", "v", "nlos_ambient", "target", "posture", "trajectory", "flash_nlos", "transport", "nuisance",
              "albedo", "shadow", "bounce")
"""SceneTensors fields indexed by sample (the rest describe the room)."""


def transport_samples(s: SceneTensors) -> SceneTensors:
    """Room ``s`` with only its full-transport samples (the images of every candidate spot: what
    the spot policy / IEN trains and is scored on); ``s`` itself when it has no image samples."""
    if s.transport is None or bool(s.transport.all()):
        return s
    return s.subset(torch.nonzero(s.transport).flatten())


def holdout_mask(s: SceneTensors, every: int) -> torch.Tensor:
    """(N,) bool: the static samples k with k % every == every - 1 and every walking-trajectory frame,
    held out of training (the seen-rooms test and its tracking).

    Postures are a random permutation per room (``data.scene_builder``), so the held-out samples
    are a posture-mixed sample of every training room; ``every`` 0 holds out nothing.
    """
    k = torch.arange(s.num_samples, device=s.posture.device)
    static = s.trajectory[:, 0] < 0
    if every <= 0:
        return ~static
    return (static & (k % every == every - 1)) | ~static


def room_samples(s: SceneTensors, every: int, held: bool) -> SceneTensors:
    """Room ``s`` with only the samples a run with ``holdout_every`` = ``every`` trains on, or with
    ``held`` only those it holds out (``every`` 0: all static samples are trained on)."""
    if every <= 0 and not held and bool((s.trajectory[:, 0] < 0).all()):
        return s
    mask = holdout_mask(s, every)
    return s.subset(torch.nonzero(mask if held else ~mask).flatten())


def ground_frame(pos_xy: np.ndarray, origin_xy: np.ndarray, fwd_xy: np.ndarray) -> np.ndarray:
    """World floor points (N, 2) -> (along the view, to the left of it) relative to ``origin_xy``.

    Targets use the region frame: origin at the hidden region's center, the frame a user who marks
    the area around the corner on a floor plan reads positions in. Relative to the camera, the
    region sits meters away in a different place in every room, which no network can infer from a
    handful of rooms; within the region, the position is what the light transport encodes.
    """
    left = np.array([-fwd_xy[1], fwd_xy[0]])
    rel = pos_xy - origin_xy
    return np.stack([rel @ fwd_xy, rel @ left], axis=1)


def world_floor(rel_xy: np.ndarray, origin_xy: np.ndarray, fwd_xy: np.ndarray) -> np.ndarray:
    """Region-frame floor points (N, 2) -> world floor points: the inverse of :func:`ground_frame`."""
    fwd = np.asarray(fwd_xy, float)
    left = np.array([-fwd[1], fwd[0]])
    rel = np.asarray(rel_xy, float).reshape(-1, 2)
    return np.asarray(origin_xy, float) + rel[:, :1] * fwd + rel[:, 1:] * left


def view_forward_xy(camera_to_world: np.ndarray) -> np.ndarray:
    """(2,) unit direction of the camera's view on the floor: the region frame's first axis."""
    pose = np.asarray(camera_to_world)
    return -pose[:2, 2] / np.linalg.norm(pose[:2, 2])


def region_frame(hidden_region, camera_to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(origin_xy, fwd_xy, floor_z) of a scene's ``HiddenRegion`` seen by the camera at
    ``camera_to_world``: the frame :func:`region_points` and the IEN's 'region' feature use."""
    origin = (np.asarray(hidden_region.min, float) + np.asarray(hidden_region.max, float))[:2] / 2
    return origin, view_forward_xy(camera_to_world), float(hidden_region.floor_z)


def region_center(scene_dir: Path) -> np.ndarray:
    """(2,) world floor center of a dataset scene's hidden region."""
    return _hidden_region(scene_dir)[0]


def region_floor(scene_dir: Path) -> float:
    """Floor height of a dataset scene's hidden region, m."""
    return _hidden_region(scene_dir)[1]


def _hidden_region(scene_dir: Path) -> tuple[np.ndarray, float]:
    try:
        hr = json.loads((scene_dir / "scene.json").read_text())["hidden_region"]
        return (np.asarray(hr["min"], float) + np.asarray(hr["max"], float)) / 2, float(hr.get("floor_z", 0.0))
    except (OSError, KeyError, TypeError, json.JSONDecodeError) as exc:
        raise NlosError(f"{scene_dir}/scene.json: no readable hidden_region ({type(exc).__name__})") from None


IEN_FEATURES = ("normals", "region", "adaptive")
"""Vertex features the IEN may read besides its normalized camera-frame coordinates."""
REGION_SCALE_M = 3.0
"""Region-frame coordinates reach the IEN in units of this length (meters kept: SNR falls with distance)."""


def region_points(points: np.ndarray, origin_xy: np.ndarray, fwd_xy: np.ndarray, floor_z: float) -> np.ndarray:
    """World points (N, 3) -> region frame (along the view, to its left, height above the hidden floor)."""
    return np.column_stack([ground_frame(points[:, :2], origin_xy, fwd_xy), points[:, 2] - floor_z])


PRIOR_DECADES = 4.0
"""Range of the face prior: scores this many decades below the best count as none."""


def prior_per_face(scores: np.ndarray) -> np.ndarray:
    """(F,) in [0, 1]: log10(score / best) over ``PRIOR_DECADES`` decades mapped to [0, 1] (0: none)."""
    scores = np.asarray(scores, np.float64)
    top = scores.max() if scores.size and scores.max() > 0 else 1.0
    with np.errstate(divide="ignore"):
        return np.clip((np.log10(np.maximum(scores, 0) / top) + PRIOR_DECADES) / PRIOR_DECADES, 0.0, 1.0)


def face_log_prior(scores: np.ndarray) -> torch.Tensor:
    """(F,) natural log of score / best, floored ``PRIOR_DECADES`` decades down (the IEN's ``face_prior``)."""
    return torch.as_tensor((prior_per_face(scores) - 1.0) * PRIOR_DECADES * np.log(10.0), dtype=torch.float32)


def prior_per_vertex(mesh: TriMesh, scores: np.ndarray) -> np.ndarray:
    """(V,) in [0, 1]: per face :func:`prior_per_face`, per vertex the best of its faces."""
    f = prior_per_face(scores)
    out = np.zeros(len(mesh.vertices))
    for k in range(3):
        np.maximum.at(out, mesh.faces[:, k], f)
    return out


def graph_inputs(mesh: TriMesh, camera_to_world: np.ndarray, features: list[str], region: tuple | None = None,
                 prior: np.ndarray | None = None):
    """IEN input of a LOS mesh: (V, 3 [+3] [+3] [+1]) normalized camera-frame coordinates [+ normals]
    [+ region-frame coordinates / ``REGION_SCALE_M``: where each vertex is relative to the hidden
    region, ``region`` = (origin_xy, fwd_xy, floor_z)] [+ 'adaptive': a physics prior, the Adaptive
    Lighting score of each face (``prior``, (F,)) as :func:`prior_per_vertex`], (2, E) edges."""
    unknown = set(features) - set(IEN_FEATURES)
    if unknown:
        raise NlosError(f"ien_features: unknown {sorted(unknown)} (known: {', '.join(IEN_FEATURES)})")
    graph = mesh_to_graph(mesh, frame=np.linalg.inv(camera_to_world))
    x = normalize_positions(torch.as_tensor(graph.pos, dtype=torch.float32))[0]
    if "normals" in features:
        x = torch.cat([x, torch.as_tensor(graph.normals, dtype=torch.float32)], dim=1)
    if "region" in features:
        if region is None:
            raise NlosError("this IEN reads where the hidden region is (ien_features 'region'): give the region")
        r = region_points(np.asarray(mesh.vertices, np.float64), *region) / REGION_SCALE_M
        x = torch.cat([x, torch.as_tensor(r, dtype=torch.float32)], dim=1)
    if "adaptive" in features:
        if prior is None or len(prior) != len(mesh.faces):
            raise NlosError("this IEN reads the Adaptive Lighting score of every face (ien_features 'adaptive'): "
                            "give the scores")
        x = torch.cat([x, torch.as_tensor(prior_per_vertex(mesh, prior), dtype=torch.float32)[:, None]], dim=1)
    return x, torch.as_tensor(np.asarray(graph.edge_index), dtype=torch.long)


@functools.lru_cache(maxsize=None)
def adaptive_prior(scene_dir: str) -> np.ndarray:
    """(T,) Adaptive Lighting scores of a stored room's candidates (computed once per process)."""
    from ..lighting.adaptive import adaptive_scores
    from ..scene.io import load_scene

    from .static import read_static

    return adaptive_scores(load_scene(scene_dir), read_static(scene_dir, "aim_points")["aim_points"])


SAMPLE_KINDS = ("all", "transport", "images")


def stored_spots(scene_dir: Path) -> list[int] | None:
    """The candidates a room's image samples hold, slot order (``spots.json``); None without one."""
    path = Path(scene_dir) / "spots.json"
    if not path.exists():
        return None
    try:
        spots = json.loads(path.read_text())["spots"]
        return [int(t) for t in spots]
    except (OSError, KeyError, TypeError, ValueError, json.JSONDecodeError):
        raise NlosError(f"{path}: corrupted (no readable 'spots' list)") from None


_LABELS = ("position", "posture", "trajectory", "frame")
_NUISANCES = ("facing_deg", "height_m")
"""Labels besides the targets (auxiliary targets: ``SceneTensors.nuisance``); older datasets may lack them."""


def _read_sample(path: Path, image: bool) -> dict:
    """The arrays the loader needs from one sample file, read whole and closed (a room may hold
    thousands: open NpzFiles would exhaust file handles); float16 images decoded to float32."""
    from .store import f16_decode

    with np.load(path) as z:
        out = {k: z[k] for k in _LABELS}
        out.update({k: z[k] for k in _NUISANCES + ("albedo",) if k in z.files})
        for k in ("nlos_ambient", "flash_nlos") + (("nlos_spots",) if image else ()):
            if k in z.files:
                out[k] = f16_decode(z, k)
        if not image:
            out["transport_u"], out["transport_v"] = z["transport_u"], z["transport_v"]
    return out


def _factors(full: list[dict], images: list[dict], spots: list[int], t: int) -> tuple[np.ndarray, np.ndarray]:
    """u (N, T, R), v (N, R, H, W, 3) float32 of full-transport samples then image samples."""
    r = max([z["transport_u"].shape[1] for z in full] + ([len(spots)] if images else []), default=0)
    shape = (full[0]["transport_v"] if full else images[0]["nlos_spots"]).shape[1:] if full or images else (0, 0, 3)
    u = np.zeros((len(full) + len(images), t, r), np.float32)
    v = np.zeros((len(full) + len(images), r, *shape), np.float32)
    for i, z in enumerate(full):
        zu = z["transport_u"]
        u[i, :, :zu.shape[1]] = zu
        v[i, :zu.shape[1]] = z["transport_v"]
    for i, z in enumerate(images, start=len(full)):
        u[i, spots, np.arange(len(spots))] = 1.0
        v[i, :len(spots)] = z["nlos_spots"]
    return u, v


def _sample_files(folder: Path) -> list[Path]:
    """The sample files of a folder in index order (a writer's dot-named temporaries left out)."""
    return [f for f in sorted(folder.glob("*.npz")) if not f.name.startswith(".")]


def load_scene_tensors(scene_dir: Path, features: list[str], samples: str = "all") -> SceneTensors:
    """One stored room; ``samples``: 'all' (full-transport samples, then image samples, in sample
    order), 'transport' (only full-transport ones) or 'images' (only image samples, rank K).

    'all' pads image samples to the full-transport rank r: with many people per room, 'images'
    holds the same images in K / r of the memory."""
    if samples not in SAMPLE_KINDS:
        raise NlosError(f"samples: expected one of {', '.join(SAMPLE_KINDS)}, got {samples!r}")
    scene_dir = Path(scene_dir)
    from .static import read_static

    st = read_static(scene_dir, "los_vertices", "los_faces", "spot_landed", "direct", "ambient", "camera_to_world",
                     optional=("flash_direct",))
    try:
        full = [_read_sample(f, False) for f in _sample_files(scene_dir / "samples")] \
            if samples != "images" else []
        images = [_read_sample(f, True) for f in _sample_files(scene_dir / "images")] \
            if samples != "transport" else []
    except Exception as exc:  # np.load raises several types on torn files
        raise NlosError(f"{scene_dir}: corrupted dataset file ({type(exc).__name__})") from None
    num_t = len(st["los_faces"])
    stored = np.ones(num_t, bool)
    spots = stored_spots(scene_dir) if images else []
    if images:
        if spots is None:
            raise NlosError(f"{scene_dir}: image samples without spots.json (regenerate the scene)")
        if any(not 0 <= t < num_t for t in spots) or any(z["nlos_spots"].shape[0] != len(spots) for z in images):
            raise NlosError(f"{scene_dir}: image samples do not match spots.json (regenerate the scene)")
        stored[:] = False
        stored[spots] = True
    u, v = _factors(full, images, spots, num_t)
    zs = full + images
    pose = st["camera_to_world"]
    fwd = view_forward_xy(pose)
    cam = pose[:2, 3]
    origin = region_center(scene_dir)
    prior = adaptive_prior(str(scene_dir)) if "adaptive" in features else None
    x, edges = graph_inputs(TriMesh(st["los_vertices"], st["los_faces"]), pose, features,
                            (origin, fwd, region_floor(scene_dir)), prior)
    f32 = lambda a: torch.as_tensor(np.asarray(a), dtype=torch.float32)
    has_flash = bool(zs) and all("flash_nlos" in z for z in zs)
    return SceneTensors(
        x=x, edge_index=edges,
        faces=torch.as_tensor(st["los_faces"], dtype=torch.long), landed=torch.as_tensor(st["spot_landed"]),
        direct=f32(st["direct"]), ambient=f32(st["ambient"]),
        u=torch.from_numpy(u), v=torch.from_numpy(v),
        nlos_ambient=f32(np.stack([z["nlos_ambient"] for z in zs])),
        target=f32(ground_frame(np.stack([z["position"] for z in zs]), origin, fwd)),
        posture=torch.as_tensor([int(z["posture"]) for z in zs]),
        trajectory=torch.as_tensor([[int(z["trajectory"]), int(z["frame"])] for z in zs]),
        camera_xy=f32(cam), forward_xy=f32(fwd), origin_xy=f32(origin),
        flash_direct=f32(st["flash_direct"]) if "flash_direct" in st else None,
        flash_nlos=f32(np.stack([z["flash_nlos"] for z in zs])) if has_flash else None,
        scene_dir=str(scene_dir), stored=torch.from_numpy(stored),
        transport=torch.as_tensor([True] * len(full) + [False] * len(images), dtype=torch.bool),
        nuisance=nuisances(zs, fwd),
        albedo=f32(np.stack([z["albedo"] for z in zs])) if zs and all("albedo" in z for z in zs) else None,
        face_prior=face_log_prior(prior) if prior is not None else None)


def nuisances(zs: list[dict], fwd_xy: np.ndarray) -> torch.Tensor | None:
    """(N, 3) cos, sin of the facing relative to the region frame's forward axis, and height (m)."""
    if not zs or not all(k in z for z in zs for k in _NUISANCES):
        return None
    a = np.radians([float(z["facing_deg"]) for z in zs]) - np.arctan2(fwd_xy[1], fwd_xy[0])
    h = np.array([float(z["height_m"]) for z in zs])
    return torch.as_tensor(np.stack([np.cos(a), np.sin(a), h], 1), dtype=torch.float32)


def split_ids(data_dir: str | Path, split: str) -> list[str]:
    """Scene ids of a finished dataset's split (NlosError when unfinished, corrupted or empty)."""
    from .store import read_manifest

    data_dir = Path(data_dir)
    ids = [s["id"] for s in read_manifest(data_dir)["splits"].get(split, [])]
    if not ids:
        raise NlosError(f"{data_dir}: split '{split}' is empty")
    return ids


def finished_scene_dirs(data_dir: str | Path, split: str) -> list[Path]:
    """A split's scene directories in index order: those of the manifest when the dataset is
    finished, else the rooms finished so far (``done.json``), so experiments can start on a
    dataset still being generated; an empty split gives []."""
    data_dir = Path(data_dir)
    if (data_dir / "manifest.json").exists():
        from .store import read_manifest

        return [data_dir / "scenes" / s["id"] for s in read_manifest(data_dir)["splits"].get(split, [])]
    return sorted(p for p in (data_dir / "scenes").glob(f"{split}-*") if (p / "done.json").exists())


def load_split(data_dir: str | Path, split: str, features: list[str],
               keep: Callable[[SceneTensors], SceneTensors] | None = None, samples: str = "all") -> list[SceneTensors]:
    """Every scene of a split; ``keep`` (e.g. a sample subset) is applied as each loads, to bound memory;
    ``samples``: which sample kinds (:func:`load_scene_tensors`)."""
    keep = keep or (lambda s: s)
    return [keep(load_scene_tensors(Path(data_dir) / "scenes" / sid, features, samples))
            for sid in split_ids(data_dir, split)]
