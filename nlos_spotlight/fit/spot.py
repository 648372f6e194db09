"""The fit's spot: which candidate face, and how to aim the projector at it (``apps.spotlight``'s
conventions: pan positive to the left of the camera's view, tilt positive up)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from ..errors import NlosError
from ..data.static import read_static
from ..lighting.learned import require_learned
from ..scene.format import Scene, TriMesh


def check_ien_run(checkpoint: str):
    """A trained run whose IEN can pick spots (policy 'ien'), loaded; else one line saying why."""
    from ..train.checkpoint import load_trained

    models = load_trained(checkpoint)
    require_learned(models)
    return models


def ien_face(models, scene: Scene, los: TriMesh) -> int:
    """The most probable landed candidate of a trained IEN on ``los`` (the room's candidates)."""
    from ..lighting.aim import projector_reach
    from ..lighting.learned import ien_logits
    from ..render.rays import RayEngine

    require_learned(models)
    mesh = scene.static_mesh()[0]
    reach, _ = projector_reach(RayEngine(mesh.vertices, mesh.faces), scene.projector.position, scene.camera, los)
    logits = ien_logits(models, los, scene.camera, scene).double().masked_fill(~torch.as_tensor(reach), float("-inf"))
    if not reach.any():
        raise NlosError("the projector reaches none of the faces the camera sees")
    return int(torch.argmax(logits))


def scene_dir(out: Path) -> Path:
    """The fit dataset's one scene directory."""
    dirs = sorted((Path(out) / "data" / "scenes").glob("*"))
    if len(dirs) != 1:
        raise NlosError(f"{out}/data: expected one room, found {len(dirs)}")
    return dirs[0]


def spot_record(out: Path, face: int) -> dict:
    """``report.json``'s ``spot``: face, aim point, pan and tilt, with a printable explanation."""
    from ..lighting.aim import aim_projector
    from ..render.rays import RayEngine
    from ..scene.io import load_scene

    if face < 0:
        raise NlosError("the spot policy chose no spot (flash or ambient): nothing to aim")
    room = load_scene(Path(out) / "room")
    target = np.asarray(read_static(scene_dir(out), "aim_points")["aim_points"][face], np.float64)
    mesh = room.static_mesh()[0]
    proj = room.projector.position
    d = (target - proj) / np.linalg.norm(target - proj)
    hit = RayEngine(mesh.vertices, mesh.faces).first_hit(proj[None], d[None])
    landing = proj + d * hit.t[0] if hit.hit[0] else None
    aim = aim_projector(proj, target, room.camera, landing)
    explain = (f"spot: candidate face {face} at ({target[0]:+.2f}, {target[1]:+.2f}, {target[2]:+.2f}) m; aim the "
               f"projector {aim.distance_m:.2f} m away: pan {aim.pan_deg:+.1f} deg (+ = left of the camera's view), "
               f"tilt {aim.tilt_deg:+.1f} deg (+ = up)")
    if landing is not None and aim.landing_offset_m > 0.02:
        explain += (f"; the beam's center meets the scan at ({landing[0]:+.2f}, {landing[1]:+.2f}, "
                     f"{landing[2]:+.2f}) m, {100 * aim.landing_offset_m:.0f} cm from the aim point (the candidate "
                     "face is decimated): check the spot there")
    return {"face": int(face), "aim": target.tolist(), "pan_deg": aim.pan_deg, "tilt_deg": aim.tilt_deg,
            "azimuth_deg": aim.azimuth_deg, "distance_m": aim.distance_m,
            "landing": None if landing is None else landing.tolist(), "explain": explain,
            "convention": aim.to_dict()["convention"]}


REPORTED_POLICIES = ("oracle", "adaptive", "center", "random")
"""The fixed spot policies the fit's report compares (the chosen one among them)."""


def spot_policies(out: Path, cfg, split, chosen: int) -> dict:
    """``report.json``'s ``spot_policies``: for each of :data:`REPORTED_POLICIES` (and the chosen
    spot) the face it picks in this room and that face's mean NLOS SNR over the best landed
    candidate's (``lighting.snr``, the room's full-transport people): what each policy would give
    up against the physics search, before any training. A fit without a spot (``cfg.light``
    'flash' or 'ambient', ``chosen`` -1): the chosen row is that light's SNR over the best spot's
    (``lighting.snr.scene_snr``: the flash's, or the person's own room light with the projector off)."""
    import dataclasses

    from ..lighting.oracle import by_snr
    from ..lighting.snr import scene_snr

    got = scene_snr(scene_dir(out))
    snr = np.asarray(got.candidates, np.float64)
    landed = split.pool.landed.cpu().numpy().astype(bool)
    best = float(snr[landed].max()) if landed.any() else float("nan")
    rows = {}
    for name in REPORTED_POLICIES:  # the oracle's rule on the SNR in hand, not a second SNR pass
        face = by_snr(snr, landed)[0] if name == "oracle" else policy_face(
            dataclasses.replace(cfg, policy=name, checkpoint="", method="ours"), split)
        rows[name] = {"face": face, "snr_over_best": float(snr[face] / best) if face >= 0 else 0.0}
    if cfg.light == "spot":
        rows["chosen"] = {"face": int(chosen), "snr_over_best": float(snr[chosen] / best)}
    else:
        light = got.flash if cfg.light == "flash" else got.ambient
        if light is None:
            raise NlosError(f"{scene_dir(out)}: the room's people were rendered without the flash; fit it again")
        rows["chosen"] = {"face": -1, "light": cfg.light, "snr_over_best": float(light / best)}
    return {"best_snr": best, "policies": rows}


def light_record(cfg) -> dict:
    """``report.json``'s ``light`` for a fit without a spot (``cfg.light`` 'flash' or 'ambient'):
    what lights the photographs, what to capture, and which of the fit's spot terms it leaves out
    (:func:`unrendered`); ``face`` -1, as the trainer reports a light that is no spot."""
    from ..evaluate.methods import LIGHTS

    capture = LIGHTS[cfg.light].capture
    return {"mode": cfg.light, "face": -1, "explain": f"light: no spot to aim; photograph with {capture}",
            "capture": capture, "not_rendered": unrendered(cfg)}


def unrendered(cfg) -> dict[str, str]:
    """The fit's spot terms a fit without a spot leaves out, each with why (report and console)."""
    from ..evaluate.methods import LIGHTS

    light = LIGHTS[cfg.light].blocked
    return {"spot": "no spot to choose or aim: the method lights none",
            "layers": "the room's static layers under the spot are not rendered: no capture drift (capture_preset "
                      "'ideal'), which render.variation models for the spot's light only",
            "shadow": f"the light the body blocks (nlos_shadow) is rendered under a spot only: photographs without "
                      f"{light} the body blocks on its way to and from the room (shadow_samples 0)",
            "bounce": "the body's light over one more bounce (nlos_bounce) is rendered under a spot only: not in "
                      "these photographs (bounce off)"}


def policy_face(cfg, split) -> int:
    """The face a fixed spot policy picks in the fit's room (what the trainer will use: the same
    policy function and random key, ``train.loop.fixed_illuminations``)."""
    from ..train.loop import fixed_illuminations
    from .train import fit_train_config

    ill, = fixed_illuminations(fit_train_config(cfg), [split.pool])
    return int(ill.face) if ill.mode == "spot" else -1
