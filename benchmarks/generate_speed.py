"""Dataset generation speed on this machine: scenes per minute and samples per second.

Times a whole ``nlos generate`` run of a preset (default ``tiny``) into a temporary directory, and
its parts: room generation, per-scene precompute (LOS mesh, decimation, candidates, direct images)
and per-sample work (posed body, transport to every candidate, low-rank factorization).

With ``--fuse`` the same run is made a second time with the fused person kernels
(``nlos generate --fuse``; their compilation included) and the ratio of the two is printed.

    python benchmarks/generate_speed.py [--preset tiny] [--scenes 3] [--fuse] [--set FIELD=VALUE ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import torch

from nlos_spotlight.config_file import apply_assignments
from nlos_spotlight.data.config import load_config
from nlos_spotlight.data.generate import generate, plan
from nlos_spotlight.data.scene_builder import SceneBuilder


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="tiny")
    ap.add_argument("--scenes", type=int, default=3, help="train scenes to build (val/test set to 0)")
    ap.add_argument("--fuse", action="store_true", help="also time the run with fused kernels (same data)")
    ap.add_argument("--set", nargs="*", default=[], metavar="FIELD=VALUE",
                    help="override config fields, e.g. person_samples=4000 person_quadrature=faces")
    args = ap.parse_args()
    cfg = dataclasses.replace(load_config(args.preset), train_scenes=args.scenes, val_scenes=0, test_scenes=0)
    cfg = apply_assignments(cfg, args.set)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        # parts, on the first scene
        p = plan(cfg)[0]
        from nlos_spotlight.world.rooms import generate_room

        t = time.perf_counter()
        b = SceneBuilder(cfg, p, out / "parts")
        generate_room(p.seed, b._room_config())
        t_room = time.perf_counter() - t
        # the whole run
        t = time.perf_counter()
        generate(cfg, out / "data", progress=False)
        total = time.perf_counter() - t
        if args.fuse:
            t = time.perf_counter()
            generate(cfg, out / "fused", progress=False, fuse=True)
            fused = time.perf_counter() - t
    n_samples = cfg.train_scenes * cfg.samples_per_scene
    print(f"preset {cfg.name}: {cfg.train_scenes} scenes x {cfg.samples_per_scene} samples at "
          f"{cfg.render.person_samples} body samples ({cfg.render.person_quadrature}), "
          f"{cfg.resolution}x{cfg.resolution}, LOS mesh {cfg.los_vertices} vertices, "
          f"{torch.get_num_threads()} torch threads")
    print(f"room generation: {t_room:.2f} s per room")
    print(f"whole run: {total:.1f} s -> {cfg.train_scenes / total * 60:.2f} scenes/min, "
          f"{n_samples / total:.2f} samples/s (each sample: the nlos image for every candidate spot)")
    if args.fuse:
        print(f"fused kernels: {fused:.1f} s -> {n_samples / fused:.2f} samples/s; "
              f"speed-up {total / fused:.2f}x over eager in this run (compilation included)")


if __name__ == "__main__":
    main()
