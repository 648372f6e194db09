"""Ours versus Mitsuba 3 at equal error for the ``nlos`` image.

1. A long Mitsuba render (person minus black person, ``path``, max_depth 4) is the reference.
2. Ours renders ``nlos`` (per-scene precompute timed separately); its error against the
   reference is the relative RMS error of 4x4-block means.
3. Mitsuba renders the same with other seeds at growing spp until its error is at most ours;
   the time to get there (interpolated in log-log between measured points, or extrapolated by
   error ~ spp^-1/2 when the largest spp tried is still worse) is compared with ours.

    python benchmarks/render_vs_mitsuba.py [--scene diffuse_corner] [--ref-spp 262144]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from nlos_spotlight.render.mitsuba_ref import mitsuba_nlos
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.examples import CROSSCHECK, SPOT_TARGET, corner_scene


def block_error(img: np.ndarray, ref: np.ndarray, k: int = 4) -> float:
    h, w = img.shape[:2]
    b = lambda x: x.sum(-1).reshape(h // k, k, w // k, k).mean((1, 3))
    return float(np.linalg.norm(b(img) - b(ref)) / np.linalg.norm(b(ref)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="diffuse_corner", choices=CROSSCHECK)
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--ref-spp", type=int, default=262144)
    ap.add_argument("--max-spp", type=int, default=65536)
    args = ap.parse_args()
    sc = corner_scene(args.scene, args.res)
    t = time.perf_counter()
    ref = mitsuba_nlos(sc, SPOT_TARGET, args.ref_spp, seed=1000, protocol="scatter")
    t_ref = time.perf_counter() - t
    print(f"scene {args.scene} {args.res}x{args.res}; Mitsuba reference {args.ref_spp} spp in {t_ref:.0f} s")
    settings = RenderSettings(pixel_samples=4, transport_pixel_samples=2, spot_samples=64, person_samples=512)
    t = time.perf_counter()
    r = Renderer(sc, settings, aim_points=SPOT_TARGET[None])
    t_pre = time.perf_counter() - t
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, settings.person_samples)
    r.render(r.spot_vector(0), person, components=("nlos",))  # warm-up
    t = time.perf_counter()
    ours = r.render(r.spot_vector(0), person, components=("nlos",))["nlos"].numpy()
    t_ours = time.perf_counter() - t
    e_ours = block_error(ours, ref)
    print(f"ours: {t_ours:.3f} s per image (+{t_pre:.2f} s per-scene precompute), block error {e_ours:.4f}, "
          f"total {ours.sum() / ref.sum() - 1:+.4f}")
    pts = []
    spp = 256
    mitsuba_nlos(sc, SPOT_TARGET, 64, seed=1)  # JIT warm-up
    while spp <= args.max_spp:
        t = time.perf_counter()
        img = mitsuba_nlos(sc, SPOT_TARGET, spp, seed=7, protocol="scatter")
        dt = time.perf_counter() - t
        e = block_error(img, ref)
        pts.append((spp, dt, e))
        print(f"  mitsuba {spp:7d} spp: {dt:7.2f} s, block error {e:.4f}")
        if e <= e_ours:
            break
        spp *= 2
    spp_, dt_, e_ = map(np.array, zip(*pts))
    if e_[-1] <= e_ours and len(pts) > 1:
        # log-log interpolation between the last two points
        w = (np.log(e_[-2]) - np.log(e_ours)) / (np.log(e_[-2]) - np.log(e_[-1]))
        t_mi = float(np.exp(np.log(dt_[-2]) + w * (np.log(dt_[-1]) - np.log(dt_[-2]))))
        how = "interpolated"
    elif e_[-1] <= e_ours:
        t_mi, how = float(dt_[-1]), "measured"
    else:
        t_mi, how = float(dt_[-1] * (e_[-1] / e_ours) ** 2), "extrapolated by error ~ spp^-1/2"
    print(f"Mitsuba time to ours' error: {t_mi:.1f} s ({how})")
    print(f"speed-up at equal error: {t_mi / t_ours:.0f}x per image, {t_mi / (t_ours + t_pre):.0f}x including "
          f"the per-scene precompute (goal 100x)")


if __name__ == "__main__":
    main()
