"""Body-sampling error of the stored person light, per dataset preset, and the posture signal.

For each preset (its settings from ``nlos_spotlight.data.config.PRESETS``), on one generated room
(``generate_room(seed, RoomConfig(resolution=...))`` with the preset's LOS mesh and candidates, as
``data/scene_builder.py`` builds them) and one person at one place and facing in each of the six
postures, renders the person light a dataset sample stores: the transport images F of every
candidate spot (``Renderer.transport_images``) and, under the flash, ``nlos`` and
``nlos_ambient``. Each is compared with the *converged* render of the same decimated body: the
``faces`` rule at ``--ref-samples`` samples (every face cut into k x k sub-triangles). Rows:

* ``mc``: the Monte Carlo sampler at the preset's ``person_samples`` from before the ``faces``
  rule (192, 192, 256, 512);
* the preset's own ``person_quadrature`` at its ``person_samples`` (marked ``*``);
* ``faces`` at each of ``--faces-n`` (default 1500 and 4000);
* ``area``: the ``faces`` rule without its self-shadow weight (density by area alone), at the
  largest ``--faces-n``.

A row is printed once when two of these coincide; ``n`` is the number of samples made.

Errors are relative L2 over all of F (T x H x W x 3), over the flash ``nlos`` image and over the
``nlos_ambient`` image; s/person is Person.from_mesh + transport_images + the flash render (what
a dataset sample spends on the person light, the low-rank factorization and body aside).

The posture-signal table gives each posture's converged relative L2 difference from ``standing``
(same place, facing, build and albedo): the signal that body-sampling error must stay well below.

    python benchmarks/person_convergence.py [--quick] [--presets tiny demo] [--faces-n 1500 3000 4000]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
import torch

from nlos_spotlight.data.config import PRESETS
from nlos_spotlight.data.flash import FLASH_SPOT_SAMPLES, flash_scene
from nlos_spotlight.scene.los import los_mesh
from nlos_spotlight.render.person import Person, face_quadrature
from nlos_spotlight.render.surface import StaticSurfaces
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.world.body import POSTURES, posed_body, sample_body_params
from nlos_spotlight.world.rooms import RoomConfig, generate_room, person_positions

OLD_MC_SAMPLES = {"tiny": 192, "demo": 192, "demo-room": 192, "small": 256, "paper": 512}
"""``person_samples`` of the presets when they used the ``mc`` sampler."""
BATCH = 4000
"""Body samples per render of the reference (the light is a sum over samples)."""


def renderers(cfg, seed: int, max_spots: int):
    """The preset's room, spot renderer, flash renderer and hidden-region floor height."""
    scene = generate_room(seed, RoomConfig(resolution=cfg.resolution)).scene
    surf = StaticSurfaces(scene)
    los = los_mesh(surf.mesh, surf.engine, scene.camera, cfg.los_vertices)
    aim = los.centroids()
    if 0 < max_spots < len(aim):
        aim = aim[np.linspace(0, len(aim) - 1, max_spots).round().astype(int)]
    settings = RenderSettings(pixel_samples=cfg.render.pixel_samples, transport_pixel_samples=cfg.render.transport_pixel_samples,
                              spot_samples=cfg.render.spot_samples, person_samples=cfg.render.person_samples, device="cpu")
    r = Renderer(scene, settings, aim_points=aim)
    flash_settings = dataclasses.replace(settings, spot_samples=settings.spot_samples * FLASH_SPOT_SAMPLES)
    flash = Renderer(flash_scene(scene), flash_settings, aim_points=scene.camera.look_at[None])
    return scene, r, flash


def person_light(r: Renderer, flash: Renderer, person: Person, t: np.ndarray) -> dict[str, torch.Tensor]:
    """F, flash nlos and nlos_ambient, summed over batches of body samples (float64)."""
    out: dict[str, torch.Tensor] = {}
    for a in range(0, len(person), BATCH):
        sl = slice(a, a + BATCH)
        part = Person(person.mesh, person.pos[sl], person.normal[sl], person.area[sl], person.albedo[sl],
                      person.closed)
        fl = flash.render(flash.spot_vector(0), part, translation=t, components=("nlos", "nlos_ambient"))
        res = {"F": r.transport_images(part, t), "flash": fl["nlos"], "amb": fl["nlos_ambient"]}
        for k, v in res.items():
            out[k] = out[k] + v.double() if k in out else v.double()
    return out


def timed_light(r, flash, body, albedo, n: int, rule: str, t) -> tuple[dict, int, float]:
    """The person light of one sampling (one batch, as a dataset sample renders it) and its time."""
    t0 = time.perf_counter()
    person = area_rule(body, albedo, n) if rule == "area" else Person.from_mesh(body, albedo, n, rule)
    fl = flash.render(flash.spot_vector(0), person, translation=t, components=("nlos", "nlos_ambient"))
    res = {"F": r.transport_images(person, t).double(), "flash": fl["nlos"].double(),
           "amb": fl["nlos_ambient"].double()}
    return res, len(person), time.perf_counter() - t0


