"""The drift estimate with and without the people's light in its fit: how many person directions
(``models.nuisance.person_light_basis``) ``nlos predict``'s drift fit needs.

Held-out people of a room model photographed under every capture effect at multiples of ``tripod``
(as ``benchmarks/robustness.py``'s flag check draws them); per number K of person directions (0:
the network's own projection), the seven drift directions' errors over their tolerance (mean and
standard deviation) and the flag's hit rates (``apps.drift.Drift``). The directions come from the
room model's training people, as ``nlos fit`` keeps them (``fit.train.keep_person_light``).

    python benchmarks/drift_directions.py --model out/people-curve2/copyroom-3000 --out docs/results/drift-directions.csv
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np
import torch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", type=Path, required=True, help="a finished room model (nlos fit --out)")
    ap.add_argument("--directions", default="0,1,4,8,16,32")
    ap.add_argument("--multiples", default="1,2")
    ap.add_argument("--captures", type=int, default=400)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    sys.path.insert(0, str(Path(__file__).parent))
    import robustness as R

    from nlos_spotlight.apps.drift import Drift, tolerance
    from nlos_spotlight.fit.train import room_split
    from nlos_spotlight.models.nuisance import DIRECTIONS, noise_weights, nuisance_basis, person_light_basis, project_out
    from nlos_spotlight.render.variation import draw_captures, preset
    from nlos_spotlight.train.imaging import drifted_images, form_parts, photographs

    if not (args.model / "report.json").exists():
        sys.exit(f"--model: {args.model} is not a finished room model (no report.json)")
    room = R.load_room("room", "model", args.model, 100)
    net, L, t = room.models.net, room.test.layers, room.test
    cfg = R.fit_config(args.model)
    pool = room_split(args.model, cfg, ["normals"], room.spot if cfg.shadow_samples > 0 else None).pool
    y = R.spot_vector(room, t)
    lit, amb, _ = form_parts(pool, torch.arange(min(cfg.people, pool.num_samples)), y)  # as nlos fit keeps them
    p, a = L.nominal()
    total = p + a
    proj, burst = net.nuisance, room.sensor.burst_frames
    tol = tolerance(room.models.config.variation, burst, L.f_px, L.depth_m)
    rows = []
    for k in (int(v) for v in args.directions.split(",")):
        q = person_light_basis(lit + amb, total, k).double() if k else None
        gen = torch.Generator().manual_seed(30_000)
        for m in (float(v) for v in args.multiples.split(",")):
            v = preset("tripod").capture_effects.scaled(m)
            truth, est, se = [], [], []
            for a0 in range(0, args.captures, t.num_samples):
                idx = torch.arange(min(t.num_samples, args.captures - a0))
                draw = lambda: draw_captures(v, len(idx), burst, L.f_px, L.depth_m, gen)
                pp, e = draw(), draw()
                images, empty, free = drifted_images(t, idx, y, None, v, burst, gen, draws=(pp, e))
                ph = photographs(images, empty, room.sensor, gen, True, True, metered=free)
                bg = ph.background.expand_as(ph.images).double()
                basis = nuisance_basis(bg, proj.fraction.double(), proj.relative.double())
                if q is not None:
                    basis = torch.cat([basis, bg.unsqueeze(1) * q], 1)
                _, c, e_ = project_out((ph.images - ph.background).double(), basis, noise_weights(bg, ph.clipped))
                est.append(c[:, :7].numpy())
                se.append(e_[:, :7].numpy())
                truth.append(torch.stack([pp.projector * pp.exposure / (e.projector * e.exposure) - 1,
                                          pp.ambient * pp.exposure / (e.ambient * e.exposure) - 1,
                                          pp.shift[:, 0] - e.shift[:, 0], pp.shift[:, 1] - e.shift[:, 1], pp.roll - e.roll,
                                          pp.aim[:, 0] - e.aim[:, 0], pp.aim[:, 1] - e.aim[:, 1]], 1).double().numpy())
            T, E, S = map(np.concatenate, (truth, est, se))
            err = (E - T) / tol
            beyond, judged = Drift(T, tol).flagged, Drift(E, tol, S)
            rows.append({"directions": k, "magnitude": m, "captures": len(T), "beyond": int(beyond.sum()),
                         "flagged_beyond": float(judged.flagged[beyond].mean()) if beyond.any() else "",
                         "flagged_within": float(judged.flagged[~beyond].mean()) if (~beyond).any() else "",
                         **{f"err_mean_{d}": float(err[:, i].mean()) for i, d in enumerate(DIRECTIONS)},
                         **{f"err_sd_{d}": float(err[:, i].std()) for i, d in enumerate(DIRECTIONS)}})
            r = rows[-1]
            print(f"K={k:2d} x{m:g}: flags {r['flagged_beyond']:.3f} of {r['beyond']} beyond, {r['flagged_within']:.3f} "
                  f"within; room light error {r['err_mean_ambient']:+.3f} +- {r['err_sd_ambient']:.3f} of its tolerance",
                  flush=True)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with args.out.open("w", newline="") as f:
            w = csv.DictWriter(f, list(rows[0]))
            w.writeheader()
            w.writerows({k: (f"{v:.4f}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows)
        args.out.with_suffix(".json").write_text(json.dumps({"argv": sys.argv[1:], "model": str(args.model)}, indent=1))


if __name__ == "__main__":
    main()
