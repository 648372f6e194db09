"""``nlos predict``: the hidden person's floor position and posture from photographs or a video.

Each frame (see :mod:`.images` for the accepted inputs and how they are linearized and resampled)
goes through the trained NLOS network: position (x, y) in meters in the region frame the network
was trained in (``data.tensors.ground_frame``: x along the camera's horizontal viewing direction, y
to its left, from the center of the hidden region; a room model from ``nlos fit`` also gives x, y
in the room's own z-up coordinates) and the six posture probabilities (softmax of the
logits). A sequence of at least :data:`MIN_SMOOTH_FRAMES` frames also gets a Savitzky-Golay
smoothed trajectory (:func:`nlos_spotlight.evaluate.tracking.smooth_trajectory`).
"""

from __future__ import annotations

import csv
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..errors import NlosError
from ..evaluate.tracking import DEFAULT_ORDER, default_window, smooth_trajectory
from ..train.checkpoint import TrainedModels
from ..world.body import POSTURES
from .images import Frames

MIN_SMOOTH_FRAMES = 5
"""Shortest sequence that is smoothed (a window of 5 frames around a quadratic)."""


@dataclass
class Predictions:
    """Per-frame results of ``nlos predict`` (N frames)."""

    sources: list[str]
    """(N,) where each frame came from."""
    xy: np.ndarray
    """(N, 2) float64 position, m, region frame: along the view, to its left, from the region's center."""
    probabilities: np.ndarray
    """(N, 6) float64 posture probabilities in :data:`POSTURES` order; rows sum to 1."""
    times: np.ndarray | None
    """(N,) seconds from the first frame when a frame rate is known, else None."""
    smoothed: np.ndarray | None = None
    """(N, 2) Savitzky-Golay smoothed positions, or None (single frames, short sequences)."""
    window: int | None = None
    """Smoothing window (frames), when smoothed."""
    order: int | None = None
    """Smoothing polynomial order, when smoothed."""
    checkpoint: str = ""
    """The checkpoint file used."""
    image_shape: tuple[int, int] = (0, 0)
    """(H, W) every frame was resampled to."""
    room_xy: np.ndarray | None = None
    """(N, 2) the positions in the room's z-up frame (room models from ``nlos fit``), else None."""
    drift: object | None = None
    """``apps.drift.Drift``: what changed since the empty-room burst, per frame (room models trained
    under a capture variation, with --background), else None."""

    def __len__(self) -> int:
        return len(self.sources)

    @property
    def postures(self) -> list[str]:
        """(N,) most probable posture per frame."""
        return [POSTURES[i] for i in self.probabilities.argmax(axis=1)]

    def to_dict(self) -> dict:
        frames = []
        for i, src in enumerate(self.sources):
            row = {"frame": i, "source": src, "time_s": None if self.times is None else float(self.times[i]),
                   "x_m": float(self.xy[i, 0]), "y_m": float(self.xy[i, 1]), "posture": self.postures[i],
                **({} if self.room_xy is None else {"x_room_m": float(self.room_xy[i, 0]),
                                                    "y_room_m": float(self.room_xy[i, 1])}),
                   "probabilities": {p: float(v) for p, v in zip(POSTURES, self.probabilities[i])}}
            if self.smoothed is not None:
                row["x_smooth_m"], row["y_smooth_m"] = float(self.smoothed[i, 0]), float(self.smoothed[i, 1])
            if self.drift is not None:
                row["drift"] = self.drift.rows()[i]
            frames.append(row)
        smoothing = None if self.smoothed is None else {
            "method": "Savitzky-Golay (scipy.signal.savgol_filter, mode='interp')",
            "window_frames": self.window, "order": self.order}
        return {"checkpoint": self.checkpoint, "image_shape": list(self.image_shape),
                "frame": "region frame: x along the camera's horizontal viewing direction, y to its left, "
                         "meters from the center of the hidden region; x_room_m, y_room_m (room models): "
                         "the room's z-up coordinates",
                "postures": list(POSTURES), "smoothing": smoothing, "frames": frames}


