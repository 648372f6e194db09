"""How fast the person's light converges over a pixel's footprint, by brute force and by footprint
sampling, in a fitted room (speed and fidelity; ``RenderSettings.pixel_footprint``).

For a few of a room model's people under its spot: ``nlos`` at n x n sub-samples a pixel that each
see the whole body (n = 1: the pixel's centre, the recipe before), against the 8 x 8 brute-force
render; footprint sampling at n x n (the body samples shared out among the sub-samples) at two
pixel-offset seeds: its noise (half their difference) and its distance to the 8 x 8 render; and
``nlos_shadow`` the same way at the fit's and twice the fit's relay points. Seconds a person on one
thread, in the same run. Writes ``--out`` (CSV: term, method, n, samples, seconds_per_person,
rel_to_brute8, noise) and a JSON of the run beside it.

    python benchmarks/pixel_footprint.py out/fits/copyroom --out docs/results/pixel-footprint.csv
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch


def main(argv=None) -> int:
    from nlos_spotlight.fit.run import finished_model
    from nlos_spotlight.render.settings import RenderSettings

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model", type=Path, help="a fitted room model (its people and spot)")
    ap.add_argument("--people", type=int, default=4, help="people rendered (default 4)")
    ap.add_argument("--out", required=True, type=Path, help="CSV to write")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    cfg, aim, builder, dcfg = finished_model(args.model)
    idx = list(range(cfg.transport_people, cfg.transport_people + args.people))
    base = RenderSettings(pixel_samples=dcfg.render.pixel_samples, transport_pixel_samples=1, spot_samples=dcfg.render.spot_samples,
                          person_samples=dcfg.render.person_samples, device="cpu")
    builder.rerender(idx[:1], base, aim, ("nlos",))  # compile the loops before timing

    def run(term, seed=None, **kw):
        if seed is not None:
            kw["footprint_seed"] = seed
        t0 = time.perf_counter()
        img = builder.rerender(idx, dataclasses.replace(base, **kw), aim, (term,))[term]
        return img, (time.perf_counter() - t0) / len(idx)

    rel = lambda a, b: float(np.mean([np.linalg.norm(x - y) / np.linalg.norm(y) for x, y in zip(a, b)]))
    rows = []
    brute = {n: run("nlos", transport_pixel_samples=n) for n in (1, 2, 4, 8)}
    ref = brute[8][0]
    for n, (img, s) in brute.items():
        rows.append(("nlos", "brute", n, dcfg.render.person_samples, s, rel(img, ref), 0.0))
    for n in (8, 16):
        (a, s), (b, _) = (run("nlos", seed, pixel_footprint=n) for seed in (1, 2))
        rows.append(("nlos", "footprint", n, dcfg.render.person_samples, s, rel(a, ref),
                     rel((a - b) / np.sqrt(2) + ref, ref)))
    sh_ref, _ = run("nlos_shadow", transport_pixel_samples=2, shadow_samples=2 * 4096)
    for m in (4096, 2 * 4096):
        (a, s), (b, _) = (run("nlos_shadow", seed, pixel_footprint=8, shadow_samples=m) for seed in (1, 2))
        rows.append(("nlos_shadow", "footprint", 8, m, s, rel(a, sh_ref), rel((a - b) / np.sqrt(2) + sh_ref, sh_ref)))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["term", "method", "n", "samples", "seconds_per_person", "rel_to_brute8", "noise"])
        for r in rows:
            w.writerow([*r[:4], f"{r[4]:.3f}", f"{r[5]:.4f}", f"{r[6]:.4f}"])
            print(f"{r[0]:12s} {r[1]:9s} {r[2]:2d}x{r[2]:<2d} samples {r[3]:5d}  {r[4]:6.2f} s/person  "
                  f"{100 * r[5]:5.1f}% from 8 x 8 brute force (shadow: 2 x 2 at 8,192)  noise {100 * r[6]:4.1f}%")
    from nlos_spotlight.data.generate import versions

    args.out.with_suffix(".json").write_text(json.dumps({"argv": sys.argv[1:], "people": idx,
                                                          "versions": versions()}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
