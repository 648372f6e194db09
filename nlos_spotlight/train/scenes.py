"""A dataset split in memory as tensors: per scene the IEN graph and static images, per sample the transport."""

from __future__ import annotations

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

    def to(self, device) -> "SceneTensors":
        move = lambda v: v.to(device) if isinstance(v, torch.Tensor) else v
        return SceneTensors(**{k: move(getattr(self, k)) for k in self.__dataclass_fields__})

    @property
    def num_samples(self) -> int:
        return len(self.posture)

    def subset(self, idx: torch.Tensor) -> "SceneTensors":
        """The same room with only samples ``idx`` (room tensors shared, per-sample ones indexed)."""
        take = lambda k, v: v[idx] if k in PER_SAMPLE and v is not None else v
        return SceneTensors(**{k: take(k, getattr(self, k)) for k in self.__dataclass_fields__})


PER_SAMPLE = ("u", "v", "nlos_ambient", "target", "posture", "trajectory", "flash_nlos")
"""SceneTensors fields indexed by sample (the rest describe the room)."""


def holdout_mask(s: SceneTensors, every: int) -> torch.Tensor:
    """(N,) bool: the static samples k with k % every == every - 1, held out of training (seen-rooms test).

    Postures are a random permutation per room (``data.scene_builder``), so the held-out samples
    are a posture-mixed sample of every training room; ``every`` 0 holds out nothing.
    """
    k = torch.arange(s.num_samples, device=s.posture.device)
    static = s.trajectory[:, 0] < 0
    if every <= 0:
        return torch.zeros_like(static)
    return static & (k % every == every - 1)


def room_samples(s: SceneTensors, every: int, held: bool) -> SceneTensors:
    """Room ``s`` with only the samples a run with ``holdout_every`` = ``every`` trains on, or with
    ``held`` only those it holds out (``every`` 0: all samples are trained on, ``s`` itself)."""
    if every <= 0 and not held:
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


def region_center(scene_dir: Path) -> np.ndarray:
    """(2,) world floor center of a dataset scene's hidden region."""
    try:
        hr = json.loads((scene_dir / "scene.json").read_text())["hidden_region"]
        return (np.asarray(hr["min"], float) + np.asarray(hr["max"], float)) / 2
    except (OSError, KeyError, TypeError, json.JSONDecodeError) as exc:
        raise NlosError(f"{scene_dir}/scene.json: no readable hidden_region ({type(exc).__name__})") from None


def graph_inputs(mesh: TriMesh, camera_to_world: np.ndarray, features: list[str]):
    """IEN input of a LOS mesh: (V, 3 [+3]) normalized camera-frame coordinates [+ normals], (2, E) edges."""
    graph = mesh_to_graph(mesh, frame=np.linalg.inv(camera_to_world))
    x = normalize_positions(torch.as_tensor(graph.pos, dtype=torch.float32))[0]
    if "normals" in features:
        x = torch.cat([x, torch.as_tensor(graph.normals, dtype=torch.float32)], dim=1)
    return x, torch.as_tensor(np.asarray(graph.edge_index), dtype=torch.long)


def load_scene_tensors(scene_dir: Path, features: list[str]) -> SceneTensors:
    try:
        st = np.load(scene_dir / "static.npz")
        files = sorted((scene_dir / "samples").glob("*.npz"))
        zs = [np.load(f) for f in files]
    except Exception as exc:  # np.load raises several types on torn files
        raise NlosError(f"{scene_dir}: corrupted dataset file ({type(exc).__name__})") from None
    pose = st["camera_to_world"]
    x, edges = graph_inputs(TriMesh(st["los_vertices"], st["los_faces"]), pose, features)
    fwd = -pose[:2, 2]
    fwd = fwd / np.linalg.norm(fwd)
    cam = pose[:2, 3]
    origin = region_center(scene_dir)
    f32 = lambda a: torch.as_tensor(np.asarray(a), dtype=torch.float32)
    return SceneTensors(
        x=x, edge_index=edges,
        faces=torch.as_tensor(st["los_faces"], dtype=torch.long), landed=torch.as_tensor(st["spot_landed"]),
        direct=f32(st["direct"]), ambient=f32(st["ambient"]),
        u=f32(np.stack([z["transport_u"] for z in zs])), v=f32(np.stack([z["transport_v"] for z in zs])),
        nlos_ambient=f32(np.stack([z["nlos_ambient"] for z in zs])),
        target=f32(ground_frame(np.stack([z["position"] for z in zs]), origin, fwd)),
        posture=torch.as_tensor([int(z["posture"]) for z in zs]),
        trajectory=torch.as_tensor([[int(z["trajectory"]), int(z["frame"])] for z in zs]),
        camera_xy=f32(cam), forward_xy=f32(fwd), origin_xy=f32(origin),
        flash_direct=f32(st["flash_direct"]) if "flash_direct" in st.files else None,
        flash_nlos=f32(np.stack([z["flash_nlos"] for z in zs])) if zs and "flash_nlos" in zs[0].files else None,
        scene_dir=str(scene_dir))


def split_ids(data_dir: str | Path, split: str) -> list[str]:
    """Scene ids of a finished dataset's split (NlosError when unfinished, corrupted or empty)."""
    data_dir = Path(data_dir)
    try:
        manifest = json.loads((data_dir / "manifest.json").read_text())
    except FileNotFoundError:
        raise NlosError(f"{data_dir}: no manifest.json (not a finished nlos dataset)") from None
    except json.JSONDecodeError:
        raise NlosError(f"{data_dir}/manifest.json: corrupted (invalid JSON)") from None
    ids = [s["id"] for s in manifest["splits"].get(split, [])]
    if not ids:
        raise NlosError(f"{data_dir}: split '{split}' is empty")
    return ids


def load_split(data_dir: str | Path, split: str, features: list[str],
               keep: Callable[[SceneTensors], SceneTensors] | None = None) -> list[SceneTensors]:
    """Every scene of a split; ``keep`` (e.g. a sample subset) is applied as each loads, to bound memory."""
    keep = keep or (lambda s: s)
    return [keep(load_scene_tensors(Path(data_dir) / "scenes" / sid, features)) for sid in split_ids(data_dir, split)]
