"""What the bounce's coarser body costs and saves (``RenderSettings.bounce_body_samples``): a room
model's held-out people rendered as ``nlos fit``'s shadow step renders them (``nlos_shadow`` and
``nlos_bounce``, one relay set shared as in a block), with the body's own quadrature (the
reference, first in the same run) and with n stratified body samples. Prints per n the seconds a
person, the speed-up over the reference, and the bounce's per-person relative L2 error against
the reference's; beside it the reference's own Monte Carlo noise: the relative L2 between two
relay draws (other relay offsets) over sqrt(2), the error one draw carries.

    python benchmarks/bounce_body_samples.py --model out/fits8/copyroom-near --people 8 \
        --samples 1024,512,256 --out docs/results/bounce-body-samples.txt
"""

from __future__ import annotations

import sys
import time

import numpy as np


def main() -> None:
    from nlos_spotlight.args import room_model_parser

    ap = room_model_parser(__doc__.split("\n\n")[0], people=8)
    ap.add_argument("--samples", default="1024,512,256", help="body samples to compare (comma-separated)")
    args = ap.parse_args()
    import torch

    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.fit.run import heldout_model

    torch.set_num_threads(1)  # as a shadow worker renders
    try:
        cfg, aim, builder, dcfg, idx = heldout_model(args.model, args.people)
    except NlosError as exc:
        sys.exit(f"--model: {exc}")
    counts = [int(n) for n in args.samples.split(",")]
    comps = ("nlos_shadow", "nlos_bounce")

    def render(n: int, offset: float = 0.5, components=comps) -> tuple[dict, float]:
        rs = dcfg.render_settings(shadow_samples=cfg.shadow.shadow_samples, bounce_body_samples=n)
        builder.rerender(idx[:1], rs, aim, components, [offset])  # the renderer's one-off precompute, untimed
        t0 = time.perf_counter()
        got = builder.rerender(idx, rs, aim, components, [offset] * len(idx))
        return got, (time.perf_counter() - t0) / len(idx)

    ref, t_ref = render(0)
    norm = lambda x: np.linalg.norm(x.reshape(len(x), -1), axis=1)
    b = ref["nlos_bounce"]
    other = render(0, 0.25, ("nlos_bounce",))[0]["nlos_bounce"]
    relay = norm(other - b) / norm(b) / np.sqrt(2)
    lines = [f"# python benchmarks/bounce_body_samples.py --model {args.model} --people {len(idx)} --samples {args.samples}",
             f"# {len(idx)} held-out people, one relay set; the body's own quadrature: "
             f"{len(builder._person(builder._scan_people()[1][idx[0]], 0.0)[1])} samples (the first person)",
             "body samples, seconds a person (shadow + bounce), speed-up, bounce error against the reference "
             "(median, max), the reference's relay noise (median, max)",
             f"own, {t_ref:.2f}, 1.00, 0, 0, {np.median(relay):.3f}, {relay.max():.3f}"]
    for n in counts:
        got, t = render(n)
        err = norm(got["nlos_bounce"] - b) / norm(b)
        assert np.array_equal(got["nlos_shadow"], ref["nlos_shadow"])  # the shadow term does not change
        lines.append(f"{n}, {t:.2f}, {t_ref / t:.2f}, {np.median(err):.3f}, {err.max():.3f}, "
                     f"{np.median(relay):.3f}, {relay.max():.3f}")
        print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)


if __name__ == "__main__":
    main()
