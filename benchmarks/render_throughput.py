"""People per second of ``nlos fit``'s image samples, one room, on 1 and 2 CPU cores (and a GPU).

``nlos fit`` renders its people as ``workers`` processes of one thread each. This runs that: W
processes (W = 1, 2: one per core) each render ``--people`` image samples of a real scan's fit at
the fit's settings (``FitConfig`` defaults: 32 x 32 pixels, an 8 x 8 pixel footprint, 1,500-face
bodies of about 2,000 samples, K = 10 stored spots, the flash and ``nlos_ambient`` through one
person -> pixel pass, as ``SceneBuilder._image_sample``), started together after each has built its
renderer; people/s = all their people over the wall time. The people are the fit's draws (the
room model's ``SceneBuilder``), posed once here and handed to every run, so every row renders the
same people. Each path runs ``--repeats`` times, interleaved with the others; the median is kept
(this machine's speed wanders by a third from run to run).

The reference, measured in the same run on the same people: the per-person path as it was before
this benchmark: numba's ``omp`` threading layer and the parallel pair loops at any thread count (its
idle threads spin between the loops' calls; now a one-thread process runs serial twins,
``render/pair_loops.py``), embreex for the rays (one at a time; now Dr.Jit's array ray tests,
``render/rays_drjit.py``). One thing of the old path is not
put back: embreex's batches of 65,536 rays or more used every core whatever the process's thread
budget (``render/rays._workers`` now follows torch's), so a one-process run was not one core and two
processes oversubscribed two; both paths here keep to one thread a process, which favours the
reference. On a machine with a CUDA GPU one more row renders in one process
on the GPU (``device='cuda'``, Dr.Jit's OptiX rays when Mitsuba is installed) against that
machine's one-core reference.

Each run also counts today's path's shadow rays (``render.rays.TALLY``): rays a person, the share
of its time spent in the ray engine and that engine's rays per second, and so the most an exact
renderer casting the same rays could reach on a core if everything else were free (printed, and
``ray_budget`` in the .json): the bound that says whether a speed goal needs fewer rays or only
faster code around them. One person's rays are then tested again against the room alone and the
body alone (``ray_split``): what each blocks, what each costs, and the bound were the room's static
visibility cached for free (the body's own tests left).

Writes ``--out`` (default ``docs/results/render-throughput.csv``: ``device,threads,people_per_s,
reference_people_per_s,ratio``) and, beside it, the same with the machine and settings (``.json``).

    python benchmarks/render_throughput.py [--config benchmarks/configs/rooms/copyroom.yaml]
        [--people 16] [--cores 1,2] [--repeats 3] [--shadow] [--out CSV]

``--shadow`` times what the fit's shadow step renders instead: each person's ``nlos_shadow`` and
``nlos_bounce`` at ``FitConfig``'s relay points, bounce body samples and shadow depth, under one
spot, the room's later relays and one relay set built before the timing (the fit's people share a
set twelve or thirteen at a time; the set's first person, who casts its static visibility, is timed
apart and written to the .json). Its reference is the step before its legs and the bounce's body <->
relay exchange ran as compiled loops over every group at once (:data:`SHADOW_PATHS`):
``docs/results/render-throughput-shadow.csv``.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import multiprocessing as mp
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PATHS = {"new": (None, "auto", ""), "reference": ("omp", "embree", "loops"), "new-embree": (None, "embree", "")}
"""(numba threading layer, ``RenderSettings.rays``, legacy) of each measured path of the image
samples (None: the package's choice): today's defaults, the path before them, and today's loops
with the old rays (the changes apart; in the .json only). ``legacy``: what :func:`_legacy` puts back."""
SHADOW_PATHS = {"new": (None, "auto", ""), "reference": (None, "auto", "relay")}
"""The same for ``--shadow``: today's shadow step, and the step before its legs and the bounce's
body <-> relay exchange ran as compiled loops over every group at once (``legacy`` ``relay``)."""


def _legacy(which: str) -> None:
    """Put back, in this process, code paths the package kept as references: ``loops``: the loops as
    before (``pair_loops.PARALLEL`` at any thread count) and the shadow's torch crossing test and
    second leg (``render/shadow.py``'s references); ``relay``: the shadow's compiled leg group by group
    and chunk by chunk, and the bounce's body <-> relay exchange as torch blocks."""
    from nlos_spotlight.render import bounce, pair_loops, shadow

    if which in ("loops", "relay"):
        shadow.SpotShadow.flat_groups = lambda self: None
        bounce.LOOP_PAIRS = 0
    if which == "loops":
        pair_loops.SERIAL = pair_loops.PARALLEL
        shadow.cross_box = shadow.segments_cross_box
        shadow.SpotShadow._second_leg_loops = shadow.SpotShadow._second_leg


def build_room(config: str, work: Path):
    """The fit's room saved under ``work`` and its ``SceneBuilder`` (the fit's people draws)."""
    from nlos_spotlight.args import parse_numbers
    from nlos_spotlight.config_file import load_room_config
    from nlos_spotlight.fit.config import FitConfig
    from nlos_spotlight.fit.room import room_setup
    from nlos_spotlight.fit.run import room_builder
    from nlos_spotlight.scene.io import save_scene

    rc = load_room_config(config)
    cfg = FitConfig()
    point = {k: parse_numbers(rc[k], "X,Y,Z", k).tolist() if k in rc else None
             for k in ("camera_position", "camera_look_at", "projector_position")}
    s = room_setup(rc["room"], cfg.resolution, point["camera_position"], point["camera_look_at"],
                   point["projector_position"], rc.get("hidden_region"), rc.get("up"))
    save_scene(s.scene, work / "room")
    sb, dcfg = room_builder(work, cfg)
    return sb, dcfg


def people(sb, n: int) -> list:
    """``n`` of the fit's image-sample people, posed: (Person, translation (3,))."""
    room, specs = sb._scan_people()
    floor_z = room.hidden_region.floor_z
    first = sb.cfg.transport_samples_per_scene
    return [sb._person(spec, floor_z)[1:] for spec in specs[first:first + n]]


def _renderer(room_dir: str, dcfg, spots, shadow: bool, device: str = "cpu", rays: str = "auto"):
    """The renderer a run times and its call for one person: (renderer, render(person, translation,
    relay_offset)). Image samples: the fit's K spots, the flash and ``nlos_ambient`` through one
    person -> pixel pass; ``shadow``: what the fit's shadow step renders of a person under the
    first spot (its settings and components; ``relay_offset`` picks the relay set)."""
    import torch

    from nlos_spotlight.data.flash import FLASH_SPOT_SAMPLES, flash_scene
    from nlos_spotlight.fit.config import FitConfig
    from nlos_spotlight.render.surface import StaticSurfaces
    from nlos_spotlight.render.transport import Renderer
    from nlos_spotlight.scene.io import load_scene
    from nlos_spotlight.scene.los import los_mesh

    scene = load_scene(room_dir)
    surfaces = StaticSurfaces(scene)
    los = los_mesh(surfaces.mesh, surfaces.engine, scene.camera, dcfg.los_vertices)
    fc = FitConfig()
    settings = dcfg.render_settings(device=device, rays=rays)
    if shadow:
        from nlos_spotlight.fit.shadow import components
        from nlos_spotlight.render.settings import RenderSettings

        settings = RenderSettings.of(dcfg.render, fc.shadow, device=device, rays=rays)  # as the fit's shadow step
        r = Renderer(scene, settings, aim_points=los.centroids()[spots[:1]])
        y, comps = r.spot_vector(0), components(fc)
        return r, lambda person, tr, offset=0.25: r.render(y, person, torch.as_tensor(tr), comps, relay_offset=offset)
    r = Renderer(scene, settings, aim_points=los.centroids())
    flash = Renderer(flash_scene(scene), dataclasses.replace(settings, spot_samples=settings.spot_samples
                                                             * FLASH_SPOT_SAMPLES), aim_points=scene.camera.look_at[None])
    return r, lambda person, tr, offset=None: r.transport_images(person, tr, spots, also=(flash,), nlos_ambient=True)


def _worker(room_dir: str, dcfg, people, spots, device: str, rays: str, legacy: str, shadow: bool, barrier,
            queue) -> None:
    """Build the renderer, wait for the others, render every person (their image samples, or with
    ``shadow`` what the fit's shadow step renders of them under the first spot, one relay set: put
    also the seconds of that set's first person, who pays for the set's static visibility); put
    the seconds, the people and this process's ray tally."""
    import torch

    from nlos_spotlight.render.rays import TALLY

    torch.set_num_threads(1)
    if legacy:
        _legacy(legacy)
    r, render = _renderer(room_dir, dcfg, spots, shadow, device, rays)
    first = {}
    with torch.no_grad():
        render(*people[0], 0.5)  # warm-up (the shadow step: the room's light and one relay set)
        barrier.wait()
        if shadow:
            t = time.perf_counter()
            render(*people[0], 0.25)  # a new relay set
            first = {"first": time.perf_counter() - t}
        TALLY.reset()
        t = time.perf_counter()
        for person, tr in people:
            render(person, tr)
        if device == "cuda":
            torch.cuda.synchronize()
    queue.put({"seconds": time.perf_counter() - t, "people": len(people), **first, **_tally()})


def _split_worker(room_dir: str, dcfg, people, spots, shadow: bool, queue) -> None:
    """Put what blocks one person's shadow rays (its image samples, or with ``shadow`` the shadow
    step's render): the share of rays the room's static mesh blocks, the body blocks, and both; and
    the engine's seconds on those rays against the room and body together (as rendered), the room
    alone and the body alone (the best of 3 each, one thread)."""
    import torch

    from nlos_spotlight.render.rays import TALLY, SceneRays

    torch.set_num_threads(1)
    person, tr = people[0]
    r, render = _renderer(room_dir, dcfg, spots, shadow)
    with torch.no_grad():
        render(person, tr, 0.5)  # warm-up: the loops compiled, the room's precompute done
        render(person, tr)
        TALLY.keep = []
        render(person, tr)
    calls, TALLY.keep = TALLY.keep, None
    mesh = person.translated_mesh(np.asarray(tr, np.float64))
    static = r.rays
    engines = {"both": SceneRays(static, mesh).joined, "static": static, "body": type(static)(mesh.vertices, mesh.faces)}
    out = {"rays": int(sum(len(c[0]) for c in calls))}
    for name, engine in engines.items():
        best = np.inf
        for _ in range(3):
            t = time.perf_counter()
            hits = [engine.occluded_rays(o, d, length) for o, d, length in calls]
            best = min(best, time.perf_counter() - t)
        out[f"{name}_seconds"], out[f"{name}_blocked"] = best, int(sum(h.sum() for h in hits)) / out["rays"]
    queue.put(out)


def ray_split(room_dir: Path, dcfg, people, spots, shadow: bool) -> dict:
    """:func:`_split_worker` in its own process (one thread, as the fit's workers)."""
    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    p = ctx.Process(target=_split_worker, args=(str(room_dir), dcfg, people, spots, shadow, queue))
    p.start()
    out = queue.get()
    p.join()
    return out


def _tally() -> dict:
    """This process's shadow rays since the tally was reset: how many, and the seconds in the engine."""
    from nlos_spotlight.render.rays import TALLY

    return {"rays": TALLY.rays, "ray_seconds": TALLY.seconds}


def throughput(room_dir: Path, dcfg, people, spots, processes: int, path: tuple, device: str = "cpu",
               shadow: bool = False, firsts: list | None = None, budgets: list | None = None) -> float:
    """People per second of ``processes`` concurrent renderers, each rendering all of ``people``;
    ``path``: as :data:`PATHS`; ``firsts``: gets each process's first-person seconds (``shadow``);
    ``budgets``: gets each process's (seconds a person, rays a person, seconds in rays a person)."""
    layer, rays, legacy = path
    ctx = mp.get_context("spawn")
    barrier, queue = ctx.Barrier(processes), ctx.Queue()
    old = os.environ.get("NUMBA_THREADING_LAYER")
    if layer is not None:
        os.environ["NUMBA_THREADING_LAYER"] = layer  # the children read it when they import numba
    try:
        procs = [ctx.Process(target=_worker, args=(str(room_dir), dcfg, people, spots, device, rays, legacy, shadow, barrier,
                                                      queue))
                 for _ in range(processes)]
        for p in procs:
            p.start()
        res = [queue.get() for _ in procs]
        for p in procs:
            p.join()
    finally:
        os.environ.pop("NUMBA_THREADING_LAYER", None)
        if old is not None:
            os.environ["NUMBA_THREADING_LAYER"] = old
    if any(p.exitcode != 0 for p in procs):
        raise SystemExit("a rendering process failed")
    if firsts is not None:
        firsts.extend(r["first"] for r in res if "first" in r)
    if budgets is not None:
        budgets.extend((r["seconds"] / r["people"], r["rays"] / r["people"], r["ray_seconds"] / r["people"]) for r in res)
    return sum(r["people"] for r in res) / max(r["seconds"] for r in res)


def ray_budget(budgets: list, reference_per_core: float) -> dict:
    """The share of a person's time that is shadow-ray tests (``render.rays.TALLY``), medians over the
    processes and runs of ``budgets`` ((seconds, rays, ray seconds) a person each): with the rest of
    the work free, an exact renderer casting the same rays at this engine's speed renders at most
    1 / (ray seconds) people per second a core; ``bound_over_reference``: that over the reference's
    people/s a core (``reference_per_core``), the most any such renderer gains."""
    sec, rays, ray_s = (float(np.median([b[i] for b in budgets])) for i in range(3))
    return {"seconds_per_person": sec, "rays_per_person": rays, "ray_seconds_per_person": ray_s,
            "ray_share": ray_s / sec, "mrays_per_s": rays / ray_s / 1e6, "people_per_s_rays_only": 1 / ray_s,
            "bound_over_reference": 1 / ray_s / reference_per_core}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", default=str(ROOT / "benchmarks/configs/rooms/copyroom.yaml"), help="room config (nlos fit --config)")
    ap.add_argument("--people", type=int, default=16, help="people each process renders")
    ap.add_argument("--cores", default="1,2", help="CPU process counts (one thread each)")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each path, interleaved; the median is kept")
    ap.add_argument("--shadow", action="store_true", help="time the people's nlos_shadow (the fit's shadow step) instead "
                                                          "(default --out docs/results/render-throughput-shadow.csv)")
    ap.add_argument("--out", help="CSV (default docs/results/render-throughput.csv)")
    args = ap.parse_args()
    if args.out is None:
        args.out = str(ROOT / "docs/results" / ("render-throughput-shadow.csv" if args.shadow else "render-throughput.csv"))
    import torch

    from nlos_spotlight.config_file import flatten
    from nlos_spotlight.data.config import DatasetConfig
    from nlos_spotlight.scene.los import los_mesh
    from nlos_spotlight.render.surface import StaticSurfaces

    cores = [int(c) for c in args.cores.split(",")]
    paths = SHADOW_PATHS if args.shadow else PATHS
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        sb, dcfg = build_room(args.config, work)
        ppl = people(sb, args.people)
        scene = sb.room_scene()
        surfaces = StaticSurfaces(scene)
        los = los_mesh(surfaces.mesh, surfaces.engine, scene.camera, dcfg.los_vertices)
        spots = np.linspace(0, len(los.faces) - 1, 10).round().astype(int).tolist()  # K = 10 spread candidates
        nsamp = int(np.mean([len(p) for p, _ in ppl]))
        print(f"room {args.config}: {len(los.faces)} candidates, K = {len(spots)} spots, {dcfg.resolution}x{dcfg.resolution}, "
              f"footprint {dcfg.render.pixel_footprint}, {nsamp} body samples a person (mean), {args.people} people a process")
        rows, extra = [], []
        for n in cores:
            runs = {k: [] for k in paths}
            firsts = {k: [] for k in paths}
            budgets = {k: [] for k in paths}
            for _ in range(args.repeats):  # interleaved: a slow spell of the machine hits every path
                for k, path in paths.items():
                    runs[k].append(throughput(work / "room", dcfg, ppl, spots, n, path, shadow=args.shadow,
                                              firsts=firsts[k], budgets=budgets[k]))
            got = {k: float(np.median(v)) for k, v in runs.items()}
            budget = ray_budget(budgets["new"], got["reference"] / n)
            print(f"  rays, today's path: {budget['rays_per_person']:,.0f} a person, {budget['ray_share']:.0%} of its "
                  f"time ({budget['mrays_per_s']:.2f} Mrays/s a core); were all else free, at most "
                  f"{budget['people_per_s_rays_only']:.2f} people/s a core, {budget['bound_over_reference']:.2f}x the "
                  f"reference's", flush=True)
            rows.append({"device": "cpu", "threads": n, "people_per_s": got["new"],
                         "reference_people_per_s": got["reference"], "ratio": got["new"] / got["reference"]})
            extra.append({"threads": n, **got, "runs": runs, "ray_budget": budget,
                          **({"relay_set_first_person_s": {k: float(np.median(v)) for k, v in firsts.items()}}
                             if args.shadow else {})})
            also = "" if args.shadow else f" (the new loops with the old rays: {got['new-embree']:.2f})"
            print(f"cpu, {n} core(s): {got['new']:.2f} people/s, reference {got['reference']:.2f}: "
                  f"{rows[-1]['ratio']:.2f}x{also}", flush=True)
            if args.shadow:
                print("  a relay set's first person (its static visibility), seconds: "
                      + ", ".join(f"{k} {float(np.median(v)):.2f}" for k, v in firsts.items()), flush=True)
        split = ray_split(work / "room", dcfg, ppl, spots, args.shadow)
        one = next(e["ray_budget"] for e in extra if e["threads"] == min(cores))
        split["people_per_s_static_free"] = 1 / (one["seconds_per_person"] - one["ray_seconds_per_person"]
                                                 * (1 - split["body_seconds"] / split["both_seconds"]))
        print(f"  what blocks a person's {split['rays']:,} rays: the room {split['static_blocked']:.0%}, the body "
              f"{split['body_blocked']:.0%} (either {split['both_blocked']:.0%}); tested against both {split['both_seconds']:.2f} s, "
              f"the room alone {split['static_seconds']:.2f} s, the body alone {split['body_seconds']:.2f} s: with the room's "
              f"static visibility free, at most {split['people_per_s_static_free']:.2f} people/s a core", flush=True)
        if torch.cuda.is_available():
            card = torch.cuda.get_device_name(0)
            gpu = throughput(work / "room", dcfg, ppl, spots, 1, paths["new"], "cuda", args.shadow)
            ref = throughput(work / "room", dcfg, ppl, spots, 1, paths["reference"], shadow=args.shadow)
            rows.append({"device": card, "threads": 1, "people_per_s": gpu, "reference_people_per_s": ref, "ratio": gpu / ref})
            print(f"{card}: {gpu:.2f} people/s, one-core reference {ref:.2f}: {gpu / ref:.2f}x")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["device", "threads", "people_per_s", "reference_people_per_s", "ratio"])
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()})
    meta = {"command": " ".join(["python benchmarks/render_throughput.py", *sys.argv[1:]]),
            "machine": {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
                        "python": platform.python_version(), "torch": torch.__version__},
            "people_per_process": args.people, "body_samples_mean": nsamp, "spots": spots,
            "settings": {k: v for k, v in flatten(DatasetConfig, dcfg.to_dict()).items()
                         if k in ("resolution", "pixel_footprint", "person_samples", "body_faces", "spot_samples",
                                  "person_quadrature")},
            "paths": {k: {"numba_threading_layer": v[0] or "workqueue (the package's)", "rays": v[1], "legacy": v[2]}
                      for k, v in paths.items()},
            "measured": ("the fit's shadow step (nlos_shadow and nlos_bounce at FitConfig's shadow_samples, "
                         "bounce_body_samples and shadow_depth) under the first spot, one relay set built before"
                         if args.shadow else "image samples (10 spots, flash, nlos_ambient)"),
            "rows": rows, "all_paths_people_per_s": extra, "ray_split": split}
    out.with_suffix(".json").write_text(json.dumps(meta, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
