"""The person's SNR under the camera as used (DESIGN section 6, revised) against the first sensor model.

For every room of a dataset, under its oracle spot (best candidate by NLOS SNR under the current
sensor) and averaged over the room's full-transport people:

* **current**: average metering (person-free frame mean at 18 % of full scale, at most 1 s),
  quantization per native pixel before binning (n/12 DN^2), clipped pixels carry nothing;
* **first version**: highlight metering (99.5th percentile at 80 % of full scale) and the binned
  sum quantized once (1/12 of a binned code whose step is n native full wells / 2^14), the
  model this project shipped before the revision, in closed form here.

Both in electrons: SNR = sqrt(sum_p s_p^2 / var_p). A room "has a lamp in view" when its
ambient image (emission included) has pixels 20x brighter than its median. Also reported: both
exposures.

    python benchmarks/sensor_snr.py --data out/demo/data [--split train]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.data.static import read_static
from nlos_spotlight.lighting.snr import candidate_snr
from nlos_spotlight.render.sensor import SensorConfig, auto_exposure, noise_variance_dn
from nlos_spotlight.scene import load_scene
from nlos_spotlight.data.tensors import split_ids


def snr_electrons(signal, total, exposure: float, cfg: SensorConfig, old: bool) -> float:
    """sqrt(sum s^2 / var), in electrons; ``old``: one quantization of the binned code."""
    k = exposure * cfg.electrons_per_radiance
    s, mu = signal * k, total.clamp(min=0) * k
    if old:
        g_old = cfg.max_code / cfg.full_well_binned_e  # the binned well mapped onto 14 bits
        var = mu + cfg.read_noise_binned_e**2 + 1 / 12 / g_old**2
        ok = mu < cfg.full_well_binned_e
    else:
        var = noise_variance_dn(mu * cfg.gain, cfg) / cfg.gain**2
        ok = mu * cfg.gain < cfg.full_scale_dn
    return float(torch.sqrt((s * s / var * ok).sum()))


def room(scene_dir: Path) -> dict:
    cfg = SensorConfig.for_scene(load_scene(scene_dir))
    old_cfg = SensorConfig.from_dict({**cfg.to_dict(), "metering": "highlight"})
    st = read_static(scene_dir, "direct", "ambient")
    t = int(np.argmax(candidate_snr(scene_dir)))
    static = torch.as_tensor(st["direct"][t] + st["ambient"]).double()
    amb = st["ambient"].sum(-1)
    lamp = bool(amb.max() > 20 * np.median(amb))
    e_new, e_old = auto_exposure(static, cfg), auto_exposure(static, old_cfg)
    new, old = [], []
    for path in sorted((scene_dir / "samples").glob("*.npz")):
        z = np.load(path)
        if int(z["trajectory"]) >= 0:
            continue
        nl = torch.as_tensor(np.einsum("r,rhwc->hwc", z["transport_u"][t], z["transport_v"])).double()
        total = static + nl + torch.as_tensor(z["nlos_ambient"]).double()
        new.append(snr_electrons(nl, total, e_new, cfg, old=False))
        old.append(snr_electrons(nl, total, e_old, old_cfg, old=True))
    return {"lamp": lamp, "exposure_new": e_new, "exposure_old": e_old, "snr_new": float(np.mean(new)),
            "snr_old": float(np.mean(old))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="train")
    args = ap.parse_args()
    torch.set_num_threads(1)
    rows = []
    print(f"{'scene':12s} lamp  exposure old -> new     SNR old -> new   gain")
    data = Path(args.data)
    ids = split_ids(data, args.split) if (data / "manifest.json").exists() else \
        sorted(p.name for p in (data / "scenes").glob(f"{args.split}-*") if (p / "static.npz").exists())
    for sid in ids:
        r = room(Path(args.data) / "scenes" / sid)
        rows.append(r)
        print(f"{sid:12s} {'yes' if r['lamp'] else 'no ':4s} {r['exposure_old']:9.4f} -> {r['exposure_new']:7.4f} s "
              f"{r['snr_old']:8.2f} -> {r['snr_new']:8.2f}  {r['snr_new'] / max(r['snr_old'], 1e-30):6.1f}x")
    for lamp in (True, False):
        sel = [r for r in rows if r["lamp"] == lamp]
        if sel:
            g = np.array([r["snr_new"] / max(r["snr_old"], 1e-30) for r in sel])
            print(f"rooms {'with' if lamp else 'without'} a lamp in view: {len(sel)}, SNR gain median "
                  f"{np.median(g):.1f}x (min {g.min():.1f}x, max {g.max():.1f}x)")


if __name__ == "__main__":
    main()