def run_network(models: TrainedModels, images: np.ndarray, batch_size: int = 64,
                background: np.ndarray | None = None, clipped: np.ndarray | None = None,
                backend: str = "eager") -> tuple[np.ndarray, np.ndarray]:
    """The NLOS network on frames already at ``models.image_shape``.

    Args:
        images: (N, H, W, 3) linear radiance.
        batch_size: frames per forward pass.
        background: (H, W, 3) empty-room frame, for networks trained with background subtraction.
        clipped: (N, H, W) bool, where the camera clipped (photograph or background); None: nowhere.
        backend: ``models.inference.BACKENDS`` (``onnx-int8`` calibrates on the first 16 frames).

    Returns:
        positions (N, 2) m and posture probabilities (N, 6), float64.
    """
    from ..models.inference import compile_network

    if images.ndim != 4 or tuple(images.shape[1:]) != (*models.image_shape, 3):
        raise NlosError(f"frames have shape {images.shape[1:]}, the network expects {(*models.image_shape, 3)}")
    uses_bg = bool(models.config.net.background_subtract)
    if uses_bg and background is None:
        raise NlosError("this network was trained with background subtraction: pass --background EMPTY_ROOM_IMAGE")
    if background is not None and not uses_bg:
        raise NlosError("--background: this network does not use an empty-room image")
    if clipped is None:
        clipped = np.zeros(images.shape[:3], bool)
    bg = lambda n: None if background is None else np.broadcast_to(background, (n, *background.shape))
    calibration = [(images[i:i + 1], bg(1), clipped[i:i + 1]) for i in range(min(16, len(images)))] \
        if backend == "onnx-int8" else None
    run = compile_network(models.net, tuple(models.image_shape), backend, calibration=calibration)
    xy, probs = [], []
    for s in range(0, len(images), batch_size):
        x = images[s:s + batch_size]
        pos, logits = run(x, bg(len(x)), clipped[s:s + batch_size])
        xy.append(pos.astype(np.float64))
        probs.append(torch.softmax(torch.as_tensor(logits, dtype=torch.float64), dim=1).numpy())
    return np.concatenate(xy), np.concatenate(probs)


def predict(models: TrainedModels, frames: Frames, smooth: bool = True, window: int | None = None,
            order: int = DEFAULT_ORDER, batch_size: int = 64, background: np.ndarray | None = None,
            background_clipped: np.ndarray | None = None, backend: str = "eager",
            drift_tolerance: np.ndarray | None = None) -> Predictions:
    """Positions and postures of every frame; a smoothed trajectory for >= 5 frames when ``smooth``.

    ``window`` None picks :func:`default_window` of the frame count. The network's clip flag is
    where the frame or the background (``background_clipped``, (H, W)) clipped. ``drift_tolerance``
    (7,): for a network that projects the capture drift out, also estimate each frame's drift
    against the background and flag it beyond these limits (``apps.drift``), on the same pixels.
    """
    clipped = frames.clipped
    if background_clipped is not None:
        clipped = background_clipped[None] if clipped is None else clipped | background_clipped[None]
    if clipped is not None:
        clipped = np.broadcast_to(clipped, frames.images.shape[:3])
    xy, probs = run_network(models, frames.images, batch_size, background, clipped, backend)
    times = None if frames.fps is None else np.arange(len(frames)) / frames.fps
    out = Predictions(list(frames.sources), xy, probs, times, checkpoint=str(models.path),
                      image_shape=tuple(models.image_shape))
    if drift_tolerance is not None and getattr(models.net, "nuisance", None) is not None and background is not None:
        from .drift import estimate_drift

        out.drift = estimate_drift(models.net, frames.images, background, clipped, drift_tolerance)
    if smooth and len(frames) >= MIN_SMOOTH_FRAMES:
        out.window = window if window is not None else default_window(len(frames), order)
        out.order = order
        out.smoothed = smooth_trajectory(xy, out.window, order)
    return out


# ---------------------------------------------------------------- outputs

