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
from ..evaluate.methods import LIGHTS, light_of
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

    @property
    def light(self) -> str:
        """'spot', 'flash' or 'ambient' (projector off): what lights the photographs it reads (a
        report written before fits without a spot has a spot)."""
        return (self.report.get("light") or {}).get("mode", "spot")

    def check_network(self, policy: str) -> None:
        """Refuse, in one line, weights trained under another light than the report's (a room model's
        ``final.pt`` swapped for another's): such a network reads photographs it never saw."""
        light = light_of(policy)
        if light != self.light:
            said = lambda x: "a projector spot" if x == "spot" else LIGHTS[x].words
            raise NlosError(f"{self.path}: final.pt was trained under {said(light)} (policy {policy}), but report.json "
                            f"says the photographs are taken under {said(self.light)}; fit the room again")

    def describe(self) -> str:
        """What to photograph: where the spot is aimed, or with what light, and the capture."""
        s = self.report["spot"]
        light = (f"spot on face {s['face']} (pan {s['pan_deg']:+.1f} deg, tilt {s['tilt_deg']:+.1f} deg)"
                 if self.light == "spot" else f"no spot: {LIGHTS[self.light].photograph}")
        return (f"room model {self.path}: {light}; capture: bursts of {self.burst_frames} frames of "
                f"{1000 * self.exposure_s:.0f} ms, minus the empty-room burst (--background) in the same light")


def load_room_model(path: str | Path) -> RoomModel | None:
    """The room model at ``path``, or None when ``path`` is a plain run or checkpoint."""
    p = Path(path)
    rep = p / "report.json"
    if not (p.is_dir() and (p / "fit.json").exists()):
        return None
    try:
        report = json.loads(rep.read_text())
        c, r, s = report["capture"], report["room"], report["spot"]
        light = (report.get("light") or {}).get("mode", "spot")
        int(c["burst_frames"]), float(c["exposure_s"])
        if light == "spot":
            int(s["face"]), float(s["pan_deg"]), float(s["tilt_deg"])
        hr, cam = r["hidden_region"], r["camera"]
        numbers = [float(v) for v in (*hr["min"], *hr["max"], *cam["position"], *cam["look_at"])]
    except FileNotFoundError:
        raise NlosError(f"{p}: the fit has not finished (no report.json); rerun nlos fit with --resume") from None
    except (json.JSONDecodeError, KeyError, TypeError, ValueError, AttributeError):
        raise NlosError(f"{rep}: corrupted or not a room model report") from None
    problem = _report_problem(c, s, numbers, light)
    if problem:
        raise NlosError(f"{rep}: {problem} (edited or damaged; fit the room again)")
    return RoomModel(p, report)


def _report_problem(capture: dict, spot: dict | None, numbers: list[float], light: str) -> str | None:
    """What makes a parsed ``report.json`` impossible for a fit to have written, or None."""
    if light not in ("spot", *LIGHTS):
        return f"light must be spot, {' or '.join(LIGHTS)}, got {light!r}"
    if light != "spot" and spot is not None:
        return f"a {light} room model aims no spot, but its report names one"
    if not all(np.isfinite(numbers)) or max(abs(v) for v in numbers) > 1e6:
        return "a non-finite or absurd coordinate in the room's camera or hidden region"
    lo, hi = np.asarray(numbers[:2]), np.asarray(numbers[2:4])
    if len(numbers) != 10 or not (hi > lo).all():
        return "the hidden region's min and max are not a box"
    if np.allclose(numbers[4:6], numbers[7:9]):
        return "the camera looks straight up or down (its look_at is above its position)"
    if not isinstance(capture["burst_frames"], int) or not 1 <= capture["burst_frames"] <= 1000:
        return f"burst_frames must be an integer from 1 to 1000, got {capture['burst_frames']!r}"
    if not 0 < float(capture["exposure_s"]) <= 3600:
        return f"exposure_s must be a positive number of seconds, got {capture['exposure_s']!r}"
    if light == "spot" and not all(np.isfinite([float(spot["pan_deg"]), float(spot["tilt_deg"])])):
        return "the spot's pan and tilt are not finite"
    return None
