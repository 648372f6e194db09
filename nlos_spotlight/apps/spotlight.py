"""``nlos spotlight``: which triangle of a room's mesh to spotlight, and how to aim the projector.

Pipeline (the inference half of DESIGN section 8, on a user's room):

1. **Geometry** (``scene.setup.load_setup``): a scene directory, or a bare scan turned z up, with
   the camera and projector from flags or derived from the mesh. All coordinates in and out
   (flags, printout, JSON) are in that z-up frame; the JSON gives ``file_to_world`` and the spot in
   the file's frame too.
2. **LOS mesh.** As in dataset generation (one function, ``scene.los.los_mesh``): the faces the camera
   sees (2 x 2 rays per pixel, at least ``scene.setup.VISIBILITY_WIDTH`` pixels across so small faces
   of a fine scan are found), cleaned, quadric-decimated to the target vertex count
   (``--target-vertices``, else the run's training dataset's ``los_vertices`` when its config is
   found, else :data:`DEFAULT_TARGET_VERTICES`): the IEN sees meshes as dense as those it was
   trained on. Its faces are the spot candidates.
3. **IEN** (``lighting.learned.ien_logits``): the graph of the LOS mesh in the camera frame, with
   every input the run's training read, one logit per face.
4. **Reachability** (``lighting.aim.projector_reach``): a face is a candidate only if the
   projector's beam toward its centroid lands on it. Probabilities are the softmax of the logits
   over those faces (0 elsewhere); the spot is the most probable face.
5. **Aim** (``lighting.aim.aim_projector``): the direction from the projector to the face centroid,
   and its pan and tilt.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..errors import NlosError
from ..lighting.aim import Aim, aim_projector, oriented_normals, projector_reach
from ..lighting.learned import ien_logits, require_learned
from ..scene.format import TriMesh
from ..scene.setup import PROJECTOR_OFFSET_M, VISIBILITY_WIDTH, RoomSetup
from ..train.checkpoint import TrainedModels

DEFAULT_TARGET_VERTICES = 800
"""LOS mesh size when the run's training dataset is unknown (the paper decimates to 500-1000)."""


# ---------------------------------------------------------------- geometry in

def visible_mesh(setup: RoomSetup, target_vertices: int) -> TriMesh:
    """The LOS mesh (``scene.los.los_mesh``), visible faces found at least :data:`VISIBILITY_WIDTH` rays across."""
    from ..scene.los import los_mesh

    return los_mesh(setup.mesh, setup.engine, setup.camera, target_vertices, min_width=VISIBILITY_WIDTH)


def training_los_vertices(models: TrainedModels) -> int | None:
    """The LOS vertex count of the run's training dataset (RUN/config.json -> DATA/config.json),
    or None when either file is not there."""
    try:
        data = Path(json.loads((models.path.parent / "config.json").read_text())["data"])
        n = json.loads((data / "config.json").read_text())["los_vertices"]
        return int(n) if isinstance(n, int) and n >= 8 else None
    except (OSError, KeyError, TypeError, ValueError):
        return None


# ---------------------------------------------------------------- the result

@dataclass
class Candidate:
    """One of the top-k faces."""

    face: int
    """Face index in the LOS mesh."""
    probability: float
    """IEN probability among the reachable faces."""
    centroid: np.ndarray
    """(3,) world position, m."""


@dataclass
class SpotlightResult:
    """Everything ``nlos spotlight`` reports (and writes with ``--json``)."""

    setup: RoomSetup
    """Input geometry, camera and projector."""
    los: TriMesh
    """The LOS mesh (world frame); face indices refer to it."""
    target_vertices: int
    """Decimation target of the LOS mesh."""
    target_source: str
    """Where the target came from: 'flag', 'training dataset' or 'default'."""
    logits: np.ndarray
    """(F,) IEN logits."""
    reachable: np.ndarray
    """(F,) bool, the projector's beam lands on the face (module docstring, step 4)."""
    probabilities: np.ndarray
    """(F,) softmax of the logits over the reachable faces, 0 elsewhere; sums to 1."""
    face: int
    """The chosen face: argmax of ``probabilities``."""
    normal: np.ndarray
    """(3,) unit normal of the chosen face, toward the camera."""
    top: list[Candidate]
    """The k most probable faces, best first."""
    aim: Aim
    """How to point the projector at the chosen face."""
    checkpoint: str = ""
    """The checkpoint file."""

    @property
    def centroid(self) -> np.ndarray:
        return self.los.centroids()[self.face]

    def to_dict(self) -> dict:
        s, cam = self.setup, self.setup.camera
        return {
            "source": str(s.source), "kind": s.kind, "checkpoint": self.checkpoint,
            "camera": {**{k: v for k, v in cam.to_dict().items() if k not in ("width", "height")},
                       "source": s.camera_source},
            "projector": {"position": s.projector.tolist(), "source": s.projector_source},
            "los_mesh": {"target_vertices": self.target_vertices, "target_source": self.target_source,
                         "vertices": self.los.vertices.tolist(), "faces": self.los.faces.tolist()},
            "file_to_world": s.file_to_world.tolist(),
            "chosen": {"face": self.face, "probability": float(self.probabilities[self.face]),
                       "centroid": self.centroid.tolist(), "normal": self.normal.tolist(),
                       "centroid_in_file": (np.linalg.inv(s.file_to_world) @ [*self.centroid, 1.0])[:3].tolist()},
            "top_k": [{"rank": i + 1, "face": c.face, "probability": c.probability, "centroid": c.centroid.tolist()}
                      for i, c in enumerate(self.top)],
            "aim": self.aim.to_dict(),
            "reachable_faces": int(self.reachable.sum()),
            "probabilities": self.probabilities.tolist(),
            "logits": self.logits.tolist(),
        }


