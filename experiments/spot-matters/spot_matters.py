"""Does the spot matter? NLOS signal-to-noise ratio of the oracle, center and random spots.

For every held-out scene of a generated dataset and every candidate spot t, the camera auto-exposes
on the person-free image (direct_t + ambient), and the NLOS signal s = nlos_t (in digital numbers)
is compared with the sensor noise of the whole image (shot noise of everything, read noise,
quantization): SNR_t = sqrt(sum_p s_p^2 / var_p), the matched-filter detectability of the person.
Per scene SNR_t is averaged over the static samples; then

* oracle: the best candidate (exhaustive search),
* center: the candidate whose aim point is nearest the center of the camera image,
* random: the mean over candidates whose spot lands (the expected value of a random choice),
* ambient only: no projector; the signal is ``nlos_ambient``, exposure on ``ambient``;
* with ``--adaptive``, Adaptive Lighting's spot (the ``adaptive`` policy, which reads the scan only)
  and its SNR over the oracle's, with the share of rooms below 0.62x and 0.75x of it (a fitted
  room's posture does not drop between 0.62x and 1x: docs/results.md, "Does the spot matter in the dark?").

Also, in radiance (before any exposure): the person's light with the projector off over the
person's light under the oracle spot, sum |nlos_ambient| / sum |nlos_oracle| ("amb/or light"); and
the SNR of that same hidden-region light (``nlos_ambient``) inside the oracle spot's photograph
("amb in or"): exposed for the spot on the wall, the photograph keeps less of it than the
projector-off one does.

The SNR and the center choice are the package's (``nlos_spotlight.lighting.snr``, ``.center``).

    python experiments/spot-matters/spot_matters.py --data DIR [--split test] [--rooms N]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from nlos_spotlight.data.static import read_static
from nlos_spotlight.data.tensors import finished_scene_dirs
from nlos_spotlight.errors import NlosError
from nlos_spotlight.lighting.center import center_candidate
from nlos_spotlight.lighting.snr import scene_snr, snr
from nlos_spotlight.render.sensor import SensorConfig, auto_exposure
from nlos_spotlight.scene import load_scene


def ambient_light(scene_dir: Path, st, scene, oracle: int) -> tuple[float, float]:
    """Over a scene's static samples: sum |nlos_ambient| / sum |nlos under the oracle spot|
    (radiance), and the mean SNR of ``nlos_ambient`` inside the oracle spot's photograph (``st``:
    its static.npz, ``scene``: its loaded scene)."""
    static = torch.as_tensor(st["direct"][oracle] + st["ambient"]).double()
    cfg = SensorConfig.for_scene(scene)
    exposure = auto_exposure(static, cfg)  # metered on the spot's person-free photograph
    amb, spot_sum, amb_snr = 0.0, 0.0, []
    for path in sorted((scene_dir / "samples").glob("*.npz")):
        with np.load(path) as z:
            if int(z["trajectory"]) >= 0:
                continue
            spot = np.einsum("r,rhwc->hwc", z["transport_u"][oracle], z["transport_v"])
            na = z["nlos_ambient"]
            amb += float(np.abs(na).sum())
            spot_sum += float(np.abs(spot).sum())
            na_t = torch.as_tensor(na).double()
            amb_snr.append(snr(na_t, static + torch.as_tensor(spot).double() + na_t, exposure, cfg))
    return amb / max(spot_sum, 1e-30), float(np.mean(amb_snr))


def adaptive_candidate(scene_dir: Path) -> int:
    """The candidate Adaptive Lighting lights in a scene (deterministic: it reads the scan only)."""
    from nlos_spotlight.data.tensors import load_scene_tensors
    from nlos_spotlight.evaluate.unseen import room_lights

    return int(room_lights([load_scene_tensors(scene_dir, [], samples="transport")], "adaptive", 0)[0].face)


def scene_snrs(scene_dir: Path, adaptive: bool = False) -> dict:
    st = read_static(scene_dir)
    landed = st["spot_landed"]
    r = scene_snr(scene_dir)
    mean_t = r.candidates
    scene = load_scene(scene_dir)
    center = center_candidate(scene.camera, st["aim_points"], landed)
    ratio, amb_in_oracle = ambient_light(scene_dir, st, scene, int(mean_t.argmax()))
    out = {"oracle": float(mean_t.max()), "center": float(mean_t[center]),
           "random": float(mean_t[landed].mean()), "ambient_only": r.ambient,
           "family": str(st["family"]), "candidates": int(landed.sum()),
           "ambient_light_ratio": ratio, "ambient_in_oracle": amb_in_oracle}
    if adaptive:
        out["adaptive"] = float(mean_t[adaptive_candidate(scene_dir)])
    return out


def over(a: float, b: float) -> float:
    """a / b, infinite where b is 0 (a center spot that lands where the camera sees no person light)."""
    return a / b if b > 0 else float("inf")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="test")
    ap.add_argument("--rooms", type=int, default=0, help="only the split's first ROOMS scenes (0: all)")
    ap.add_argument("--json", help="also write the numbers here")
    ap.add_argument("--adaptive", action="store_true", help="also Adaptive Lighting's spot (its SNR over the oracle's)")
    args = ap.parse_args()
    try:  # a dataset generated in shards and not merged: the scenes finished so far
        scenes = finished_scene_dirs(args.data, args.split)[:args.rooms or None]
        if not scenes:
            raise SystemExit(f"{args.data}: no finished {args.split} scenes")
        rows = {d.name: scene_snrs(d, args.adaptive) for d in scenes}
    except NlosError as exc:
        raise SystemExit(str(exc)) from None
    print(f"{'scene':12s} {'family':18s} {'T':>4s} {'oracle':>9s} {'center':>9s} {'random':>9s} {'ambient':>9s} "
          f"{'or/cen':>7s} {'or/rnd':>7s} {'amb/or light':>12s} {'amb in or':>9s}")
    for sid, r in rows.items():
        print(f"{sid:12s} {r['family']:18s} {r['candidates']:4d} {r['oracle']:9.3g} {r['center']:9.3g} "
              f"{r['random']:9.3g} {r['ambient_only']:9.3g} {over(r['oracle'], r['center']):7.2f} "
              f"{over(r['oracle'], r['random']):7.2f} {r['ambient_light_ratio']:12.3f} {r['ambient_in_oracle']:9.3g}")
    mean = {k: float(np.mean([r[k] for r in rows.values()]))
            for k in ("oracle", "center", "random", "ambient_only", "ambient_in_oracle")}
    print(f"mean SNR: oracle {mean['oracle']:.3g}, center {mean['center']:.3g}, random {mean['random']:.3g}, "
          f"ambient only {mean['ambient_only']:.3g}")
    print(f"oracle / center = {mean['oracle'] / mean['center']:.2f}x, oracle / random = "
          f"{mean['oracle'] / mean['random']:.2f}x (target >= 3x each)")
    ratios = [r["ambient_light_ratio"] for r in rows.values()]
    print(f"projector-off person light / oracle-spot person light (radiance): median {np.median(ratios):.3f}, "
          f"range {min(ratios):.3f}-{max(ratios):.3f}")
    kept = [r["ambient_in_oracle"] / r["ambient_only"] for r in rows.values()]
    print(f"the hidden region's light on the person: SNR {mean['ambient_in_oracle']:.3g} in the oracle spot's "
          f"photograph against {mean['ambient_only']:.3g} with the projector off (median ratio {np.median(kept):.3f}, "
          f"range {min(kept):.3f}-{max(kept):.3f})")
    if args.adaptive:
        frac = np.array([r["adaptive"] / r["oracle"] for r in rows.values()])
        print("Adaptive Lighting's SNR over the oracle's per room: " + ", ".join(
            f"{sid} {f:.3f}" for sid, f in zip(rows, frac)))
        print(f"Adaptive Lighting over the oracle: mean {frac.mean():.3f}, median {np.median(frac):.3f}; below "
              f"0.62x in {int((frac < 0.62).sum())} of {len(frac)} rooms, below 0.75x in {int((frac < 0.75).sum())}")
    if args.json:
        Path(args.json).write_text(json.dumps({"scenes": rows, "mean": mean}, indent=1))


if __name__ == "__main__":
    main()
