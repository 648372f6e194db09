"""How far physics alone gets in rooms nobody trained on: matched-filter backprojection.

For every test room (``--test``: full-transport people, e.g. ``out/unseen/test``) and spot policy,
each person's background-subtracted photograph is correlated with the room's point-scatterer
templates (``data/backprojection.py``: the scan, the spot, no training) and the best valid floor
cell is the answer. Three inputs per policy and capture:

* ``spot``: the person's light from the spot only (``nlos``: what "projector on minus projector
  off" with the person present gives);
* ``photo``: the background-subtracted photograph (``nlos`` + the person's ambient light
  ``nlos_ambient``; what the networks read), noise-free and under the ``default`` capture (the
  photograph and the empty-room one each with their own noise; the filter weighted by the
  inverse noise variance).

Prints and writes per room and overall mean errors (cm) beside the mean answer (the training
rooms' mean position, ``--train``), to ``--out`` (CSV).

    python experiments/backprojection-across-rooms/backprojection_unseen.py --train out/unseen/train --test out/unseen/test \\
        [--rooms 40] [--policies oracle,adaptive,center,random] [--seed 0] [--out CSV]
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.console import console
from nlos_spotlight.render.sensor import SensorConfig


def noisy(clean: torch.Tensor, person_free: torch.Tensor, sensor, gen: torch.Generator):
    """A background-subtracted photograph of ``clean`` (B, H, W, 3) in radiance units and the inverse
    noise variance per pixel (H, W, 3), metered on ``person_free`` as the camera does."""
    from nlos_spotlight.render.sensor import auto_exposure
    from nlos_spotlight.train.imaging import add_sensor_noise, radiance_variance

    exposure = auto_exposure(person_free.clamp(min=0), sensor)
    photo, _ = add_sensor_noise(clean.clamp(min=0), exposure, sensor, gen)
    bg, _ = add_sensor_noise(person_free.clamp(min=0).expand_as(clean), exposure, sensor, gen)
    var = 2 * radiance_variance(person_free, person_free, sensor)  # photo and background
    return (photo - bg).numpy(), (1.0 / var).numpy()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", required=True, help="training dataset (its rooms' mean position: the mean answer)")
    ap.add_argument("--test", required=True, help="test dataset with full-transport people")
    ap.add_argument("--rooms", type=int, default=40)
    ap.add_argument("--policies", default="oracle,adaptive,center,random")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    torch.set_num_threads(1)

    from nlos_spotlight.data.backprojection import candidate_spot_factor, room_backprojector
    from nlos_spotlight.data.tensors import finished_scene_dirs, load_scene_tensors
    from nlos_spotlight.lighting import policy_rng
    from nlos_spotlight.lighting.learned import policy_named
    from nlos_spotlight.train.imaging import form_images

    train_dirs = finished_scene_dirs(args.train, "train")
    mean_xy = np.concatenate([load_scene_tensors(d, [], samples="images").target.numpy()
                              for d in train_dirs]).mean(0)
    dirs = finished_scene_dirs(args.test, "test")[: args.rooms]
    policies = args.policies.split(",")
    rows = []
    t0 = time.perf_counter()
    for i, d in enumerate(dirs):
        s = load_scene_tensors(d, [], samples="transport")
        bp, _ = room_backprojector(str(d))
        sensor = SensorConfig.at(tuple(s.ambient.shape[:2]))
        tgt = s.target.numpy()
        mean_err = np.linalg.norm(tgt - mean_xy, axis=1).mean() * 100
        idx = torch.arange(s.num_samples)
        for policy in policies:
            ill = policy_named(policy)(s, Path(d), policy_rng(args.seed, i, new_room=True))  # as room_lights draws
            y = ill.spot_vector(len(s.faces))
            spot = candidate_spot_factor(str(d), ill.face)
            with torch.no_grad():
                img, person_free = form_images(s, idx, y, "spot")
            nlos = img - person_free - s.nlos_ambient
            gen = torch.Generator().manual_seed(args.seed * 1000 + i)
            inputs = {("noise-free", "spot"): (nlos.numpy(), None),
                      ("noise-free", "photo"): ((img - person_free).numpy(), None),
                      ("default", "photo"): noisy(img, person_free, sensor, gen)}
            for (capture, kind), (x, w) in inputs.items():
                pred = bp.locate(x, spot, w)
                err = np.linalg.norm(pred - tgt, axis=1).mean() * 100
                rows.append(dict(room=Path(d).name, policy=policy, capture=capture, input=kind,
                                 people=len(tgt), error_cm=round(err, 2), mean_answer_cm=round(mean_err, 2)))
        console.print(f"[{i + 1}/{len(dirs)}] {Path(d).name}: oracle spot-only noise-free "
                      f"{rows[-len(policies) * 3]['error_cm']:.1f} cm, mean answer {mean_err:.1f} cm "
                      f"({time.perf_counter() - t0:.0f} s)")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with open(args.out, "w", newline="") as f:
            wr = csv.DictWriter(f, fieldnames=list(rows[0]))
            wr.writeheader()
            wr.writerows(rows)
    console.print(f"{len(dirs)} rooms; mean error over people (cm); mean answer "
                  f"{np.mean([r['mean_answer_cm'] for r in rows if r['policy'] == policies[0]]):.1f} cm")
    for policy in policies:
        for capture, kind in (("noise-free", "spot"), ("noise-free", "photo"), ("default", "photo")):
            if True:
                sel = [r for r in rows if (r["policy"], r["capture"], r["input"]) == (policy, capture, kind)]
                e = np.average([r["error_cm"] for r in sel], weights=[r["people"] for r in sel])
                console.print(f"  {policy:9s} {capture:10s} {kind:5s} {e:6.1f} cm")


if __name__ == "__main__":
    main()
