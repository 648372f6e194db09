"""Inference latency on this machine's CPU, one thread, against the goals (issue: inference at the
paper's speed): the NLOS network on one 32x32 frame (<= 7 ms, the paper's time per estimate), the
IEN on a 1000-vertex mesh (<= 10 ms) and one 64x64 photograph through every per-frame component
(<= 50 ms), and what int8 costs in accuracy on a trained room model.

1. NLOS network, batch 1, one 32x32 frame: ResNet-18 with the small-image stem (the paper's
   network) and the lighter ResNet of the seen-rooms recipe (``nlos fit``'s room models), through
   each backend of ``models.inference`` in turn: eager under ``no_grad``, ``inference_mode``, batch
   norm folded + channels-last, ONNX Runtime, ONNX Runtime int8.
2. IEN on a real scan (``../shared/data/real-scans/icl_office2.obj``, cleaned, z up, decimated to
   1000 vertices; without it a subdivided box room): PyG's FeaStConv as called per edge (the
   reference) and the per-vertex evaluation the IEN uses (``models.feast``).
3. One photograph, all per-frame components after the per-scene precompute (checkpoint loaded, IEN
   run, network compiled): decode the file (16-bit PNG as RAW conversion writes it, at 64x64 and at
   a 1536x1024 binned camera frame), undo sRGB, clip flag, area resampling to 64x64, photograph minus
   the empty-room photograph, the network (``paper`` preset: ResNet-18, 64x64), softmax.
4. With ``--room-model`` (default ``out/fits/copyroom`` when it exists): the room model's held-out
   people photographed with its capture, predicted in float32 and int8 (calibrated on 16 training
   people): accuracy, error and how often the two disagree.

Each timing is the median of ``--repeats`` runs after warm-up (10th-90th percentiles beside it).

    python benchmarks/inference_latency.py [--repeats 200] [--room-model out/fits/copyroom]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.render.sensor import SensorConfig

GOALS_MS = {"nlos32": 7.0, "ien": 10.0, "frame64": 50.0}
"""The issue's goals, one thread."""
SCAN = Path(__file__).resolve().parents[2] / "shared" / "data" / "real-scans" / "icl_office2.obj"


def timing(fn, repeats: int) -> tuple[float, float, float]:
    """(median, 10th, 90th percentile) in ms after three warm-up runs."""
    for _ in range(3):
        fn()
    t = []
    for _ in range(repeats):
        a = time.perf_counter()
        fn()
        t.append(1000 * (time.perf_counter() - a))
    return statistics.median(t), float(np.percentile(t, 10)), float(np.percentile(t, 90))


def fmt(ms: tuple[float, float, float], goal: float | None = None) -> str:
    s = f"{ms[0]:7.2f} ms ({ms[1]:.2f}-{ms[2]:.2f})"
    return s + (f"  {'meets' if ms[0] <= goal else 'misses'} <= {goal:g} ms" if goal else "")


def mesh_1000():
    """(TriMesh with ~1000 vertices, camera, description)."""
    from nlos_spotlight.scene.setup import default_camera
    from nlos_spotlight.scene.scan import load_scan_z_up
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


def network(backbone: str, stem: str):
    from nlos_spotlight.models.nlos_net import NLOSNetConfig
    from nlos_spotlight.models.registry import build_network

    return build_network("resnet18", NLOSNetConfig(background_subtract=True, backbone=backbone, stem=stem)).eval()


def frame_inputs(shape, seed: int = 0, n: int = 1):
    rng = np.random.default_rng(seed)
    bg = rng.random((n, *shape, 3), dtype=np.float32)
    return bg + 0.01 * rng.random((n, *shape, 3), dtype=np.float32), bg, np.zeros((n, *shape), bool)


