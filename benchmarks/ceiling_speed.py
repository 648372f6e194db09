"""What the room's ceiling costs (``fit/ceiling.py``): its derivatives by :func:`jacobian` (the albedo
columns from the light's linearity, one render at albedo 0, one sampled body for the floor steps: 10 renders a posture) and by
:func:`jacobian_reference` (every column two renders: 15), on a finished room model's first held-out
people, as ``room_ceiling`` computes them. The two run interleaved in the same process; prints the
seconds a person of each, their ratio, and the largest relative difference of the derivatives.

    python benchmarks/ceiling_speed.py --model out/fits11/copyroom-default --people 2 \
        --out docs/results/ceiling-speed.txt
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np


def main() -> None:
    from nlos_spotlight.args import room_model_parser

    args = room_model_parser(__doc__.split("\n\n")[0], people=2).parse_args()
    import torch

    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.fit.ceiling import jacobian, jacobian_reference, light_renderer, person_light
    from nlos_spotlight.fit.run import heldout_model
    from nlos_spotlight.render.settings import resolve_device
    from nlos_spotlight.world.body import POSTURES

    try:
        cfg, aim, builder, dcfg, people = heldout_model(args.model, args.people)
    except NlosError as exc:
        raise SystemExit(f"error: {exc}") from None
    room, specs = builder._scan_people()
    settings = dcfg.render_settings(device=resolve_device(cfg.render_device))
    r, y = light_renderer(room, settings, cfg.light, {"aim": aim})
    seconds = {"jacobian": 0.0, "reference": 0.0}
    worst = 0.0
    for i in people:
        base, t = specs[i]["params"], np.array([*specs[i]["position"], room.hidden_region.floor_z])
        for q in POSTURES:
            params = dataclasses.replace(base, posture=q)
            t0 = time.perf_counter()
            mu = person_light(r, y, params, t, dcfg)
            fast = jacobian(r, y, params, t, dcfg, mu)
            t1 = time.perf_counter()
            person_light(r, y, params, t, dcfg)  # the ceiling renders the light either way
            ref = jacobian_reference(r, y, params, t, dcfg)
            t2 = time.perf_counter()
            seconds["jacobian"] += t1 - t0
            seconds["reference"] += t2 - t1
            scale = ref.abs().amax(0).clamp(min=1e-30)
            worst = max(worst, float(((fast - ref).abs().amax(0) / scale).max()))
    n = len(people)
    lines = [f"room model {args.model}: {n} held-out people x {len(POSTURES)} postures, "
             f"{torch.get_num_threads()} torch threads",
             f"ceiling renders: {seconds['jacobian'] / n:.1f} s a person (jacobian, 10 renders a posture), "
             f"{seconds['reference'] / n:.1f} s (jacobian_reference, 15): ratio "
             f"{seconds['reference'] / seconds['jacobian']:.2f}x",
             f"largest difference of a derivative column over its largest value: {worst:.2e}"]
    print("\n".join(lines))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
