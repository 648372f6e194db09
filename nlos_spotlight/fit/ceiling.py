"""The room's ceiling: what any reader of the room model's photographs could do (``report.json``'s ``ceiling``).

For the first ``ceiling_people`` held-out people, under the chosen spot and the fit's capture (a
burst of ``burst_frames``), the person's light (``nlos`` + ``nlos_ambient``) is rendered in each of
the six postures with everything else the same, and its derivatives with respect to seven nuisances
(floor x and y, facing, height, the three clothing albedo channels; central differences of
:data:`STEPS`). Whitened by the capture's noise (``render.sensor.noise_variance_dn``, metered on
the person-free frame as the study ``experiments/physics-bounds`` does):

* six-way posture of an ideal observer (``evaluate.ideal_observer``): ``known`` (everything but the
  posture known) and ``nuisance`` (the nuisances fitted to first order): the accuracy no network
  reading the photograph can pass;
* the position Cramer-Rao bound of the person's own posture (``evaluate.crb``: the RMS error of
  any unbiased estimator that knows everything but x and y).

A fit without a spot (``FitConfig.light``) computes the same under its own light: the flash (the
dataset's flash renderer, ``data/flash.py``) or the projector off (no projector term: the person's
light is ``nlos_ambient`` alone, the exposure metered on the room's own light).

Both are upper bounds on what the room model can reach: they know the body's build and pose
variant, the room exactly, and read one capture without the empty-room photograph's noise or the
capture's drift. Cost: 6 x 10 renders a person (the three albedo columns need one: :func:`jacobian`).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import torch

from .config import FitConfig

STEPS = {"x": 0.01, "y": 0.01, "facing_deg": 2.0, "height_m": 0.01, "albedo_r": 0.01, "albedo_g": 0.01,
         "albedo_b": 0.01}
"""Nuisance -> central-difference step (m, degrees or albedo); x and y come first (the CRB's columns)."""
DRAWS = 4000
"""Monte Carlo draws of the ideal observer per person and posture."""


def perturbed(params, t: np.ndarray, name: str, h: float):
    """(body parameters, translation) with nuisance ``name`` moved by ``h``."""
    from ..world.body import HEIGHT_RANGE_M

    t = t.copy()
    if name in ("x", "y"):
        t["xy".index(name)] += h
        return params, t
    if name.startswith("albedo_"):
        a = np.array(params.albedo, float)
        a["rgb".index(name[-1])] += h
        return dataclasses.replace(params, albedo=np.clip(a, 0, 1)), t
    if name == "height_m":
        lo, hi = HEIGHT_RANGE_M
        return dataclasses.replace(params, height_m=float(np.clip(params.height_m + h, lo, hi))), t
    return dataclasses.replace(params, **{name: getattr(params, name) + h}), t


def _person(params, dcfg):
    """The posed body of ``params`` sampled as the fit samples it (``render.person.Person``)."""
    from ..render.person import Person
    from ..world.body import posed_body

    body = posed_body(params, target_faces=dcfg.body_faces)
    return Person.sampled(body, params.albedo, dcfg.render)


def person_light(r, y, params, t: np.ndarray, dcfg, person=None) -> torch.Tensor:
    """(H * W * 3,) the person's light (the terms that depend on the person), float64 radiance;
    ``person``: ``params``' body already sampled."""
    from ..evaluate.crb import PERSON

    person = _person(params, dcfg) if person is None else person
    return r.render(y, person, translation=t, components=PERSON).image.double().reshape(-1)


def jacobian_reference(r, y, params, t: np.ndarray, dcfg) -> torch.Tensor:
    """(H * W * 3, 7) derivatives of the person's light with respect to :data:`STEPS`' nuisances:
    every column a central difference of two renders (the slow reference of :func:`jacobian`)."""
    cols = []
    for name, h in STEPS.items():
        plus, minus = (person_light(r, y, *perturbed(params, t, name, s), dcfg) for s in (h, -h))
        cols.append((plus - minus) / (2 * h))
    return torch.stack(cols, 1)


def jacobian(r, y, params, t: np.ndarray, dcfg, light: torch.Tensor | None = None, person=None) -> torch.Tensor:
    """(H * W * 3, 7) :func:`jacobian_reference`'s derivatives with 5 renders fewer. The person's
    light in channel c is affine in albedo_c (one Lambertian bounce off the body: ``nlos`` is
    albedo_c times that channel's transport; ``nlos_ambient`` is (albedo_c - 1) times the hidden
    light the body sends back, the light it replaces counted negative), so an albedo column is that
    channel of ``light`` (``params``' own, rendered here if not given) minus the same body's light at
    albedo 0, over albedo_c, times the clipped step's share (clip(a + h) - clip(a - h)) / 2h: the
    central difference exactly, with one render for all three channels. The floor steps move the
    same sampled body (``person``: ``params``' body already sampled, as ``light`` was rendered)."""
    from ..evaluate.crb import PERSON

    person = _person(params, dcfg) if person is None else person
    light = person_light(r, y, params, t, dcfg, person) if light is None else light
    albedo = np.broadcast_to(np.asarray(params.albedo, np.float64), (3,))
    black = None  # the body's light at albedo 0 (the hidden light it blocks), rendered once if needed
    cols = []
    for name, h in STEPS.items():
        c = "rgb".index(name[-1]) if name.startswith("albedo_") else None
        if c is not None and albedo[c] > 0:
            if black is None:
                dark = dataclasses.replace(person, albedo=np.zeros_like(person.albedo))
                black = r.render(y, dark, translation=t, components=PERSON).image.double().reshape(-1)
            a = albedo[c]
            share = (min(a + h, 1.0) - max(a - h, 0.0)) / (2 * h)
            col = torch.zeros_like(light)
            col.view(-1, 3)[:, c] = (light - black).view(-1, 3)[:, c] * (share / a)
        elif name in ("x", "y"):
            plus, minus = (person_light(r, y, params, perturbed(params, t, name, s)[1], dcfg, person) for s in (h, -h))
            col = (plus - minus) / (2 * h)
        else:
            plus, minus = (person_light(r, y, *perturbed(params, t, name, s), dcfg) for s in (h, -h))
            col = (plus - minus) / (2 * h)
        cols.append(col)
    return torch.stack(cols, 1)


def crb_m(jac_xy: torch.Tensor, frames: int) -> float:
    """sqrt(trace(J^-1)) (m) from whitened one-frame derivatives (P, 2) and a burst of ``frames``."""
    fisher = frames * (jac_xy.T @ jac_xy)
    if float(torch.linalg.det(fisher)) <= 0:
        return float("inf")
    return float(torch.sqrt(torch.trace(torch.linalg.inv(fisher))))


def light_renderer(room, settings, light: str, spot: dict):
    """(``Renderer``, spot vector y) of the fit's light in ``room``: the chosen ``spot``; 'flash' the
    flash as the dataset renders it (``data.scene_builder``: its scene and projector rays); 'ambient'
    y zero, so that no projector term is lit (the aim is then only a placeholder the renderer needs)."""
    from ..data.flash import FLASH_SPOT_SAMPLES, flash_scene
    from ..render.transport import Renderer

    if light == "flash":
        more = dataclasses.replace(settings, spot_samples=settings.spot_samples * FLASH_SPOT_SAMPLES)
        r = Renderer(flash_scene(room), more, aim_points=room.camera.look_at[None])
        return r, r.spot_vector(0)
    aim = room.camera.look_at if light == "ambient" else spot["aim"]
    r = Renderer(room, settings, aim_points=np.asarray(aim, np.float64)[None])
    return r, r.spot_vector(0) * (light == "spot")


def room_ceiling(out: Path, cfg: FitConfig, spot: dict, progress: bool = True) -> dict:
    """The ceiling of a fitted room (module docstring) over its first ``cfg.ceiling_people`` held-out people."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from ..console import QUIET, console
    from ..evaluate.ideal_observer import ideal_observer
    from ..render.sensor import SensorConfig, auto_exposure, dn_per_radiance, noise_variance_dn
    from ..render.settings import resolve_device
    from ..world.body import POSTURES
    from .run import room_builder
    from .train import capture_overrides, heldout_indices

    builder, dcfg = room_builder(out, cfg)
    room, specs = builder._scan_people()
    settings = dcfg.render_settings(device=resolve_device(cfg.render_device))
    r, y = light_renderer(room, settings, cfg.light, spot)
    sensor = SensorConfig.at(r.shape, capture_overrides(out, cfg), {"burst_frames": 1})  # one frame's noise
    static = r.render(y, None, components=("direct", "ambient")).image.double()
    k = dn_per_radiance(auto_exposure(static, sensor), sensor)
    people = heldout_indices(out, cfg)[:cfg.ceiling_people]
    known, fitted, crbs = [], [], []
    columns = (TextColumn("ceiling"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn())
    with Progress(*columns, console=console, disable=QUIET or not progress) as bar:
        task = bar.add_task("ceiling", total=len(people))
        for i in people:
            spec = specs[i]
            base, t = spec["params"], np.array([*spec["position"], room.hidden_region.floor_z])
            per = {q: dataclasses.replace(base, posture=q) for q in POSTURES}
            body = {q: _person(per[q], dcfg) for q in POSTURES}  # sampled once: the light and its derivatives
            mu = {q: person_light(r, y, per[q], t, dcfg, body[q]) for q in POSTURES}
            jac = {q: jacobian(r, y, per[q], t, dcfg, mu[q], body[q]) for q in POSTURES}
            sigma = noise_variance_dn(((static.reshape(-1) + mu[base.posture]) * k).clamp(min=0), sensor).sqrt() / k
            means = torch.stack([mu[q] / sigma for q in POSTURES])
            jacs = torch.stack([jac[q] / sigma[:, None] for q in POSTURES])
            obs = ideal_observer(means, jacs, frames=cfg.burst_frames, draws=DRAWS, seed=cfg.seed + i)
            known.append(obs.accuracy[0])
            fitted.append(obs.accuracy[1])
            crbs.append(crb_m(jac[base.posture][:, :2] / sigma[:, None], cfg.burst_frames))
            bar.advance(task)
    return {"people": len(people), "burst_frames": cfg.burst_frames,
            "posture_accuracy_known": float(np.mean(known)), "posture_accuracy": float(np.mean(fitted)),
            "position_crb_cm": float(100 * np.median(crbs)), "position_crb_cm_mean": float(100 * np.mean(crbs)),
            "indices": [int(i) for i in people]}


def ceiling_record(out: Path, cfg: FitConfig, spot: dict, progress: bool = True) -> dict | None:
    """``ROOM_MODEL/ceiling.json`` (computed once, atomically, for this spot and people count), None if
    ``ceiling_people`` is 0."""
    from ..data.store import atomic_json

    if cfg.ceiling_people == 0:
        return None
    path = Path(out) / "ceiling.json"
    key = {"face": int(spot["face"]), "people": cfg.ceiling_people, "burst_frames": cfg.burst_frames,
           **({} if cfg.light == "spot" else {"light": cfg.light})}
    if path.exists():
        try:
            got = json.loads(path.read_text())
            if got.get("key") == key:
                return got
        except (OSError, json.JSONDecodeError):
            pass  # damaged: computed again
    got = {"key": key, **room_ceiling(out, cfg, spot, progress)}
    atomic_json(path, got)
    return got


__all__ = ["STEPS", "ceiling_record", "jacobian", "jacobian_reference", "room_ceiling"]
