"""Does the spot matter? NLOS signal-to-noise ratio of the oracle, center and random spots.

For every held-out scene of a generated dataset and every candidate spot t, the camera auto-exposes
on the person-free image (direct_t + ambient), and the NLOS signal s = nlos_t (in digital numbers)
is compared with the sensor noise of the whole image (shot noise of everything, read noise,
quantization): SNR_t = sqrt(sum_p s_p^2 / var_p), the matched-filter detectability of the person.
Per scene SNR_t is averaged over the static samples; then

* oracle: the best candidate (exhaustive search),
* center: the candidate whose aim point is nearest the center of the camera image,
* random: the mean over candidates whose spot lands (the expected value of a random choice),
* ambient only: no projector; the signal is ``nlos_ambient``, exposure on ``ambient``.

    python benchmarks/spot_matters.py --data DIR [--split test]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.render.camera import project
from nlos_spotlight.render.sensor import SensorConfig, auto_exposure, expected_dn
from nlos_spotlight.scene import load_scene


def snr(signal: torch.Tensor, total: torch.Tensor, exposure: float, cfg: SensorConfig) -> float:
    s = expected_dn(signal, exposure, cfg)
    mu = expected_dn(total.clamp(min=0), exposure, cfg)
    var = cfg.gain * mu + (cfg.gain * cfg.read_noise_binned_e) ** 2 + 1 / 12  # DN^2
    return float(torch.sqrt((s * s / var).sum()))


def scene_snrs(scene_dir: Path) -> dict:
    st = np.load(scene_dir / "static.npz")
    direct, ambient = torch.as_tensor(st["direct"]).double(), torch.as_tensor(st["ambient"]).double()
    landed = st["spot_landed"]
    scene = load_scene(scene_dir)
    cfg = SensorConfig.from_dict({**(scene.sensor or {}), "width": scene.camera.width,
                                  "height": scene.camera.height})
    t_count = direct.shape[0]
    exposures = [auto_exposure(direct[t] + ambient, cfg) if landed[t] else None for t in range(t_count)]
    amb_exposure = auto_exposure(ambient, cfg) if float(ambient.max()) > 0 else cfg.max_exposure_s
    per_t, amb = [], []
    for path in sorted((scene_dir / "samples").glob("*.npz")):
        z = np.load(path)
        if int(z["trajectory"]) >= 0:
            continue
        f = torch.einsum("tr,rhwc->thwc", torch.as_tensor(z["transport_u"]).double(),
                         torch.as_tensor(z["transport_v"]).double())
        na = torch.as_tensor(z["nlos_ambient"]).double()
        per_t.append([snr(f[t], direct[t] + ambient + f[t] + na, exposures[t], cfg) if landed[t] else 0.0
                      for t in range(t_count)])
        amb.append(snr(na, ambient + na, amb_exposure, cfg))
    mean_t = np.mean(per_t, axis=0)
    h, w = scene.camera.height, scene.camera.width
    pix = project(scene.camera, st["aim_points"])
    dist = np.where(landed, np.hypot(pix[:, 0] - h / 2, pix[:, 1] - w / 2), np.inf)
    return {"oracle": float(mean_t.max()), "center": float(mean_t[np.nanargmin(dist)]),
            "random": float(mean_t[landed].mean()), "ambient_only": float(np.mean(amb)),
            "family": str(st["family"]), "candidates": int(landed.sum())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="test")
    ap.add_argument("--json", help="also write the numbers here")
    args = ap.parse_args()
    root = Path(args.data)
    manifest = json.loads((root / "manifest.json").read_text())
    rows = {s["id"]: scene_snrs(root / "scenes" / s["id"]) for s in manifest["splits"][args.split]}
    print(f"{'scene':12s} {'family':18s} {'T':>4s} {'oracle':>9s} {'center':>9s} {'random':>9s} {'ambient':>9s} "
          f"{'or/cen':>7s} {'or/rnd':>7s}")
    for sid, r in rows.items():
        print(f"{sid:12s} {r['family']:18s} {r['candidates']:4d} {r['oracle']:9.3g} {r['center']:9.3g} "
              f"{r['random']:9.3g} {r['ambient_only']:9.3g} {r['oracle'] / r['center']:7.2f} "
              f"{r['oracle'] / r['random']:7.2f}")
    mean = {k: float(np.mean([r[k] for r in rows.values()])) for k in ("oracle", "center", "random", "ambient_only")}
    print(f"mean SNR: oracle {mean['oracle']:.3g}, center {mean['center']:.3g}, random {mean['random']:.3g}, "
          f"ambient only {mean['ambient_only']:.3g}")
    print(f"oracle / center = {mean['oracle'] / mean['center']:.2f}x, oracle / random = "
          f"{mean['oracle'] / mean['random']:.2f}x (target >= 3x each)")
    if args.json:
        Path(args.json).write_text(json.dumps({"scenes": rows, "mean": mean}, indent=1))


if __name__ == "__main__":
    main()