def _replace(path: Path, write) -> None:
    """Write through a temporary file and rename: a reader never sees half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    write(tmp)
    os.replace(tmp, path)


def write_csv(p: Predictions, path: Path) -> None:
    """One row per frame: frame, source, time_s, x_m, y_m, posture, p_<posture> x6, x/y_smooth_m."""
    from ..models.nuisance import DIRECTIONS

    header = ["frame", "source", "time_s", "x_m", "y_m", "posture", *[f"p_{n}" for n in POSTURES],
              "x_smooth_m", "y_smooth_m", "x_room_m", "y_room_m", *[f"drift_{d}" for d in DIRECTIONS], "drift_flagged"]

    def write(tmp: Path) -> None:
        with tmp.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(header)
            for i, src in enumerate(p.sources):
                t = "" if p.times is None else f"{p.times[i]:.6g}"
                sm = ["", ""] if p.smoothed is None else [f"{v:.6f}" for v in p.smoothed[i]]
                room = ["", ""] if p.room_xy is None else [f"{v:.6f}" for v in p.room_xy[i]]
                drift = [""] * (len(DIRECTIONS) + 1) if p.drift is None else \
                    [f"{v:.6g}" for v in p.drift.coefficients[i]] + [int(p.drift.flagged[i])]
                w.writerow([i, src, t, f"{p.xy[i, 0]:.6f}", f"{p.xy[i, 1]:.6f}", p.postures[i],
                            *[f"{v:.6f}" for v in p.probabilities[i]], *sm, *room, *drift])

    _replace(path, write)


def write_json(p: Predictions, path: Path) -> None:
    """The predictions as JSON; a non-finite number is written as null (JSON has no NaN)."""
    _replace(path, lambda tmp: tmp.write_text(json.dumps(_finite(p.to_dict()), indent=1, allow_nan=False)))


def _finite(x):
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


SHORT_NAMES = {"standing": "stand", "sitting": "sit", "crouching": "crouch", "hands_90": "h90",
               "hands_45": "h45", "unknown": "unk"}
"""Column headers of the posture probabilities on screen."""


def print_table(p: Predictions, console, max_rows: int = 40) -> None:
    """A rich table of the frames (the first and last ``max_rows // 2`` when there are more)."""
    from rich import box
    from rich.table import Table

    t = Table(title=f"{len(p)} frame{'s' * (len(p) != 1)} at {p.image_shape[0]}x{p.image_shape[1]}", box=box.SIMPLE,
              padding=0, pad_edge=False, caption="x: along the view, y: to its left (m); sm: smoothed")
    t.add_column("#", justify="right")
    t.add_column("source", max_width=14, overflow="ellipsis", no_wrap=True)
    t.add_column("x", justify="right")
    t.add_column("y", justify="right")
    if p.smoothed is not None:
        t.add_column("x sm", justify="right")
        t.add_column("y sm", justify="right")
    if p.room_xy is not None:
        t.add_column("x room", justify="right")
        t.add_column("y room", justify="right")
    t.add_column("posture")
    for name in POSTURES:
        t.add_column(SHORT_NAMES[name], justify="right")
    rows = list(range(len(p)))
    if len(rows) > max_rows:
        rows = rows[:max_rows // 2] + [-1] + rows[-(max_rows // 2):]
    for i in rows:
        if i < 0:
            t.add_row("...", f"{len(p) - 2 * (max_rows // 2)} more")
            continue
        cells = [str(i), p.sources[i], f"{p.xy[i, 0]:.3f}", f"{p.xy[i, 1]:.3f}"]
        if p.smoothed is not None:
            cells += [f"{p.smoothed[i, 0]:.3f}", f"{p.smoothed[i, 1]:.3f}"]
        if p.room_xy is not None:
            cells += [f"{p.room_xy[i, 0]:.2f}", f"{p.room_xy[i, 1]:.2f}"]
        cells.append(p.postures[i])
        cells += [f"{v:.2f}".removeprefix("0") for v in p.probabilities[i]]  # .17: fits 80 columns
        t.add_row(*cells)
    console.print(t)