def backends(net, shape, repeats: int, goal: float | None) -> dict[str, float]:
    """Each backend in turn on one frame; returns median ms per backend."""
    from nlos_spotlight.models.inference import compile_network

    x, bg, cl = frame_inputs(shape)
    tx, tbg, tcl = (torch.as_tensor(a) for a in (x, bg, cl))
    out = {}
    with torch.no_grad():
        out["eager, no_grad"] = timing(lambda: net(tx, tbg, tcl), repeats)
    cal = [frame_inputs(shape, 10 + k) for k in range(16)]
    for name, backend in (("eager, inference_mode", "eager"), ("BN folded + channels-last", "torch"),
                          ("ONNX Runtime", "onnx"), ("ONNX Runtime int8", "onnx-int8")):
        run = compile_network(net, shape, backend, threads=1, calibration=cal)
        out[name] = timing(lambda: run(x, bg, cl), repeats)
    for name, ms in out.items():
        print(f"    {name:<28} {fmt(ms, goal)}")
    return {k: v[0] for k, v in out.items()}


def ien_timings(repeats: int) -> None:
    from nlos_spotlight.render.camera import camera_to_world
    from nlos_spotlight.models.feast import with_self_loops
    from nlos_spotlight.models.ien import IEN, IENConfig
    from nlos_spotlight.data.tensors import graph_inputs

    mesh, cam, what = mesh_1000()
    pose = camera_to_world(cam)
    x, edges = graph_inputs(mesh, pose, ["normals"])
    faces = torch.as_tensor(mesh.faces, dtype=torch.long)
    ien = IEN(IENConfig(in_features=6)).eval()

    def per_edge():  # PyG's layer as it is called: maps applied to every edge's features
        h = ien.encoder(x)
        for conv in ien.convs:
            h = torch.relu(conv(h, edges))
        h = h[faces]
        return ien.face_head(torch.cat([h.mean(1), h.amax(1)], dim=-1)).squeeze(-1)

    with torch.inference_mode():
        torch.testing.assert_close(per_edge(), ien(x, edges, faces), rtol=1e-4, atol=1e-5)
        ref = timing(per_edge, repeats)
        fast = timing(lambda: ien(x, edges, faces), repeats)
    graph = timing(lambda: graph_inputs(mesh, pose, ["normals"]), max(5, repeats // 10))
    print(f"2. IEN on {what}: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces, "
          f"{with_self_loops(edges, len(x)).shape[1]} edges with loops (graph building {graph[0]:.1f} ms, once per room)")
    print(f"    {'PyG FeaStConv per edge':<28} {fmt(ref, GOALS_MS['ien'])}")
    print(f"    {'per vertex (models.feast)':<28} {fmt(fast, GOALS_MS['ien'])}  ({ref[0] / fast[0]:.1f}x)")


def write_png16(a: np.ndarray, path: Path) -> None:
    import imagecodecs

    path.write_bytes(imagecodecs.png_encode(a, level=6))


def frame_pipeline(repeats: int) -> None:
    """Section 3: a file on disk to position and posture probabilities."""
    from nlos_spotlight.apps.images import area_resize, clip_flag, read_image
    from nlos_spotlight.models.inference import compile_network

    shape = (64, 64)
    net = network("resnet18", "cifar")
    rng = np.random.default_rng(1)
    bg, _, _ = frame_inputs(shape, 2)
    with tempfile.TemporaryDirectory() as d:
        for native in ((64, 64), (1024, 1536)):
            path = Path(d) / f"frame{native[0]}.png"
            write_png16((rng.random((*native, 3)) * 60000).astype(np.uint16), path)
            print(f"    photograph: 16-bit PNG {native[1]}x{native[0]} ({path.stat().st_size / 1e6:.2f} MB)")
            for backend in ("torch", "onnx", "onnx-int8"):
                cal = [frame_inputs(shape, 10 + k) for k in range(16)]
                run = compile_network(net, shape, backend, threads=1, calibration=cal)

                def one():
                    img = read_image(path)
                    x = area_resize(img, shape)[None].astype(np.float32)
                    pos, logits = run(x, bg, clip_flag(img, shape)[None])
                    return pos, torch.softmax(torch.as_tensor(logits), 1)

                reps = repeats if native[0] <= 64 else max(5, repeats // 20)
                read = timing(lambda: read_image(path), reps)
                print(f"      {backend:<10} all components {fmt(timing(one, reps), GOALS_MS['frame64'])}"
                      f"   (decoding + sRGB: {read[0]:.2f} ms)")


def int8_on_room_model(room: Path) -> None:
    """Section 4: held-out people of a fitted room, float32 and int8."""
    from nlos_spotlight.evaluate.seen import GROUP_OF
    from nlos_spotlight.fit.config import FitConfig
    from nlos_spotlight.fit.train import capture_overrides, room_split
    from nlos_spotlight.models.inference import compile_network
    from nlos_spotlight.train.checkpoint import load_trained
    from nlos_spotlight.train.imaging import form_images, photographs
    import json

    fit = json.loads((room / "fit.json").read_text())["settings"]
    cfg = FitConfig.from_record(fit)
    models = load_trained(room / "final.pt")
    split = room_split(room, cfg, ["normals"])
    face = json.loads((room / "report.json").read_text())["spot"]["face"]
    sensor = SensorConfig.at(models.image_shape, capture_overrides(room, cfg))
    g = torch.Generator().manual_seed(0)

    def shots(s):
        y = torch.zeros(s.direct.shape[0])
        y[face] = 1.0
        img, free = form_images(s, torch.arange(s.num_samples), y, "spot")
        ph = photographs(img, free, sensor, g, True, True)
        return ph.images.numpy(), ph.background.numpy(), ph.clipped.numpy()

    test, cal = shots(split.test), shots(split.pool.subset(torch.arange(16)))
    calib = [tuple(a[i:i + 1] for a in cal) for i in range(16)]
    truth_xy, truth_p = split.test.target.numpy(), split.test.posture.numpy()
    res = {}
    for backend in ("torch", "onnx-int8"):
        pos, logits = compile_network(models.net, models.image_shape, backend, threads=1, calibration=calib)(*test)
        res[backend] = (pos, logits.argmax(1))
        err = 100 * np.linalg.norm(pos - truth_xy, axis=1).mean()
        acc, acc3 = 100 * np.mean(res[backend][1] == truth_p), 100 * np.mean(GROUP_OF[res[backend][1]] == GROUP_OF[truth_p])
        print(f"    {backend:<10} six-way {acc:5.1f}%  upright/sitting/crouching {acc3:5.1f}%  error {err:5.1f} cm")
    moved = 100 * np.linalg.norm(res["torch"][0] - res["onnx-int8"][0], axis=1)
    print(f"    int8 vs float32 on {len(truth_p)} people: posture differs for {np.sum(res['torch'][1] != res['onnx-int8'][1])}, "
          f"position moves {moved.mean():.2f} cm on average (max {moved.max():.2f} cm)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=200)
    ap.add_argument("--sections", default="1,2,3,4", help="which sections to run")
    ap.add_argument("--room-model", default="out/fits/copyroom", help="a fitted room (nlos fit --out) for section 4")
    args = ap.parse_args()
    torch.set_num_threads(1)
    print(f"CPU, 1 thread, torch {torch.__version__}")
    want = set(args.sections.split(","))
    print("1. NLOS network, one 32x32 frame, batch 1" if "1" in want else "1. skipped")
    for label, backbone, stem in (("ResNet-18, small-image stem (the paper's network)", "resnet18", "cifar"),
                                  ("lighter ResNet, half stem (room models of nlos fit)", "resnet10-narrow", "half")
                                  ) if "1" in want else ():
        print(f"  {label}")
        backends(network(backbone, stem), (32, 32), args.repeats, GOALS_MS["nlos32"])
    if "2" in want:
        ien_timings(args.repeats)
    if "3" in want:
        print("3. One photograph to position and posture, 64x64 network (paper preset: ResNet-18)")
        frame_pipeline(max(20, args.repeats // 4))
    room = Path(args.room_model)
    if "4" not in want:
        pass
    elif (room / "report.json").is_file():
        print(f"4. int8 on the room model {room} (held-out people, its capture)")
        int8_on_room_model(room)
    else:
        print(f"4. skipped: no fitted room at {room} (python experiments/real-scan-fits/real_scan_fits.py)")


if __name__ == "__main__":
    main()
