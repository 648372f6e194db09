"""Time one 64x64 image (all components) for one person and one spot after the per-scene precompute.

Prints the precompute time, the per-image time of DESIGN section 5's five components and its ratio
to the 50 ms goal (the person's pairs in compiled loops, ``RenderSettings.pair_loops``, the default;
and in torch, eager or fused by torch.compile, ``RenderSettings.fuse``, compiled during the warm-up),
the one-off interreflection of a spot (kept per candidate after its first use, so the timed
images, which keep the warm-up's spot, read it), the per-image time of the slow reference
implementation on the same samples (measured in this
run, on a smaller image), and peak memory (RSS; CUDA peak when on a GPU).

    python benchmarks/render_speed.py [--res 64] [--repeats 5]
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import time

import torch

from nlos_spotlight.render.person import Person
from nlos_spotlight.render.reference import reference_person_terms
from nlos_spotlight.render.transport import COMPONENTS, RENDER_PRESETS, Renderer, RenderSettings
from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene

GOAL_S = 0.050
TIMED = tuple(c for c in COMPONENTS if c != "nlos_shadow")
"""The components of the goal (DESIGN section 5's five); the optional shadow term is timed apart."""


def rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def time_image(sc, settings: RenderSettings, repeats: int):
    """Median seconds per all-component image after precompute, the precompute time, and the nlos image."""
    t = time.perf_counter()
    r = Renderer(sc, settings)  # every face is a candidate, as in training
    t_pre = time.perf_counter() - t
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, settings.person_samples)
    y = r.spot_vector(int(((r.aim_points - SPOT_TARGET) ** 2).sum(1).argmin()))
    with torch.no_grad():  # what generation and evaluation do; fused kernels serve only such calls
        return _time_image(r, y, person, repeats, t_pre)


def _time_image(r, y, person, repeats: int, t_pre: float):
    r.render(y, person, components=TIMED)  # warm-up (and the fused kernels' compilation)
    r.render(y, person, translation=[0.1, 0.1], components=TIMED)
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = r.render(y, person, translation=[0.1, 0.1], components=TIMED)
        times.append(time.perf_counter() - t)
    return sorted(times)[len(times) // 2], t_pre, out["nlos"], r


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    sc = corner_scene("example", args.res)
    rss0 = rss_mb()
    fast = RENDER_PRESETS["fast"]
    torch_k = dict(pair_loops=False)  # the person's pairs in torch (eager, or fused by torch.compile)
    presets = {"default": RenderSettings(), "fast": fast,
               "default, torch": RenderSettings(**torch_k), "fast, torch": dataclasses.replace(fast, **torch_k),
               "default, torch.compile": RenderSettings(fuse=True, **torch_k),
               "fast, torch.compile": dataclasses.replace(fast, fuse=True, **torch_k)}
    results = {}
    for name, settings in presets.items():
        per_image, t_pre, nlos, r = time_image(sc, settings, args.repeats)
        results[name] = nlos
        print(f"[{name}] device {r.device}, {torch.get_num_threads()} threads; {r.num_spots} candidate faces; "
              f"{args.res}x{args.res}; transport {settings.transport_pixel_samples}^2 sub-samples/pixel, "
              f"{settings.person_samples} body samples, {settings.spot_samples} spot rays")
        print(f"[{name}] precompute (D for all candidates, ambient, spot samples): {t_pre:.2f} s")
        print(f"[{name}] one image, all components, median of {args.repeats}: {per_image * 1e3:.1f} ms "
              f"(goal 50 ms: ratio {per_image / GOAL_S:.2f}x; goal {'met' if per_image <= GOAL_S else 'NOT met'})")
        with torch.no_grad():  # kept per candidate after its first use (the warm-up renders the same spot)
            t = time.perf_counter()
            r._interreflection_sum(r.spot_vector(int(r.spot_landed.argmax())))
        print(f"[{name}] interreflection of a spot at its first use (then kept): "
              f"{(time.perf_counter() - t) * 1e3:.0f} ms")
        if name == "default":
            with torch.no_grad():
                t = time.perf_counter()
                r.render(r.spot_vector(int(r.spot_landed.argmax())), Person.from_mesh(
                    sc.human.mesh, sc.human.albedo, settings.person_samples), components=("nlos_shadow",))
            print(f"[{name}] the optional nlos_shadow term ({settings.shadow_samples} static samples, first call "
                  f"with its set-up): {(time.perf_counter() - t) * 1e3:.0f} ms")
    a, b = results["fast"], results["default"]
    print(f"fast vs default nlos: total {float(a.sum() / b.sum()) - 1:+.4f}, "
          f"pixel correlation {float(torch.corrcoef(torch.stack([a.sum(-1).flatten(), b.sum(-1).flatten()]))[0, 1]):.4f}")
    # the slow reference on the same kind of samples, at 16x16, for a same-run ratio
    small = corner_scene("example", 16)
    rs = Renderer(small, RenderSettings(transport_pixel_samples=1, person_samples=128, spot_samples=16),
                  aim_points=SPOT_TARGET[None])
    ps = Person.from_mesh(small.human.mesh, small.human.albedo, 128)
    t = time.perf_counter()
    rs.render(rs.spot_vector(0), ps, components=("nlos", "nlos_ambient"))
    t_fast = time.perf_counter() - t
    t = time.perf_counter()
    reference_person_terms(rs, rs.spot_vector(0), ps, None)
    t_slow = time.perf_counter() - t
    print(f"person terms at 16x16, 128 body samples: fast {t_fast * 1e3:.1f} ms, slow reference "
          f"{t_slow * 1e3:.0f} ms (speed-up {t_slow / t_fast:.0f}x)")
    peak = torch.cuda.max_memory_allocated() / 2**20 if torch.cuda.is_available() else None
    print(f"peak RSS {rss_mb():.0f} MB (+{rss_mb() - rss0:.0f} MB for the renderers)"
          + (f", CUDA peak {peak:.0f} MB" if peak is not None else ""))


if __name__ == "__main__":
    main()
