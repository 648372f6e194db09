"""Is the person's position decodable from the photographs, within rooms and across rooms?

A ridge regression from the background-subtracted, RMS-normalized photograph (oracle spot per
scene, sensor noise on or off) to the floor position in the region frame, fitted on the training
rooms except every ``--holdout``-th sample (``data.tensors.holdout_mask``); prints its mean error
on the fitted samples, on the held-out samples of the same rooms (seen rooms) and on the test
rooms (unseen rooms), next to the error of always answering the training mean. A linear probe is
the simplest decoder: if it predicts new people in seen rooms but not in unseen rooms, the limit
is how many rooms the data holds, not the signal.

    python benchmarks/linear_probe.py --data DIR [--lambdas 0.1,10,1000] [--holdout 6]
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from nlos_spotlight.lighting.snr import candidate_snr
from nlos_spotlight.render.sensor import SensorConfig
from nlos_spotlight.train.imaging import form_images, photographs
from nlos_spotlight.data.tensors import holdout_mask, load_split


def features(data: str, split: str, noise: bool, holdout: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    xs, ys, held = [], [], []
    for s in load_split(data, split, ["normals"]):
        y = torch.zeros(len(s.faces))
        y[int(candidate_snr(s.scene_dir).argmax())] = 1
        idx = torch.nonzero(s.trajectory[:, 0] < 0).flatten()
        img, free = form_images(s, idx, y)
        h, w = free.shape[:2]
        ph = photographs(img, free, SensorConfig.at((h, w)), torch.Generator().manual_seed(0), noise, True)
        d = (ph.images - ph.background).reshape(len(idx), -1).double()
        xs.append((d / d.pow(2).mean(1, keepdim=True).sqrt()).numpy())
        ys.append(s.target[idx].double().numpy())
        held.append(holdout_mask(s, holdout)[idx].numpy())
    return np.concatenate(xs), np.concatenate(ys), np.concatenate(held)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True)
    ap.add_argument("--lambdas", default="0.1,10,1000")
    ap.add_argument("--holdout", type=int, default=6, help="hold out every n-th sample of the training rooms")
    args = ap.parse_args()
    print(f"{'noise':6s} {'lambda':>8s} {'fit cm':>8s} {'seen rooms cm':>14s} {'unseen rooms cm':>16s} "
          f"{'mean answer seen/unseen cm':>27s}")
    for noise in (False, True):
        xa, ya, held = features(args.data, "train", noise, args.holdout)
        xtr, ytr, xse, yse = xa[~held], ya[~held], xa[held], ya[held]
        xte, yte, _ = features(args.data, "test", noise, 0)
        mu = ytr.mean(0)
        base = lambda y: 100 * np.linalg.norm(y - mu, axis=1).mean()
        for lam in (float(v) for v in args.lambdas.split(",")):
            w = np.linalg.solve(xtr.T @ xtr + lam * np.eye(xtr.shape[1]), xtr.T @ (ytr - mu))
            err = lambda x, y: 100 * np.linalg.norm(x @ w + mu - y, axis=1).mean() if len(y) else float("nan")
            print(f"{str(noise):6s} {lam:8.3g} {err(xtr, ytr):8.1f} {err(xse, yse):14.1f} {err(xte, yte):16.1f} "
                  f"{base(yse):13.1f} / {base(yte):.1f}")


if __name__ == "__main__":
    main()
