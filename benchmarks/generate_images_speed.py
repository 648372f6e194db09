"""Generation speed and size of the two sample kinds (docs/dataset-format.md), one room.

Builds one room of a preset (default ``demo``) with ``--transport`` full-transport people (the
spot policies' samples) and ``--images`` image samples (the person's light under the room's stored
spots only), one torch thread, and prints seconds per person of each kind, the one-off cost per
room (room, LOS mesh, per-scene images, spot choice), bytes per sample of each kind, and the
projections: 2,000 people in one room, and the disk size of 100,000 samples in rooms of
``--people`` people. ``--profile`` adds the top functions by cumulative time of each kind.

    python benchmarks/generate_images_speed.py [--preset demo] [--transport 24] [--images 200]
        [--scene 0] [--people 2000] [--profile] [--fuse] [--set FIELD=VALUE ...]
"""

from __future__ import annotations

import argparse
import cProfile
import dataclasses
import io
import pstats
import tempfile
import time
from pathlib import Path

import torch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="demo")
    ap.add_argument("--transport", type=int, default=24, help="full-transport people in the room")
    ap.add_argument("--images", type=int, default=200, help="image-sample people in the room")
    ap.add_argument("--scene", type=int, default=0, help="which room of the preset's plan (its family and seed)")
    ap.add_argument("--people", type=int, default=2000, help="people per room in the size projection")
    ap.add_argument("--top", type=int, default=None, help="stored_spots_top (default: the config's)")
    ap.add_argument("--profile", action="store_true", help="cProfile each sample kind")
    ap.add_argument("--fuse", action="store_true", help="the renderer's fused pair kernels (nlos generate --fuse)")
    ap.add_argument("--set", nargs="*", default=[], metavar="FIELD=VALUE",
                    help="other DatasetConfig overrides, e.g. person_quadrature=mc")
    args = ap.parse_args()
    torch.set_num_threads(1)

    from nlos_spotlight.data import scene_builder as sb
    from nlos_spotlight.config_file import apply_assignments
    from nlos_spotlight.data.config import load_config
    from nlos_spotlight.data.generate import plan
    from nlos_spotlight.world.body import _default_cache

    base = apply_assignments(load_config(args.preset), args.set)
    cfg = dataclasses.replace(base, train_scenes=max(base.train_scenes, args.scene + 1), val_scenes=0, test_scenes=1,
                              samples_per_scene=args.transport + args.images,
                              transport_samples_per_scene=args.transport,
                              stored_spots_top=base.stored_spots_top if args.top is None else args.top)
    p = plan(cfg)[args.scene]
    times = {"transport": [], "image": [], "spots": []}
    cpu = {"transport": [], "image": [], "spots": []}
    profiles = {k: cProfile.Profile() for k in ("transport", "image")} if args.profile else {}

    def timed(kind, fn):
        def wrapper(*a, **k):
            prof = profiles.get(kind)
            t, c = time.perf_counter(), time.process_time()
            if prof:
                prof.enable()
            try:
                return fn(*a, **k)
            finally:
                if prof:
                    prof.disable()
                times[kind].append(time.perf_counter() - t)
                cpu[kind].append(time.process_time() - c)
        return wrapper

    sb.SceneBuilder._sample = timed("transport", sb.SceneBuilder._sample)
    sb.SceneBuilder._image_sample = timed("image", sb.SceneBuilder._image_sample)
    sb.SceneBuilder._stored_spots = timed("spots", sb.SceneBuilder._stored_spots)
    f16_errors = []
    encode = sb.f16_encode

    def measured_encode(a, per_first_axis=False):  # the precision float16 costs, per stored image
        import numpy as np

        half, scale = encode(a, per_first_axis)
        back = half.astype(np.float64) * (scale.reshape(-1, *([1] * (a.ndim - 1))) if per_first_axis else scale)
        flat = lambda x: x.reshape(len(x), -1) if per_first_axis else x.reshape(1, -1)
        norm = np.linalg.norm(flat(a), axis=1)
        f16_errors.extend((np.linalg.norm(flat(back - a), axis=1) / np.where(norm > 0, norm, 1))[norm > 0])
        return half, scale

    sb.f16_encode = measured_encode
    cache = _default_cache()
    before = dict(cache.stats)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        sb.SceneBuilder(cfg, p, Path(tmp), fuse=args.fuse).build(lambda k=1: None)
        total = time.perf_counter() - t0
        d = Path(tmp) / "scenes" / p.id
        size = lambda pattern: [f.stat().st_size for f in d.glob(pattern)]
        from nlos_spotlight.data.static import STATIC, read_static

        full_b, img_b = size("samples/*.npz"), size("images/*.npz")
        static_b = sum(size(STATIC)) + sum(size("*.ply")) + sum(size("*.json"))
        import json
        import numpy as np

        spots = json.loads((d / "spots.json").read_text())["spots"] if args.images else []
        t_cands = len(read_static(d, "los_faces")["los_faces"])
        body_b = 0
        with np.load(d / "samples" / "00000.npz") as z:
            body_b = z["body_vertices"].nbytes + z["body_faces"].nbytes
        from nlos_spotlight.data.tensors import load_scene_tensors

        loads = {}
        for kind in ("all", "transport", "images") if args.images else ("all",):
            t = time.perf_counter()
            st = load_scene_tensors(d, [], samples=kind)
            loads[kind] = (time.perf_counter() - t, (st.u.nbytes + st.v.nbytes) / 1e6, st.num_samples)
            del st
    stats = {k: cache.stats[k] - before[k] for k in cache.stats}
    mean = lambda v: sum(v) / len(v) if v else float("nan")
    per = {k: (sum(v) / len(v) if v else float("nan")) for k, v in times.items()}
    overhead = total - sum(times["transport"]) - sum(times["image"]) - sum(times["spots"])
    print(f"preset {cfg.name}, room {p.id} ({p.family}), {cfg.resolution}x{cfg.resolution}, T = {t_cands} candidates, "
          f"K = {len(spots)} stored spots (top {cfg.stored_spots_top} by SNR + adaptive, center, random x3), "
          f"{torch.get_num_threads()} torch thread")
    print(f"bodies: {stats['generated']} posed with Anny (library misses), {stats['disk_loads']} from disk, "
          f"{stats['memory_hits']} from memory")
    print(f"room, LOS mesh, per-scene images, file writes: {overhead:.1f} s; "
          f"spot choice (SNR + policies): {sum(times['spots']):.1f} s")
    med = lambda v: sorted(v)[len(v) // 2]
    print(f"full-transport person: {per['transport']:.3f} s wall ({args.transport} people, median "
          f"{med(times['transport']):.3f} s), {mean(cpu['transport']):.3f} s CPU")
    if args.images:
        print(f"image person:          {per['image']:.3f} s wall ({args.images} people, median "
              f"{med(times['image']):.3f} s), {mean(cpu['image']):.3f} s CPU")
    print(f"bytes per sample: full transport {mean(full_b) / 1e3:.1f} kB (body mesh {body_b / 1e3:.1f} kB of it), "
          f"image {mean(img_b) / 1e3:.1f} kB; per room (scene files, static.npz, spots.json) {static_b / 1e3:.0f} kB")
    if f16_errors:
        e = np.asarray(f16_errors)
        print(f"float16 (power-of-two scaled) relative Frobenius error per stored image: median {np.median(e):.1e}, "
              f"max {e.max():.1e} (bound 2^-11 = 4.9e-4); float32 would be 0 (the renderer's dtype)")
    for kind, (sec, mb, n) in loads.items():
        print(f"load_scene_tensors(samples={kind!r}): {n} samples, u+v {mb:.0f} MB float32, {sec:.1f} s")
    n_img = max(args.people - args.transport, 0)
    room = overhead + sum(times["spots"])
    t2000 = room + args.transport * per["transport"] + n_img * (per["image"] if args.images else float("nan"))
    print(f"projection, one room of {args.people} people ({args.transport} full + {n_img} image): "
          f"{t2000:.0f} s = {t2000 / 60:.1f} min (target <= 10 min)")
    rooms = 100_000 / args.people
    gb = rooms * (static_b + args.transport * mean(full_b) + n_img * (mean(img_b) if img_b else float("nan"))) / 1e9
    print(f"projection, 100,000 samples in {rooms:.0f} rooms of {args.people}: {gb:.2f} GB (target <= 10 GB); "
          f"all full transport: {100_000 * mean(full_b) / 1e9:.1f} GB")
    for kind, prof in profiles.items():
        s = io.StringIO()
        pstats.Stats(prof, stream=s).sort_stats("cumulative").print_stats(18)
        print(f"\n--- profile: {kind} samples ---")
        print("\n".join(line for line in s.getvalue().splitlines() if line.strip())[:6000])


if __name__ == "__main__":
    main()
