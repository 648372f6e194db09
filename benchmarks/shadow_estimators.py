"""The ``nlos_shadow`` estimator at the fit's and the camera photographs' settings: bias and noise.

For a few of a room model's people, the shadow (the spot light the body blocks) is rendered with
several independent draws (relay strata offsets and pixel slot offsets) at each setting: pixel
footprint n x n and relay points m. Per setting and person: one draw's relative L2 from the
setting's own mean (its Monte Carlo noise), the mean's relative L2 from the reference setting's
mean, and the standard error that noise alone would give that distance (so a distance well above
it is a bias of one of the two settings). Writes ``--out`` (CSV) and a JSON of the run beside it.

    python benchmarks/shadow_estimators.py out/fits3/copyroom --out docs/results/shadow-estimators.csv
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

SETTINGS = {"f8-4096": (8, 4096, 8), "f16-8192": (16, 8192, 4), "f8-8192": (8, 8192, 4), "f16-4096": (16, 4096, 4),
            "f4-4096": (4, 4096, 4)}
"""Name -> (pixel footprint, relay points, draws); the first is the reference (the fit's)."""


def draws(builder, base, aim: np.ndarray, people: list[int], footprint: int, relay: int, count: int) -> np.ndarray:
    """(count, people, H, W, 3): independent draws (relay offsets (k + 1/2) / count, footprint seeds)."""
    out = []
    for k in range(count):
        s = dataclasses.replace(base, pixel_footprint=footprint, shadow_samples=relay, footprint_seed=100 + k)
        out.append(builder.rerender(people, s, aim, ("nlos_shadow",), [(k + 0.5) / count] * len(people))["nlos_shadow"])
    return np.stack(out)


def main(argv=None) -> int:
    from nlos_spotlight.fit.run import finished_model
    from nlos_spotlight.render.settings import RenderSettings

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model", type=Path, help="a room model directory (nlos fit --out)")
    ap.add_argument("--people", default="30,1500", help="dataset sample indices")
    ap.add_argument("--out", required=True, type=Path, help="CSV to write")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    cfg, aim, builder, dcfg = finished_model(args.model)
    people = [int(p) for p in args.people.split(",")]
    base = RenderSettings(pixel_samples=dcfg.render.pixel_samples, spot_samples=dcfg.render.spot_samples,
                          person_samples=dcfg.render.person_samples, device="cpu")
    got, seconds = {}, {}
    for name, (f, m, n) in SETTINGS.items():
        t0 = time.perf_counter()
        got[name] = draws(builder, base, aim, people, f, m, n)
        seconds[name] = (time.perf_counter() - t0) / (n * len(people))
        print(f"{name}: {seconds[name]:.2f} s a draw", flush=True)
    ref_name = next(iter(SETTINGS))
    ref = got[ref_name]
    rows = []
    for name, a in got.items():
        for p in range(len(people)):
            mean, rmean = a[:, p].mean(0), ref[:, p].mean(0)
            scale = np.linalg.norm(rmean)
            noise = float(np.mean([np.linalg.norm(x - mean) for x in a[:, p]]) / np.linalg.norm(mean))
            ref_noise = float(np.mean([np.linalg.norm(x - rmean) for x in ref[:, p]]) / scale)
            # noise alone: each mean's error is about one draw's over sqrt(draws - 1) (deviations from its own mean)
            expect = float(np.hypot(noise * np.linalg.norm(mean) / np.sqrt(max(len(a) - 1, 1)),
                                    ref_noise * scale / np.sqrt(len(ref) - 1)) / scale) if name != ref_name else 0.0
            rows.append({"setting": name, "footprint": SETTINGS[name][0], "relay_points": SETTINGS[name][1],
                         "draws": len(a), "person": people[p], "one_draw_noise": noise,
                         "mean_vs_reference": float(np.linalg.norm(mean - rmean) / scale), "noise_only_expected": expect,
                         "sum_ratio": float(mean.sum() / rmean.sum()), "seconds_per_draw": seconds[name]})
            r = rows[-1]
            print(f"{name:9s} person {people[p]}: one draw {noise:.3f} from its mean; mean {r['mean_vs_reference']:.3f} "
                  f"from {ref_name}'s (noise alone ~{expect:.3f}); sum ratio {r['sum_ratio']:.3f}", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]))
        w.writeheader()
        w.writerows({k: (f"{v:.4f}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows)
    from nlos_spotlight.data.generate import versions

    args.out.with_suffix(".json").write_text(json.dumps({"argv": sys.argv[1:], "settings": SETTINGS,
                                                         "versions": versions()}, indent=1))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
