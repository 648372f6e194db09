"""Is posture in the backprojection? The matched filter's height profile at the person's own place.

A sitting or crouching person scatters the spot's light from lower down than a standing one. If the
matched filter (``data/backprojection.py``) at the true floor cell, over a column of heights, tells
postures apart in rooms a classifier never saw, a network on the floor could learn posture too; if
it does not, posture needs more than a point-scatterer model. For each room's oracle spot, each
person's profile h(z) at the nearest cell (z = 0.1-1.9 m, every 0.2 m), normalized by its largest
value, with that value's logarithm, trains a multinomial logistic regression on the training rooms
(six-way, and upright / sitting / crouching with balanced class weights) scored on the test rooms;
noise-free and under the default capture (one noise draw per person).

    python benchmarks/backprojection_posture.py --train out/unseen/train --test out/unseen/test \\
        [--train-rooms 100] [--test-rooms 40] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.render.sensor import SensorConfig

HEIGHTS = tuple(round(0.1 + 0.2 * i, 1) for i in range(10))


def profiles(d: Path, seed: int, i: int) -> dict:
    """Per person: the filter's height profile at the true cell, noise-free and noisy; posture."""
    from nlos_spotlight.data.backprojection import FloorGrid, candidate_spot_factor, room_backprojector
    from nlos_spotlight.data.tensors import load_scene_tensors
    from nlos_spotlight.lighting import policy_rng
    from nlos_spotlight.lighting.learned import policy_named
    from nlos_spotlight.train.imaging import form_images, radiance_variance

    s = load_scene_tensors(d, [], samples="images" if "train" in d.name or "val" in d.name else "transport")
    grid = FloorGrid(heights=HEIGHTS)
    bp, _ = room_backprojector(str(d), grid)
    face = policy_named("oracle")(s, d, policy_rng(seed, i, new_room=True)).face
    y = torch.zeros(len(s.faces))
    y[face] = 1.0
    with torch.no_grad():
        img, pf = form_images(s, torch.arange(s.num_samples), y, "spot")
    sensor = SensorConfig.at(tuple(s.ambient.shape[:2]))
    var = (2 * radiance_variance(pf, pf, sensor)).numpy()
    clean = (img - pf).numpy()
    gen = np.random.default_rng(seed * 1000 + i)
    noisy = clean + gen.standard_normal(clean.shape) * np.sqrt(var)
    spot = candidate_spot_factor(str(d), face, grid)
    cell = np.argmin(((bp.cells[None] - s.target.numpy()[:, None]) ** 2).sum(-1), axis=1)
    out = {"posture": s.posture.numpy()}
    for name, x, w in (("noise-free", clean, None), ("default", noisy, 1.0 / var)):
        h = bp.heatmap(x, spot, w)  # (B, Z, G)
        out[name] = h[np.arange(len(cell)), :, cell]
    return out


def features(h: np.ndarray) -> np.ndarray:
    peak = np.abs(h).max(1, keepdims=True)
    return np.concatenate([h / np.maximum(peak, 1e-12), np.log(np.maximum(peak, 1e-12))], 1)


def fit_predict(x: np.ndarray, y: np.ndarray, xt: np.ndarray, classes: int, balanced: bool) -> np.ndarray:
    """Multinomial logistic regression (standardized inputs, L2 1e-3, LBFGS)."""
    mu, sd = x.mean(0), x.std(0) + 1e-9
    xs, xts = torch.as_tensor((x - mu) / sd, dtype=torch.float32), torch.as_tensor((xt - mu) / sd, dtype=torch.float32)
    yt = torch.as_tensor(y)
    counts = torch.bincount(yt, minlength=classes).float()
    weight = (counts.sum() / (classes * counts.clamp(min=1))) if balanced else None
    lin = torch.nn.Linear(x.shape[1], classes)
    opt = torch.optim.LBFGS(lin.parameters(), max_iter=500)

    def closure():
        opt.zero_grad()
        loss = torch.nn.functional.cross_entropy(lin(xs), yt, weight=weight) + 1e-3 * lin.weight.pow(2).sum()
        loss.backward()
        return loss

    opt.step(closure)
    with torch.no_grad():
        return lin(xts).argmax(1).numpy()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", required=True)
    ap.add_argument("--test", required=True)
    ap.add_argument("--train-rooms", type=int, default=100)
    ap.add_argument("--test-rooms", type=int, default=40)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    torch.set_num_threads(1)
    from nlos_spotlight.data.tensors import finished_scene_dirs
    from nlos_spotlight.evaluate.seen import GROUP_OF

    tr = [profiles(d, args.seed, i) for i, d in enumerate(finished_scene_dirs(args.train, "train")[: args.train_rooms])]
    te = [profiles(d, args.seed, i) for i, d in enumerate(finished_scene_dirs(args.test, "test")[: args.test_rooms])]
    cat = lambda rooms, k: np.concatenate([r[k] for r in rooms])
    y, yt = cat(tr, "posture"), cat(te, "posture")
    result = {"heights_m": HEIGHTS, "train_people": len(y), "test_people": len(yt)}
    for capture in ("noise-free", "default"):
        x, xt = features(cat(tr, capture)), features(cat(te, capture))
        six = fit_predict(x, y, xt, 6, balanced=False)
        three = fit_predict(x, GROUP_OF[y], xt, 3, balanced=True)
        g = GROUP_OF[yt]
        balanced3 = np.mean([(three[g == c] == c).mean() for c in range(3)])
        result[capture] = {"six_way_accuracy": float((six == yt).mean() * 100),
                           "three_way_accuracy": float((three == g).mean() * 100),
                           "three_way_balanced_accuracy": float(balanced3 * 100)}
        print(f"{capture:10s} six-way {result[capture]['six_way_accuracy']:.1f}% (chance 16.7%), upright/sitting/"
              f"crouching {result[capture]['three_way_accuracy']:.1f}%, balanced {balanced3 * 100:.1f}% (chance 33.3%)")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
