"""A room model directory as ``nlos predict`` reads it: the checkpoint, the capture, the room frame.

``ROOM_MODEL/final.pt`` is an ordinary checkpoint; ``report.json`` adds what a photograph of that
room needs: the capture (burst length, exposure) and where the hidden region lies, so positions can
be given in the room's own coordinates (the scan's, turned z up) beside the network's frame.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import NlosError
from .report import region_to_world


@dataclass
class RoomModel:
    """What ``report.json`` of a room model says."""

    path: Path
    """The room model directory."""
    report: dict
    """``report.json``."""

    @property
    def burst_frames(self) -> int:
        return int(self.report["capture"]["burst_frames"])

    @property
    def exposure_s(self) -> float:
        return float(self.report["capture"]["exposure_s"])

    def room_xy(self, xy: np.ndarray) -> np.ndarray:
        """Network positions (N, 2) (region frame) -> (N, 2) x, y in the room's z-up frame, m."""
        return region_to_world(np.asarray(xy, np.float64), self.report["room"])

    def describe(self) -> str:
        s = self.report["spot"]
        return (f"room model {self.path}: spot on face {s['face']} (pan {s['pan_deg']:+.1f} deg, tilt "
                f"{s['tilt_deg']:+.1f} deg); capture: bursts of {self.burst_frames} frames of "
                f"{1000 * self.exposure_s:.0f} ms, minus the empty-room burst (--background)")


def load_room_model(path: str | Path) -> RoomModel | None:
    """The room model at ``path``, or None when ``path`` is a plain run or checkpoint."""
    p = Path(path)
    rep = p / "report.json"
    if not (p.is_dir() and (p / "fit.json").exists()):
        return None
    try:
        report = json.loads(rep.read_text())
        c, r, s = report["capture"], report["room"], report["spot"]
        int(c["burst_frames"]), float(c["exposure_s"]), int(s["face"]), float(s["pan_deg"]), float(s["tilt_deg"])
        [float(v) for v in (*r["hidden_region"]["min"], *r["hidden_region"]["max"], *r["camera"]["position"],
                            *r["camera"]["look_at"])]
    except FileNotFoundError:
        raise NlosError(f"{p}: the fit has not finished (no report.json); rerun nlos fit with --resume") from None
    except (json.JSONDecodeError, KeyError, TypeError, ValueError):
        raise NlosError(f"{rep}: corrupted or not a room model report") from None
    return RoomModel(p, report)
