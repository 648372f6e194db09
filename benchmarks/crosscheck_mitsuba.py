"""Full cross-check of the ``nlos`` component against Mitsuba 3 on the five reference scenes.

Prints, per scene and protocol, the relative error of the total and the correlation of
4x4-block means, for a long Mitsuba render:

* ``scatter`` (person minus a black person): against ``nlos``;
* ``blocked`` (black person minus no person): against ``nlos_shadow``;
* ``presence`` (with minus without the person, what background subtraction sees): against
  ``nlos + nlos_shadow``, and in the last column the error of ``nlos`` alone.

    python benchmarks/crosscheck_mitsuba.py --spp 262144 --res 32

``--integrator ptracer`` uses Mitsuba's particle tracer instead of its camera-side path tracer, and
``--seeds`` repeats the Mitsuba render at several seeds (their spread is its Monte Carlo noise):

    python benchmarks/crosscheck_mitsuba.py --scenes diffuse_corner --protocols blocked --spp 8192 \
        --seeds 5,6 --integrator path     # then --integrator ptracer
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from nlos_spotlight.render.mitsuba_ref import mitsuba_nlos
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.examples import CROSSCHECK, SPOT_TARGET, corner_scene


def block_corr(a: np.ndarray, b: np.ndarray, k: int = 4) -> float:
    h, w = a.shape[:2]
    blocks = lambda im: im.sum(-1).reshape(h // k, k, w // k, k).mean((1, 3)).ravel()
    return float(np.corrcoef(blocks(a), blocks(b))[0, 1])


def ours_nlos(kind: str, res: int, person_samples: int = 2048, spot_samples: int = 1024) -> dict[str, np.ndarray]:
    """Our ``nlos`` and ``nlos_shadow`` images of a reference scene, and the protocols' counterparts."""
    sc = corner_scene(kind, res)
    r = Renderer(sc, RenderSettings(pixel_samples=4, transport_pixel_samples=4, spot_samples=spot_samples,
                                    person_samples=person_samples, dtype="float64"), aim_points=SPOT_TARGET[None])
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, person_samples)
    out = r.render(r.spot_vector(0), person, components=("nlos", "nlos_shadow"))
    nlos, shadow = out["nlos"].numpy(), out["nlos_shadow"].numpy()
    return {"scatter": nlos, "blocked": shadow, "presence": nlos + shadow}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spp", type=int, default=262144)
    ap.add_argument("--res", type=int, default=32)
    ap.add_argument("--scenes", default=",".join(CROSSCHECK))
    ap.add_argument("--protocols", default="presence,scatter,blocked")
    ap.add_argument("--integrator", default="path", choices=("path", "ptracer"), help="Mitsuba's integrator")
    ap.add_argument("--seeds", default="1", help="Mitsuba seeds, comma-separated: one row each")
    args = ap.parse_args()
    print(f"{args.integrator}, {args.spp} samples a pixel")
    print(f"{'scene':16s} {'protocol':9s} {'seed':>4s} {'ours':>10s} {'mitsuba':>10s} {'rel.err':>8s} {'corr4x4':>8s} "
          f"{'t_mi[s]':>8s} {'nlos only':>9s}")
    with torch.no_grad():
        for kind in args.scenes.split(","):
            images, scene = ours_nlos(kind, args.res), corner_scene(kind, args.res)
            for proto in args.protocols.split(","):
                ours = images[proto]
                for seed in (int(v) for v in args.seeds.split(",")):
                    t = time.perf_counter()
                    ref = mitsuba_nlos(scene, SPOT_TARGET, args.spp, seed=seed, protocol=proto,
                                       integrator=args.integrator)
                    dt = time.perf_counter() - t
                    rel = ours.sum() / ref.sum() - 1
                    alone = f"{images['scatter'].sum() / ref.sum() - 1:+9.4f}" if proto == "presence" else ""
                    print(f"{kind:16s} {proto:9s} {seed:4d} {ours.sum():10.5g} {ref.sum():10.5g} {rel:+8.4f} "
                          f"{block_corr(ours, ref):8.4f} {dt:8.1f} {alone}", flush=True)


if __name__ == "__main__":
    main()
