"""The drift estimate with and without the people's light in its fit: how many person directions
(``models.nuisance.person_light_basis``) ``nlos predict``'s drift fit needs.

Held-out people of a room model photographed under every capture effect at multiples of ``tripod``
(as ``benchmarks/robustness.py``'s flag check draws them); per number K of person directions (0:
the network's own projection), the seven drift directions' errors over their tolerance (mean and
standard deviation) and the flag's hit rates (``apps.drift.Drift``), estimated as ``nlos predict``
estimates them (``NuisanceProjection.drift``). The directions come from the
room model's training people, as ``nlos fit`` keeps them (``fit.train.keep_person_light``).

    python benchmarks/drift_directions.py --model out/people-curve2/copyroom-3000 --out docs/results/drift-directions.csv
"""

from __future__ import annotations

import argparse
import copy
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
    from nlos_spotlight.models.nuisance import DIRECTIONS, person_light_basis
    from nlos_spotlight.train.imaging import form_parts

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
    proj = copy.deepcopy(net.nuisance)  # its person directions swapped per K; the model's own untouched
    tol = tolerance(room.models.config.variation, room.sensor.burst_frames, L.f_px, L.depth_m)
    rows = []
    for k in (int(v) for v in args.directions.split(",")):
        if k:
            proj.set_person(person_light_basis(lit + amb, total, k))
        else:
            proj.person = torch.zeros(0)  # the network's own projection (``NuisanceProjection.drift``)
        gen = torch.Generator().manual_seed(30_000)
        for m in (float(v) for v in args.multiples.split(",")):
            truth, est, se = [], [], []
            for ph, drawn in R.drifted_captures(room, m, args.captures, gen):
                with torch.no_grad():
                    c, e_ = proj.drift(ph.images - ph.background, ph.background, ph.clipped)
                est.append(c.double().numpy())
                se.append(e_.double().numpy())
                truth.append(drawn)
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
