"""Which postures give the walls the same light? An ideal observer's distance between postures.

For held-out people of the training rooms (the test people of ``nlos_spotlight.train.recipe``,
re-posed from the dataset's deterministic specs), the person's light under the room's best stored
spot (the oracle among them, ``spots.json``'s ``snr_top[0]``) is rendered in each of the six
postures with everything else the same (place, facing, height, build, clothing albedo, pose seed).
For postures a and b the difference delta = mu_a - mu_b is whitened by the default capture's
noise (``render.sensor.noise_variance_dn``, metered on the person-free frame, the burst included),
and two distances are reported:

* ``d_known``: ||delta / sigma||, postures told apart when everything else is known;
* ``d_nuisance``: the part of it no change of the nuisances can explain, to first order:
  ||(I - P_J) delta / sigma|| with P_J the projection on the whitened image derivatives with
  respect to floor x and y, facing, height and the three albedo channels (central differences,
  averaged over a and b). Build and pose jitter vary too in the data but are not differentiable
  here (cached body variants), so this distance is an upper bound on what separates the classes.

An ideal observer confuses two classes with probability Phi(-d / 2) (Gaussian, equal priors): d < 2
means more than 16% pairwise error. The same distances between one posture and itself at another
pose seed (``self``, a library variant with other jitter) show how far the light moves within a
class. Whitened distances grow as the square root of the frames averaged, so ``frames_for_d4`` is
the burst an ideal observer would need for d = 4 (2.3% pairwise error). Prints per-pair medians and
writes ``--json``.

Six-way, the same renders give an ideal observer's accuracy (``evaluate.ideal_observer``: nearest
posture with everything else known, and with the seven nuisances fitted to first order), for one
frame and for ``--frames`` (a burst): the ceiling that no network reading the photograph can pass,
mean over the people. With ``--split test`` the people are the first static people of each room of
a test dataset (``unseen-test.yaml``: rooms no network trained in), under the room's oracle spot.

    python experiments/physics-bounds/posture_separability.py --data out/lc/data --people 6
    python experiments/physics-bounds/posture_separability.py --data out/unseen/test --split test --people 3 \
        --json docs/results/posture-ceiling-unseen.json
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
from pathlib import Path

import numpy as np
import torch
from scipy.stats import norm

from nlos_spotlight.data.config import DatasetConfig, read_dataset_config
from nlos_spotlight.data.generate import plan
from nlos_spotlight.evaluate.crb import PERSON
from nlos_spotlight.evaluate.dataset_people import room_renderer, seen_test_specs, static_specs
from nlos_spotlight.evaluate.ideal_observer import ideal_observer
from nlos_spotlight.fit.ceiling import jacobian  # the nuisance steps and derivatives of the fit's ceiling
from nlos_spotlight.lighting.snr import candidate_snr
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.sensor import SensorConfig
from nlos_spotlight.render.sensor import auto_exposure, dn_per_radiance, noise_variance_dn
from nlos_spotlight.render.transport import Renderer
from nlos_spotlight.world.body import POSTURES, posed_body

def light(r: Renderer, y: torch.Tensor, params, t: np.ndarray, cfg: DatasetConfig) -> torch.Tensor:
    """(H, W, 3) the person's light (the image terms that depend on the person), radiance units."""
    body = posed_body(params, target_faces=cfg.body_faces)
    person = Person.sampled(body, params.albedo, cfg.render)
    return r.render(y, person, translation=t, components=PERSON).image.double()


def distances(delta: torch.Tensor, jac: torch.Tensor, sigma: torch.Tensor) -> tuple[float, float]:
    """(d_known, d_nuisance) of a difference (P,) with nuisance derivatives (P, K), noise sigma (P,)."""
    d = delta / sigma
    j = jac / sigma[:, None]
    coef = torch.linalg.lstsq(j, d[:, None]).solution
    return float(d.norm()), float((d - (j @ coef)[:, 0]).norm())


def room_people(cfg: DatasetConfig, p, builder, scene, people: int, split: str) -> list[dict]:
    """The people whose postures are compared: the seen-room test people of a training room, or the
    first static people of a test room."""
    if split == "train":
        return seen_test_specs(cfg, p, builder, scene, people)
    return static_specs(builder, scene, people)


def oracle_face(data: Path, room: str) -> int:
    """The room's best spot: ``spots.json``'s first by SNR, else the stored people's SNR argmax."""
    spots = data / "scenes" / room / "spots.json"
    if spots.exists():
        return int(json.loads(spots.read_text())["snr_top"][0])
    return int(np.argmax(candidate_snr(data / "scenes" / room)))


