"""How noisy ``nlos_bounce`` is: the same held-out people of a room model rendered with two relay
offsets (``RenderSettings.relay_offset``), with and without the relayed legs' distance floor
(``render.bounce.NEAR_FIELD``). Prints, per floor, the per-person relative L2 between the two draws,
their sums and the brightest pixel over the median one; and the floor's share of the light.

    python benchmarks/bounce_relay_spread.py --model out/people-curve2/copyroom-3000 --people 12 \
        --out docs/results/bounce-relay-spread.txt
"""

from __future__ import annotations

import sys
import time

import numpy as np


def main() -> None:
    from nlos_spotlight.args import room_model_parser

    args = room_model_parser(__doc__.split("\n\n")[0], people=12).parse_args()
    import nlos_spotlight.render.bounce as bounce
    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.fit.run import heldout_model

    try:
        cfg, aim, builder, dcfg, idx = heldout_model(args.model, args.people)
    except NlosError as exc:
        sys.exit(f"--model: {exc}")
    floor = bounce.NEAR_FIELD
    lines = [f"# python benchmarks/bounce_relay_spread.py --model {args.model} --people {len(idx)}",
             "near_field (relay spacings), relative L2 between two relay offsets per person (median, max), "
             "sums of the two draws, brightest pixel / median pixel, seconds"]
    print(lines[-1], flush=True)
    got = {}
    try:
        spreads(args, bounce, builder, dcfg, idx, aim, floor, got, lines)
    finally:
        bounce.NEAR_FIELD = floor
    lines.append(f"# the floor keeps {got[floor].sum() / got[0.0].sum():.3f} of the light (first offset)")
    print(lines[-1])
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")


def spreads(args, bounce, builder, dcfg, idx, aim, floor, got, lines) -> None:
    """Both draws without and with the floor; a line each."""
    from nlos_spotlight.render.settings import RenderSettings

    for near in (0.0, floor):
        bounce.NEAR_FIELD = near
        draws, t0 = [], time.perf_counter()
        for off in (0.5, 0.25):
            rs = RenderSettings(pixel_samples=dcfg.render.pixel_samples, pixel_footprint=8, footprint_jitter=True,
                                spot_samples=dcfg.render.spot_samples, person_samples=dcfg.render.person_samples,
                                shadow_samples=4096, footprint_seed=12345, relay_offset=off, device="cpu")
            draws.append(builder.rerender(idx, rs, aim, ("nlos_bounce",), one_footprint=True)["nlos_bounce"])
        a, b = draws
        got[near] = a
        n = len(a)
        spread = np.linalg.norm((a - b).reshape(n, -1), axis=1) / np.linalg.norm(((a + b) / 2).reshape(n, -1), axis=1)
        lines.append(f"{near:g}, {np.median(spread):.3f}, {spread.max():.3f}, {a.sum():.4g}, {b.sum():.4g}, "
                     f"{a.max() / max(np.median(np.abs(a)), 1e-300):.3g}, {time.perf_counter() - t0:.0f}")
        print(lines[-1], flush=True)


if __name__ == "__main__":
    main()
