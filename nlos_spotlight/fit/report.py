"""A room model's report: ``report.json`` (the numbers) and ``report.html`` (self-contained).

Figures (``fit.figures``): the room and the spot in 3D, the localization error over the hidden
region's floor, the posture confusion matrix, one simulated photograph per posture.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..evaluate.report import Block, write_report
from ..render.sensor import SensorConfig
from ..world.body import POSTURES
from .config import FitConfig


def region_to_world(xy: np.ndarray, room: dict) -> np.ndarray:
    """Region-frame positions (N, 2) (``data.tensors.ground_frame``) -> world floor x, y (N, 2)."""
    cam = np.asarray(room["camera"]["position"])
    fwd = np.asarray(room["camera"]["look_at"])[:2] - cam[:2]
    fwd = fwd / np.linalg.norm(fwd)
    left = np.array([-fwd[1], fwd[0]])
    hr = room["hidden_region"]
    origin = (np.asarray(hr["min"]) + np.asarray(hr["max"])) / 2
    return origin + xy[:, :1] * fwd + xy[:, 1:] * left


def person_free(out: Path, cfg: FitConfig, face: int) -> np.ndarray:
    """(H, W, 3) the room's stored light without the person under the fit's light, as training forms
    it (``train.imaging.form_parts``): the spot's direct light on ``face``, the flash's, or none
    (projector off), plus the room's own light."""
    from ..data.static import read_static
    from .spot import scene_dir

    key = {"spot": "direct", "flash": "flash_direct", "ambient": None}[cfg.light]
    st = read_static(scene_dir(out), "ambient", *([key] if key else []))
    if key is None:
        return st["ambient"]
    return (st[key][face] if cfg.light == "spot" else st[key]) + st["ambient"]


def capture_record(out: Path, cfg: FitConfig, face: int) -> dict:
    """The capture a user repeats: exposure per frame (average metering on the room in the fit's
    light: the spot, the flash, or the projector off), burst length, the empty-room capture."""
    import torch

    from ..render.sensor import auto_exposure
    from .train import capture_overrides

    free = person_free(out, cfg, face)
    sensor = SensorConfig.at(free.shape[:2], capture_overrides(out, cfg))
    t = auto_exposure(torch.as_tensor(free, dtype=torch.float32), sensor)
    return {"burst_frames": cfg.burst_frames, "exposure_s": t, "burst_s": t * cfg.burst_frames,
            "metering": sensor.metering, "target_mean_fraction": sensor.target_mean_fraction,
            "f_number": sensor.f_number, "bit_depth": sensor.bit_depth, "raw": True,
            "resolution": [int(free.shape[0]), int(free.shape[1])],
            "light": cfg.light,
            "background": "an empty-room burst with the same settings and light before the person enters; the "
                          "network reads the photograph minus it",
            "camera": "the APS-C mirrorless class of DESIGN section 6 (render.sensor.SensorConfig defaults, "
                      "with the room scene's sensor overrides)", "sensor": sensor.to_dict()}


def _network(cfg: FitConfig) -> str:
    """The room model's network in words (``--method``)."""
    from ..evaluate.methods import fit_method

    m = fit_method(cfg.method)
    net = "resnet10-narrow (half stem)" if m.arch == "resnet18" else f"{m.arch} ({m.label})"
    return f"{net}, photograph minus empty-room photograph"


def write_fit_report(out: Path, cfg: FitConfig, room: dict, spot: dict, result, timing: dict,
                     ceiling: dict | None = None, memory: dict | None = None) -> dict:
    """Write report.json, the figures and report.html (atomically); returns report.json's content.
    ``ceiling``: the room's ceiling (``fit/ceiling.py``), or None; ``memory``: this run's peak
    memory (``fit.run.peak_memory_mb``), or None."""
    from ..data.store import atomic_json
    from . import figures

    out = Path(out)
    hp = np.load(out / "train" / "heldout.npz")
    true_w, pred_w = region_to_world(hp["true_xy"], room), region_to_world(hp["pred_xy"], room)
    err_cm = 100 * np.linalg.norm(pred_w - true_w, axis=1)
    report = {
        "spot": None if cfg.light != "spot" else {k: spot.get(k) for k in (
            "face", "aim", "pan_deg", "tilt_deg", "azimuth_deg", "distance_m", "landing")},
        "light": {"mode": cfg.light, **{k: spot[k] for k in ("explain", "capture", "not_rendered") if k in spot}},
        "heldout": {"people": int(len(err_cm)), "posture_accuracy": result.posture_accuracy / 100,
                    "posture3_accuracy": result.posture3_accuracy / 100, "error_cm": float(err_cm.mean()),
                    "median_error_cm": float(np.median(err_cm)), "mean_answer_cm": result.mean_answer_cm,
                    "confusion": result.confusion, "postures": list(POSTURES)},
        "spot_policies": spot.get("policies"),
        "ceiling": None if ceiling is None else {k: v for k, v in ceiling.items() if k not in ("key", "indices")},
        "capture": capture_record(out, cfg, spot["face"]),
        "training": {"people": cfg.people, "policy": cfg.policy, "method": cfg.method, "steps": result.steps,
                     "seconds": result.seconds, "network": _network(cfg)},
        "room": room, "timing_s": timing, "peak_memory_mb": memory, "config": cfg.to_dict(),
        "frame": "positions: x, y in the room's z-up frame (m); the network's own output is the region frame "
                 "of nlos predict",
    }
    figs = out / "figures"
    figs.mkdir(exist_ok=True)
    figures.room_3d(out / "room", room, spot, figs / "room.png")
    figures.error_map(true_w, err_cm, room, figs / "error-map.png")
    figures.confusion(np.asarray(result.confusion), figs / "confusion.png")
    figures.photos(hp["photo_image"], hp["photo_background"], figs / "photos.png")
    atomic_json(out / "report.json", report)
    write_report(_blocks(report), out, "nlos room model")
    (out / "report.md").unlink(missing_ok=True)  # the HTML is the report; figures/ holds the PNGs
    return report