def six_way(mu: dict, jac: dict, sigma: torch.Tensor, frames: list[int]) -> dict:
    """Ideal observers' six-way confusion matrices for one person, per frame count."""
    means = torch.stack([mu[q].reshape(-1) / sigma for q in POSTURES])
    jacs = torch.stack([jac[q] / sigma[:, None] for q in POSTURES])
    return {f: ideal_observer(means, jacs, frames=f, draws=4000) for f in frames}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True)
    ap.add_argument("--people", type=int, default=6, help="test people per room")
    ap.add_argument("--rooms", type=int, default=0, help="first ROOMS training rooms (0: all)")
    ap.add_argument("--json", default="docs/results/posture-separability.json")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--split", default="train", choices=("train", "test"), help="rooms the people come from")
    ap.add_argument("--frames", type=int, default=16, help="burst for the six-way ceiling beside one frame")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    data = Path(args.data)
    cfg = read_dataset_config(data)
    rooms = [p for p in plan(cfg) if p.split == args.split]
    rooms = rooms[:args.rooms] if args.rooms else rooms
    pairs = list(itertools.combinations(POSTURES, 2)) + [(p, p) for p in POSTURES]
    found: dict[str, list[tuple[float, float]]] = {f"{a}/{b}": [] for a, b in pairs}
    snr: list[float] = []
    frames = sorted({1, args.frames})
    conf = {f: [] for f in frames}
    for p in rooms:
        face = oracle_face(data, p.id)
        b, scene, r = room_renderer(cfg, p, data, [face])
        y = r.spot_vector(0)
        sensor = SensorConfig.at(r.shape)
        static = r.render(y, None, components=("direct", "ambient")).image.double()
        exposure = auto_exposure(static, sensor)
        k = dn_per_radiance(exposure, sensor)
        for spec in room_people(cfg, p, b, scene, args.people, args.split):
            base, t = spec["params"], np.array([*spec["position"], scene.hidden_region.floor_z])
            per = {q: dataclasses.replace(base, posture=q) for q in POSTURES}
            mu = {q: light(r, y, per[q], t, cfg) for q in POSTURES}
            jac = {q: jacobian(r, y, per[q], t, cfg) for q in POSTURES}
            sigma = noise_variance_dn(((static + mu["standing"]) * k).clamp(min=0), sensor).sqrt().reshape(-1) / k
            for a, b2 in pairs:
                if a == b2:  # the same posture at another pose seed: the spread within a class
                    other = dataclasses.replace(per[a], pose_seed=per[a].pose_seed + 7919)
                    delta = (mu[a] - light(r, y, other, t, cfg)).reshape(-1)
                else:
                    delta = (mu[a] - mu[b2]).reshape(-1)
                found[f"{a}/{b2}"].append(distances(delta, (jac[a] + jac[b2 if a != b2 else a]) / 2, sigma))
            snr.append(float((mu["standing"].reshape(-1) / sigma).norm()))
            obs = six_way(mu, jac, sigma, frames)
            for f in frames:
                conf[f].append(obs[f])
            acc = " ".join(f"{f} frame(s) {100 * obs[f].accuracy[0]:.0f}% / {100 * obs[f].accuracy[1]:.0f}%" for f in frames)
            print(f"room {p.id} person {spec['index']}: exposure {exposure:.3f} s, person SNR {snr[-1]:.1f}, "
                  f"six-way ideal observer (known / nuisances fitted): {acc}", flush=True)
    out = {"person_snr_median": round(float(np.median(snr)), 2), "burst_frames": SensorConfig.at((1, 1)).burst_frames,
           "split": args.split, "people": len(snr), "postures": list(POSTURES)}
    for f in frames:
        known = torch.stack([o.known for o in conf[f]]).mean(0)
        fitted = torch.stack([o.nuisance for o in conf[f]]).mean(0)
        out[f"six_way_{f}_frames"] = {
            "known": round(float(known.diagonal().mean()), 4), "nuisance": round(float(fitted.diagonal().mean()), 4),
            "nuisance_median_person": round(float(np.median([o.accuracy[1] for o in conf[f]])), 4),
            "confusion_nuisance": np.round(fitted.numpy(), 3).tolist()}
        print(f"six-way ideal observer, {f} frame(s), mean over {len(conf[f])} people: "
              f"{100 * known.diagonal().mean():.1f}% everything else known, "
              f"{100 * fitted.diagonal().mean():.1f}% nuisances fitted")
    print(f"person's light over the noise (standing, whitened norm): median {np.median(snr):.1f} over {len(snr)}")
    print(f"{'pair':24s} {'d_known':>9s} {'d_nuisance':>11s} {'error':>7s} {'frames for d=4':>15s}  (medians)")
    for key, v in found.items():
        if not v:
            continue
        dk, dn = (float(np.median([x[j] for x in v])) for j in (0, 1))
        frames = (4 / max(dn, 1e-9)) ** 2  # d grows as sqrt(frames averaged)
        out[key] = {"d_known": round(dk, 2), "d_nuisance": round(dn, 2),
                    "pairwise_error": round(float(norm.cdf(-dn / 2)), 4), "frames_for_d4": round(frames, 1),
                    "people": len(v)}
        print(f"{key:24s} {dk:9.1f} {dn:11.1f} {100 * norm.cdf(-dn / 2):6.1f}% {frames:15.0f}")
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(out, indent=1))
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
