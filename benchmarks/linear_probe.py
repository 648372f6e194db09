"""Is the person's position decodable from the photographs, within rooms and across rooms?

A ridge regression from the background-subtracted, RMS-normalized photograph (oracle spot per
scene, sensor noise on or off) to the floor position in the region frame, fitted on the training
rooms; prints its mean error on those rooms and on the held-out test rooms next to the error of
always answering the training mean. A linear probe is the simplest decoder: if it fits the
training rooms but not the test rooms, the limit is how many rooms the data holds, not the
network.

    python benchmarks/linear_probe.py --data DIR [--lambdas 0.1,10,1000]
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from nlos_spotlight.lighting.snr import candidate_snr
from nlos_spotlight.render.sensor import SensorConfig
from nlos_spotlight.train.imaging import form_images, photographs
from nlos_spotlight.train.scenes import load_split


def features(data: str, split: str, noise: bool) -> tuple[np.ndarray, np.ndarray]:
    xs, ys = [], []
    for s in load_split(data, split, ["normals"]):
        y = torch.zeros(len(s.faces))
        y[int(candidate_snr(s.scene_dir).argmax())] = 1
        idx = torch.nonzero(s.trajectory[:, 0] < 0).flatten()
        img, free = form_images(s, idx, y)
        h, w = free.shape[:2]
        ph, bg = photographs(img, free, SensorConfig(width=w, height=h), torch.Generator().manual_seed(0), noise, True)
        d = (ph - bg).reshape(len(idx), -1).double()
        xs.append((d / d.pow(2).mean(1, keepdim=True).sqrt()).numpy())
        ys.append(s.target[idx].double().numpy())
    return np.concatenate(xs), np.concatenate(ys)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True)
    ap.add_argument("--lambdas", default="0.1,10,1000")
    args = ap.parse_args()
    print(f"{'noise':6s} {'lambda':>8s} {'train err cm':>13s} {'test err cm':>12s} {'mean-answer test cm':>20s}")
    for noise in (False, True):
        xtr, ytr = features(args.data, "train", noise)
        xte, yte = features(args.data, "test", noise)
        mu = ytr.mean(0)
        base = 100 * np.linalg.norm(yte - mu, axis=1).mean()
        for lam in (float(v) for v in args.lambdas.split(",")):
            w = np.linalg.solve(xtr.T @ xtr + lam * np.eye(xtr.shape[1]), xtr.T @ (ytr - mu))
            err = lambda x, y: 100 * np.linalg.norm(x @ w + mu - y, axis=1).mean()
            print(f"{str(noise):6s} {lam:8.3g} {err(xtr, ytr):13.1f} {err(xte, yte):12.1f} {base:20.1f}")


if __name__ == "__main__":
    main()
