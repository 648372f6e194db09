"""Figure 7 on unseen rooms: ours (IEN + FloorNet) as the IEN reads ever coarser scans (issue 12).

For each test room the camera-visible surface is remeshed to ~10k vertices (the paper's scans) and
decimated to each ratio of ``evaluate.decimation.RATIOS``; the IEN (trained across the 200 rooms,
Adaptive Lighting prior) picks a face there, the projector's aim snaps to the nearest stored
candidate (``evaluate.decimation.choices``; the snap distance is reported), and FloorNet localizes
every test person of the room under that spot with the same noise draws as
``experiments/backprojection-across-rooms/backprojection_net.py``.

    python experiments/backprojection-across-rooms/floor_net_decimation.py --test out/unseen/test \\
        --ien out/unseen/runs-s2400/ien-normals-adaptive-prior1-2000steps/ien.pt \\
        --runs out/backprojection-net/t2-s0 out/backprojection-net/t2-s1 out/backprojection-net/t2-s2 \\
        --out docs/results/unseen-paper/fig7-decimation.csv

Writes the CSV (seed, ratio, vertices, snap_m, error_cm, posture_accuracy, people) and Figure 7
beside it (``--plot-only``: the figure again from the CSV). The IEN's choices per room are kept in
``--cache`` so a rerun only scores.
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import torch

from nlos_spotlight.train.floor_net import predict, room_arrays


def room_choices(d: Path, ien, cache: Path) -> list[dict]:
    """The IEN's snapped choice at every ratio in test room ``d`` (cached as JSON)."""
    from nlos_spotlight.data.tensors import load_scene_tensors
    from nlos_spotlight.evaluate.decimation import choices

    path = cache / f"{d.name}.json"
    if path.exists():
        return json.loads(path.read_text())
    s = load_scene_tensors(d, ["normals", "adaptive"], samples="transport")
    models = SimpleNamespace(ien=ien, config=SimpleNamespace(ien_features=["normals", "adaptive"]))
    out = [{"ratio": c.ratio, "vertices": c.vertices, "candidate": c.candidate, "snap_m": c.snap_m}
           for c in choices(models, s)]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--test", type=Path, required=True)
    ap.add_argument("--test-rooms", type=int, default=40)
    ap.add_argument("--ien", type=Path, required=True)
    ap.add_argument("--runs", type=Path, nargs="+", required=True, help="FloorNet runs (floor_net.pt, run.json)")
    ap.add_argument("--cache", type=Path, default=Path("out/unseen/decimation-choices"))
    ap.add_argument("--out", type=Path, default=Path("docs/results/unseen-paper/fig7-decimation.csv"))
    ap.add_argument("--plot-only", action="store_true", help="only draw the figure from --out's CSV")
    args = ap.parse_args()
    if args.plot_only:
        with args.out.open() as f:
            return plot(list(csv.DictReader(f)), args.out.with_suffix(".png"))
    torch.set_num_threads(1)
    from nlos_spotlight.data.tensors import finished_scene_dirs
    from nlos_spotlight.models.floor_net import FloorNet, FloorNetConfig
    from nlos_spotlight.models.ien import IEN, IENConfig

    ien = IEN(IENConfig(in_features=7, prior_weight=1.0))
    ien.load_state_dict(torch.load(args.ien, weights_only=True))
    ien.eval()
    nets = []
    for run in args.runs:
        info = json.loads((run / "run.json").read_text())
        net = FloorNet(FloorNetConfig(templates=int(info["args"]["templates"])))
        net.load_state_dict(torch.load(run / "floor_net.pt", weights_only=True))
        nets.append((int(info["args"]["seed"]), net.eval()))
    dirs = finished_scene_dirs(args.test, "test")[: args.test_rooms]
    acc: dict[tuple, list] = {}
    for i, d in enumerate(dirs):
        ch = room_choices(Path(d), ien, args.cache)
        faces = sorted({c["candidate"] for c in ch})
        r = room_arrays(Path(d), faces, "transport")
        for seed, net in nets:
            for c in ch:
                g = torch.Generator().manual_seed(1000 * seed + i)  # backprojection_net.py's draws
                with torch.no_grad():
                    pos, logits, _ = predict(net, r, faces.index(c["candidate"]), torch.arange(len(r["target"])), g)
                a = acc.setdefault((seed, c["ratio"]), [[], [], [], []])
                a[0].append((pos - r["target"]).norm(dim=1))
                a[1].append(logits.argmax(1) == r["posture"])
                a[2].append(c["snap_m"])
                a[3].append(c["vertices"])
        print(f"room {i + 1}/{len(dirs)}: snap {np.mean([c['snap_m'] for c in ch]):.2f} m", flush=True)
    rows = [dict(seed=seed, ratio=ratio, vertices=int(np.mean(a[3])), snap_m=round(float(np.mean(a[2])), 3),
                 error_cm=round(100 * float(torch.cat(a[0]).mean()), 2),
                 posture_accuracy=round(100 * float(torch.cat(a[1]).float().mean()), 2),
                 people=int(sum(len(x) for x in a[0]))) for (seed, ratio), a in sorted(acc.items())]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    for row in rows:
        print(" ".join(f"{k}={v}" for k, v in row.items()))
    plot(rows, args.out.with_suffix(".png"))


def plot(rows: list[dict], path: Path) -> None:
    """Figure 7 as ``nlos evaluate`` draws it (``evaluate.figures.decimation_figure``): accuracy and
    error over the decimation ratios, mean and spread over the seeds."""
    from nlos_spotlight.evaluate.figures import decimation_figure

    ratios = sorted({float(r["ratio"]) for r in rows})
    seeds = sorted({int(r["seed"]) for r in rows})
    at = {(int(r["seed"]), float(r["ratio"])): r for r in rows}
    acc, err = (np.array([[float(at[s, x][k]) for x in ratios] for s in seeds])
                for k in ("posture_accuracy", "error_cm"))
    decimation_figure(ratios, acc, err, path)

if __name__ == "__main__":
    main()
