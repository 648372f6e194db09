"""How much light past three bounces the person adds, and how much of it ``nlos_bounce`` holds.

Per reference scene: Mitsuba 3's particle tracer renders the person minus a black person (the
``scatter`` protocol, same seeds) at ``max_depth`` 4 (our ``nlos``: P -> x_s -> body -> x_p -> C),
5, 6 and ``--tail`` (the sixth and every later bounce up to it); ours renders ``nlos`` and
``nlos_bounce`` (``render/bounce.py``, the fifth bounce both ways around the body). Prints the
fifth and sixth bounces over the fourth, ours over Mitsuba's fifth, the correlation of 4 x 4 block
means, and for everything past the fourth (up to ``--tail``): its sum over ours' fifth and the
correlation of its 4 x 4 blocks with ours' fifth (is ``nlos_bounce`` scaled a fair stand-in for
all later bounces); writes ``--out`` (text, the same lines).

    python benchmarks/bounce_mitsuba.py --spp 32768 --res 16 --out docs/results/bounce-mitsuba.txt
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.render.mitsuba_ref import mitsuba_nlos
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene


def block_corr(a: np.ndarray, b: np.ndarray, k: int = 4) -> float:
    h, w = a.shape[:2]
    blocks = lambda im: im.sum(-1).reshape(h // k, k, w // k, k).mean((1, 3)).ravel()
    return float(np.corrcoef(blocks(a), blocks(b))[0, 1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spp", type=int, default=32768)
    ap.add_argument("--res", type=int, default=16)
    ap.add_argument("--scenes", default="diffuse_corner,furniture,posed_body")
    ap.add_argument("--tail", type=int, default=6, help="deepest max_depth rendered (6 or less: no tail columns)")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    settings = RenderSettings(pixel_samples=2, transport_pixel_samples=2, spot_samples=128, person_samples=1024,
                              shadow_samples=4096, dtype="float64")
    tail = max(6, args.tail)
    lines = [f"# python benchmarks/bounce_mitsuba.py --spp {args.spp} --res {args.res} --scenes {args.scenes}"
             + (f" --tail {tail}" if tail > 6 else ""),
             "scene, fifth / fourth (Mitsuba), sixth / fourth, ours nlos / Mitsuba fourth, "
             "ours nlos_bounce / Mitsuba fifth, corr 4x4 (bounce vs fifth), corr (fifth vs fourth), "
             + (f"past the fourth to depth {tail} / ours' fifth, corr 4x4 (it vs ours' fifth), " if tail > 6 else "")
             + "seconds"]
    print(lines[-1], flush=True)
    for name in args.scenes.split(","):
        t0 = time.perf_counter()
        sc = corner_scene(name, args.res)
        r = Renderer(sc, settings, aim_points=SPOT_TARGET[None])
        person = Person.from_mesh(sc.human.mesh, sc.human.albedo, settings.person_samples)
        with torch.no_grad():
            ours = r.render(r.spot_vector(0), person, components=("nlos", "nlos_bounce"))
        n, b = ours["nlos"].numpy(), ours["nlos_bounce"].numpy()
        d = {k: mitsuba_nlos(sc, SPOT_TARGET, args.spp, seed=3, max_depth=k, protocol="scatter",
                             integrator="ptracer") for k in sorted({4, 5, 6, tail})}
        fifth, sixth, past = d[5] - d[4], d[6] - d[5], d[tail] - d[4]
        more = f"{past.sum() / b.sum():.3f}, {block_corr(b, past):.3f}, " if tail > 6 else ""
        lines.append(f"{name}, {fifth.sum() / d[4].sum():.3f}, {sixth.sum() / d[4].sum():.3f}, "
                     f"{n.sum() / d[4].sum():.3f}, {b.sum() / fifth.sum():.3f}, {block_corr(b, fifth):.3f}, "
                     f"{block_corr(fifth, d[4]):.3f}, {more}{time.perf_counter() - t0:.0f}")
        print(lines[-1], flush=True)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