def _policy_blocks(sp: dict | None) -> list[Block]:
    """The spot each policy would pick and its SNR against the best candidate's."""
    if not sp:
        return []
    rows = [[name, v.get("light", str(v["face"])), f"{v['snr_over_best']:.2f}"] for name, v in sp["policies"].items()]
    return [Block("p", "Each spot policy's pick in this room and its mean NLOS SNR over the best landed "
                       "candidate's (the room's full-transport people): what it gives up before training; "
                       "a fit without a spot: its light's SNR on the chosen row."),
            Block("table", header=["policy", "face", "SNR / best"], rows=rows)]


def _ceiling_blocks(c: dict | None, h: dict) -> list[Block]:
    """What any reader of these photographs could do, beside what the room model does."""
    if not c:
        return []
    return [Block("p", f"The room's ceiling on {c['people']} of them (fit/ceiling.py): an ideal observer that "
                       "knows the room and the body and fits place, facing, height and clothing to first order, "
                       f"and the position Cramer-Rao bound, each reading one burst of {c['burst_frames']} frames."),
            Block("table", header=["", "six-way posture", "position error"],
                  rows=[["room model", f"{100 * h['posture_accuracy']:.1f}%", f"{h['error_cm']:.1f} cm (mean)"],
                        ["ceiling", f"{100 * c['posture_accuracy']:.1f}%",
                         f"{c['position_crb_cm']:.1f} cm (bound on the RMS error, median person)"]])]


def _aim_blocks(r: dict) -> list[Block]:
    """Where to aim the projector, or (no spot) what lights the photographs and what the fit left out."""
    s, light = r["spot"], r.get("light") or {"mode": "spot"}
    if s is None:
        left = [[k, v] for k, v in light.get("not_rendered", {}).items()]
        return [Block("h2", "Light: no spot"), Block("p", light["explain"] + "."),
                Block("p", "What this fit leaves out of its training photographs (a fit with a spot renders it):"),
                Block("table", header=["step", "why"], rows=left),
                Block("image", "The room (z up), the camera, the projector and the hidden region",
                      image="figures/room.png")]
    return [Block("h2", "Where to aim the projector"),
            Block("table", header=["face", "aim point (m)", "pan (deg, + left)", "tilt (deg, + up)", "distance (m)"],
                  rows=[[str(s["face"]), ", ".join(f"{v:+.2f}" for v in s["aim"]), f"{s['pan_deg']:+.1f}",
                         f"{s['tilt_deg']:+.1f}", f"{s['distance_m']:.2f}"]]),
            Block("image", "The room (z up), the camera, the projector's beam to the spot and the hidden region",
                  image="figures/room.png")]


def _memory_phrase(m: dict | None) -> str:
    """', peak memory ...' of report.json's ``peak_memory_mb`` (empty for a report without it)."""
    if not m:
        return ""
    each = f", each rendering process at most {m['rendering_process']:,} MB" if m.get("rendering_process") else ""
    return f"; peak memory: this process {m['fit_process']:,} MB{each}"


LIT = {"spot": "the spot on", "flash": "the flash on", "ambient": "the projector off"}
"""What the capture's metering sees, per light (``report.json``'s ``light``)."""


def _blocks(r: dict) -> list[Block]:
    h, c = r["heldout"], r["capture"]
    rm = r["room"]
    return [
        Block("h1", "Room model"),
        Block("p", f"Source: {r['config']['name']} preset, {r['training']['people']} synthetic people trained on, "
                   f"method {r['training']['method']} (policy {r['training']['policy']}); fitted in "
                   f"{r['timing_s']['total_s'] / 60:.1f} min{_memory_phrase(r.get('peak_memory_mb'))}."),
        *_aim_blocks(r),
        *_policy_blocks(r.get("spot_policies")),
        Block("h2", "Capture"),
        Block("p", f"A burst of {c['burst_frames']} RAW frames of {1000 * c['exposure_s']:.0f} ms each "
                   f"({c['burst_s']:.1f} s) at f/{c['f_number']:g}, average metering at "
                   f"{100 * c['target_mean_fraction']:.0f}% of full scale with {LIT[c.get('light', 'spot')]}; "
                   f"{c['background']}."),
        Block("h2", f"Held-out synthetic people ({h['people']})"),
        Block("table", header=["six-way posture", "upright / sitting / crouching", "mean error", "median error",
                               "mean-position answer"],
              rows=[[f"{100 * h['posture_accuracy']:.1f}%", f"{100 * h['posture3_accuracy']:.1f}%",
                     f"{h['error_cm']:.1f} cm", f"{h['median_error_cm']:.1f} cm", f"{h['mean_answer_cm']:.1f} cm"]]),
        *_ceiling_blocks(r.get("ceiling"), h),
        Block("image", "Localization error over the hidden region's floor (each held-out person, and the mean "
                       "per cell)", image="figures/error-map.png"),
        Block("image", "Posture confusion matrix (rows: true posture)", image="figures/confusion.png"),
        Block("image", "One simulated photograph per posture (top) and the person's light: photograph minus "
                       "the empty-room photograph (bottom)", image="figures/photos.png"),
        Block("h2", "Room"),
        Block("code", json.dumps({k: rm[k] for k in ("camera", "projector", "hidden_region", "materials",
                                                       "hidden_check")}, indent=1)),
    ]