def spotlight(models: TrainedModels, setup: RoomSetup, target_vertices: int | None = None,
              top_k: int = 5) -> SpotlightResult:
    """Run the IEN on ``setup`` and aim the projector at its most probable reachable face."""
    require_learned(models)
    if top_k < 1:
        raise NlosError(f"--top-k: expected a positive count, got {top_k}")
    if target_vertices is not None:
        source = "flag"
    elif (target_vertices := training_los_vertices(models)) is not None:
        source = "training dataset"
    else:
        target_vertices, source = DEFAULT_TARGET_VERTICES, "default"
    if target_vertices < 8:
        raise NlosError(f"--target-vertices: expected at least 8, got {target_vertices}")
    los = visible_mesh(setup, target_vertices)
    logits = ien_logits(models, los, setup.camera, setup.scene)
    reachable, landing = projector_reach(setup.engine, setup.projector, setup.camera, los)
    if not reachable.any():
        raise NlosError(f"the projector at {np.round(setup.projector, 3).tolist()} reaches none of the "
                        f"{len(los.faces)} faces the camera sees (is it inside an object or behind a wall?)")
    masked = logits.double().masked_fill(~torch.as_tensor(reachable), float("-inf"))
    probs = torch.softmax(masked, dim=0).numpy()
    face = int(np.argmax(probs))
    order = np.argsort(-probs, kind="stable")[:min(top_k, int(reachable.sum()))]
    cents = los.centroids()
    top = [Candidate(int(f), float(probs[f]), cents[f]) for f in order]
    aim = aim_projector(setup.projector, cents[face], setup.camera, landing[face])
    return SpotlightResult(setup, los, int(target_vertices), source, logits.double().numpy(), reachable, probs,
                           face, oriented_normals(los, setup.camera)[face], top, aim, str(models.path))


# ---------------------------------------------------------------- output

def write_json(result: SpotlightResult, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(result.to_dict(), indent=1))
    os.replace(tmp, path)


def _v(a) -> str:
    return "(" + ", ".join(f"{float(x):+.3f}" for x in a) + ")"


def print_result(r: SpotlightResult, console) -> None:
    """The chosen face, the aim and the top-k table on the console."""
    from rich.table import Table

    s, cam, a = r.setup, r.setup.camera, r.aim
    if s.kind == "scene":
        console.print(f"[bold]{s.source}[/bold]: scene directory")
    else:
        turned = "" if np.allclose(s.file_to_world, np.eye(4)) else \
            ", turned z up (coordinates below are in that frame; --json has file_to_world)"
        console.print(f"[bold]{s.source}[/bold]: mesh, {len(s.mesh.vertices)} vertices after cleaning{turned}")
    cam_note = {"scene": "from scene.json", "flags": "from flags",
                "default": "default derived from the mesh bounds; set --camera-position/--camera-look-at"}
    console.print(f"camera ({cam_note[s.camera_source]}): position {_v(cam.position)} look_at {_v(cam.look_at)} "
                  f"fov {cam.fov_deg:g} deg")
    proj_note = {"scene": "from scene.json", "flags": "from flags",
                 "default": f"default {PROJECTOR_OFFSET_M[0]} m right of and {-PROJECTOR_OFFSET_M[1]} m below the "
                            "camera; set --projector-position"}
    console.print(f"projector ({proj_note[s.projector_source]}): position {_v(s.projector)}")
    console.print(f"LOS mesh: {len(r.los.vertices)} vertices, {len(r.los.faces)} faces seen by the camera "
                  f"(target {r.target_vertices}, {r.target_source}); "
                  f"{int(r.reachable.sum())} reachable by the projector")
    console.print(f"[bold]spot: face {r.face}[/bold], p = {r.probabilities[r.face]:.3f}, centroid {_v(r.centroid)} m, "
                  f"normal {_v(r.normal)}")
    console.print(f"aim the projector: direction {_v(a.direction)} (unit, from the projector), "
                  f"{a.distance_m:.2f} m away; pan {a.pan_deg:+.1f} deg (+ = left of the camera's view), tilt {a.tilt_deg:+.1f} deg "
                  f"(+ = up); world azimuth {a.azimuth_deg:+.1f} deg (from +x toward +y)")
    if not np.isnan(a.landing).any() and a.landing_offset_m > 0.01:
        console.print(f"the beam's axis meets the scan {100 * a.landing_offset_m:.0f} cm from the face centroid "
                      "(decimation moves surfaces)")
    t = Table(title=f"top {len(r.top)} faces")
    for col, just in (("rank", "right"), ("face", "right"), ("probability", "right"), ("centroid (m)", "left")):
        t.add_column(col, justify=just)
    for i, c in enumerate(r.top):
        t.add_row(str(i + 1), str(c.face), f"{c.probability:.4f}", _v(c.centroid))
    console.print(t)
