"""Inference latency on this machine's CPU: the IEN on a 1000-vertex mesh, and the NLOS network per
frame at batch 1 and batch 64, against the paper's 7 ms per estimate.

The mesh is a real scan (``../shared/data/real-scans/icl_office2.obj``) cleaned, turned z up and
decimated to 1000 vertices, seen from the default camera of ``nlos spotlight`` (the full scan is
used, not only what the camera sees, to keep the 1000 vertices); without the scan, a subdivided box
room. Networks come from ``--checkpoint`` or are freshly initialized (the same cost). Each timing
is the median of ``--repeats`` runs after two warm-up runs, under ``torch.no_grad``.

    python benchmarks/inference_latency.py [--checkpoint RUN] [--resolution 64] [--threads N]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import torch

PAPER_MS = 7.0
"""The paper's time per estimate (WACV 2024, GPU)."""
SCAN = Path(__file__).resolve().parents[2] / "shared" / "data" / "real-scans" / "icl_office2.obj"


def median_ms(fn, repeats: int) -> float:
    for _ in range(2):
        fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1000 * statistics.median(times)


def mesh_1000():
    """(TriMesh with ~1000 vertices, camera, description)."""
    from nlos_spotlight.apps.spotlight import default_camera, load_scan_z_up
    from nlos_spotlight.render.rays import RayEngine
    from nlos_spotlight.scene.builders import box
    from nlos_spotlight.scene.clean import clean_mesh
    from nlos_spotlight.scene.decimate import decimate
    from nlos_spotlight.scene.format import TriMesh

    if SCAN.is_file():
        full, _ = load_scan_z_up(SCAN)
        what = f"{SCAN.name} decimated"
    else:
        import trimesh

        b = box([0.0, 0.0, 0.0], [6.0, 4.0, 2.5])
        tm = trimesh.Trimesh(b.vertices, b.faces).subdivide().subdivide().subdivide().subdivide()
        full = clean_mesh(TriMesh(np.asarray(tm.vertices), np.asarray(tm.faces, np.int64)))
        what = "subdivided box room decimated"
    cam = default_camera(full, RayEngine(full.vertices, full.faces))
    return decimate(full, 1000), cam, what


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--checkpoint", help="trained run (default: freshly initialized networks)")
    ap.add_argument("--resolution", type=int, default=64, help="image size without a checkpoint (paper preset: 64)")
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--threads", type=int, help="torch CPU threads (default: torch's choice)")
    args = ap.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)

    from nlos_spotlight.apps.spotlight import camera_to_world
    from nlos_spotlight.models.ien import IEN, IENConfig
    from nlos_spotlight.models.registry import build_network
    from nlos_spotlight.train.scenes import graph_inputs

    if args.checkpoint:
        from nlos_spotlight.train.checkpoint import load_trained

        m = load_trained(args.checkpoint)
        ien, net, shape, features = m.ien, m.net, m.image_shape, m.config.ien_features
    else:
        ien, net = IEN(IENConfig(in_features=6)).eval(), build_network("resnet18").eval()
        shape, features = (args.resolution, args.resolution), ["normals"]
    mesh, cam, what = mesh_1000()
    pose = camera_to_world(cam)
    x, edges = graph_inputs(mesh, pose, features)
    faces = torch.as_tensor(mesh.faces, dtype=torch.long)

    print(f"CPU, {torch.get_num_threads()} torch threads, torch {torch.__version__}; "
          f"{'checkpoint ' + args.checkpoint if args.checkpoint else 'freshly initialized networks'}")
    with torch.no_grad():
        t_graph = median_ms(lambda: graph_inputs(mesh, pose, features), args.repeats)
        t_ien = median_ms(lambda: ien(x, edges, faces), args.repeats)
        print(f"IEN on {what}: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces: "
              f"forward {t_ien:.1f} ms (+ graph building {t_graph:.1f} ms), once per room")
        for batch in (1, 64):
            images = torch.rand(batch, *shape, 3)
            # a network trained on photograph - empty room also gets the empty-room frame (subtraction counted)
            bg = torch.rand(batch, *shape, 3) if getattr(net, "subtract", False) else None
            ms = median_ms(lambda: net(images, bg), args.repeats if batch == 1 else max(3, args.repeats // 4))
            per = ms / batch
            print(f"NLOS network {shape[0]}x{shape[1]}, batch {batch:>2}: {ms:8.1f} ms per batch, {per:6.2f} ms per "
                  f"frame = {per / PAPER_MS:.2f} x the paper's {PAPER_MS:g} ms ({1000 / per:.0f} frames/s)")


if __name__ == "__main__":
    main()