def area_rule(body, albedo, n: int) -> Person:
    """The ``faces`` rule with sample density by area alone (no self-shadow weight)."""
    face, bary, area = face_quadrature(body.face_areas(), n)
    pos = np.einsum("ij,ijk->ik", bary, body.vertices[body.faces[face]])
    alb = np.broadcast_to(np.asarray(albedo, np.float64), (len(face), 3)).copy()
    return Person(body, pos, body.face_normals()[face], area, alb, Person.from_mesh(body, albedo, 1, "mc").closed)


def rel(a: torch.Tensor, b: torch.Tensor) -> float:
    return float((a - b).norm() / b.norm().clamp(min=1e-300))


def run_preset(name: str, args) -> None:
    cfg = PRESETS[name]
    if args.body_faces:
        cfg = dataclasses.replace(cfg, body_faces=args.body_faces)
    scene, r, flash = renderers(cfg, args.seed, args.max_spots)
    rng = np.random.default_rng([args.seed, 7])
    xy = person_positions(scene, rng, 1)[0]
    t = np.array([xy[0], xy[1], scene.hidden_region.floor_z])
    base = sample_body_params(rng, "standing")
    print(f"\n## {name}: {cfg.resolution}x{cfg.resolution}, {r.num_spots} spots x {cfg.render.spot_samples} rays, "
          f"transport {cfg.render.transport_pixel_samples}^2 sub-samples/pixel, body_faces {cfg.body_faces}, "
          f"person at ({xy[0]:.2f}, {xy[1]:.2f}) facing {base.facing_deg:.0f} deg; "
          f"reference: faces rule at {args.ref_samples} samples", flush=True)
    print(f"{'posture':10s} {'rule':6s} {'n':>6s} {'err F':>8s} {'flash':>8s} {'amb':>8s} {'s/person':>9s}")
    preset = (cfg.render.person_quadrature, cfg.render.person_samples)
    rows = [("mc", OLD_MC_SAMPLES[name]), preset, *(("faces", n) for n in args.faces_n)]
    rows = list(dict.fromkeys(rows + [("area", max(args.faces_n))] if args.faces_n else rows))
    refs = {}
    for posture in args.postures:
        params = dataclasses.replace(base, posture=posture)
        body = posed_body(params, target_faces=cfg.body_faces)
        t0 = time.perf_counter()
        ref_person = Person.from_mesh(body, params.albedo, args.ref_samples, "faces")
        refs[posture] = ref = person_light(r, flash, ref_person, t)
        t_ref = time.perf_counter() - t0
        for rule, n in rows:
            light, count, sec = timed_light(r, flash, body, params.albedo, n, rule, t)
            errs = " ".join(f"{100 * rel(light[k], ref[k]):7.2f}%" for k in ("F", "flash", "amb"))
            mark = "*" if (rule, n) == preset else " "
            print(f"{posture:10s} {rule:5s}{mark} {count:6d} {errs} {sec:9.2f}", flush=True)
        print(f"{posture:10s} {'ref':6s} {len(ref_person):6d} {'':26s} {t_ref:9.2f}", flush=True)
    if "standing" in refs:
        print(f"\nposture signal ({name}, converged): relative L2 difference from standing")
        print(f"{'posture':10s} {'F':>8s} {'flash':>8s} {'amb':>8s}")
        for posture, ref in refs.items():
            if posture != "standing":
                d = " ".join(f"{100 * rel(ref[k], refs['standing'][k]):7.2f}%" for k in ("F", "flash", "amb"))
                print(f"{posture:10s} {d}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--presets", nargs="+", default=list(PRESETS), choices=list(PRESETS))
    ap.add_argument("--postures", nargs="+", default=list(POSTURES), choices=list(POSTURES))
    ap.add_argument("--ref-samples", type=int, default=30000, help="faces-rule samples of the converged render")
    ap.add_argument("--faces-n", type=int, nargs="*", default=[1500, 4000], help="faces-rule sample counts")
    ap.add_argument("--max-spots", type=int, default=0, help="evenly spaced subset of the candidates (0: all)")
    ap.add_argument("--seed", type=int, default=0, help="room seed")
    ap.add_argument("--body-faces", type=int, default=0, help="override the presets' body_faces (0: keep)")
    ap.add_argument("--quick", action="store_true",
                    help="standing and hands_45 only, 8000-sample reference, at most 64 candidates")
    args = ap.parse_args()
    if args.quick:
        args.postures = [p for p in args.postures if p in ("standing", "hands_45")] or ["standing"]
        args.ref_samples = min(args.ref_samples, 8000)
        args.max_spots = args.max_spots or 64
    torch.set_num_threads(1)
    print(f"person light vs a converged render; {torch.get_num_threads()} torch thread(s)")
    for name in args.presets:
        run_preset(name, args)


if __name__ == "__main__":
    main()
