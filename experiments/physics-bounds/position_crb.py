"""Cramer-Rao bound on the floor position of held-out people in the training rooms, per spot policy.

For each training room of a dataset and each policy's spot there (read from the learning-curve runs'
``result.json``, the spot each run used), the test people of ``nlos_spotlight.train.recipe`` (index
k % 10 == 9) are re-posed from the dataset's deterministic specs, rendered at +-1 cm in x and y
through the same renderer settings, and the Fisher information of one capture under the default
sensor (``nlos_spotlight.evaluate.crb``) gives sqrt(trace(J^-1)) per person. Prints the mean per
policy and writes a JSON ``{policy: crb_cm}`` for
``experiments/seen-rooms-learning-curve/learning_curve.py --crb``.

    python experiments/physics-bounds/position_crb.py --data out/lc/data --runs out/learning-curve/runs [--people 10]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.data.config import read_dataset_config
from nlos_spotlight.data.generate import plan
from nlos_spotlight.evaluate.crb import position_crb
from nlos_spotlight.evaluate.dataset_people import room_renderer, seen_test_specs
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.sensor import SensorConfig
from nlos_spotlight.world.body import posed_body


def policy_spots(runs: Path) -> dict[str, list[int]]:
    """policy -> per-room spot faces, from the default-capture run with the most people per room."""
    best: dict[str, tuple[int, list[int]]] = {}
    for res in runs.glob("default-*/result.json"):
        policy = res.parent.name.split("-")[1]
        r = json.loads(res.read_text())
        if r["people_per_room"] > best.get(policy, (-1, None))[0]:
            best[policy] = (r["people_per_room"], r["spots"])
    return {p: s for p, (_, s) in best.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True)
    ap.add_argument("--runs", default="out/learning-curve/runs")
    ap.add_argument("--people", type=int, default=10, help="test people per room")
    ap.add_argument("--json", default="docs/results/position-crb.json")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    data = Path(args.data)
    cfg = read_dataset_config(data)
    spots = policy_spots(Path(args.runs))
    if not spots:
        raise SystemExit(f"error: no default-capture runs with result.json under {args.runs}")
    rooms = [p for p in plan(cfg) if p.split == "train"]
    values: dict[str, list[float]] = {p: [] for p in spots}
    for i, p in enumerate(rooms):
        faces = sorted({s[i] for s in spots.values() if s[i] >= 0})
        b, scene, r = room_renderer(cfg, p, data, faces)
        sensor = SensorConfig.at(r.shape)
        for spec in seen_test_specs(cfg, p, b, scene, args.people):
            body = posed_body(spec["params"], target_faces=cfg.body_faces)
            person = Person.sampled(body, spec["params"].albedo, cfg.render)
            t = np.array([*spec["position"], scene.hidden_region.floor_z])
            for policy, s in spots.items():
                if s[i] < 0:
                    continue
                crb = position_crb(r, r.spot_vector(faces.index(s[i])), person, t, sensor)
                values[policy].append(100 * crb)
        done = ", ".join(f"{k} {np.mean(v):.2f} cm" for k, v in values.items() if v)
        print(f"after room {p.id}: {done}", flush=True)
    for k, v in values.items():
        if v:
            print(f"{k}: CRB mean {np.mean(v):.2f} cm, median {np.median(v):.2f} cm, "
                  f"10-90% {np.percentile(v, 10):.2f}-{np.percentile(v, 90):.2f} cm over {len(v)} people")
    out = {k: round(float(np.mean(v)), 3) for k, v in values.items() if v}
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(out, indent=1))
    print(json.dumps(out))


if __name__ == "__main__":
    main()
