"""Held-out people of a fitted room photographed by Mitsuba 3 (issue 35, item 3), in three steps
that can run on different machines:

``export``  (where the body model is): the room model's scene, its spot's aim and the held-out
            people's meshes and albedos -> ``BUNDLE/`` (``room/``, an nlos-scene/1 directory, and
            ``people.npz``).
``render``  (a GPU when there is one; only Mitsuba, trimesh and the package needed): each person as
            ``experiments/camera-photographs/robustness.py``'s ``mitsuba`` condition renders it (the room with the person
            minus without, same seeds, the particle tracer at ``PHOTOGRAPH_DEPTH`` bounces; two halves at
            other seeds give the Monte Carlo noise), until a deadline -> one ``.npz`` rewritten after
            every person. ``--spp 0`` measures the first person and picks the samples that fit
            ``--people`` people in the time given.
``compare`` Mitsuba's photographs beside ours of the same people (``robustness.py``'s cached
            camera photographs and fifth bounce): the gain that best maps ours onto Mitsuba's and
            what is left, with the fifth bounce scaled by 0, 1 and ``BOUNCE_TAIL`` -> a text table.
``unpack``  the rendered people into ``experiments/camera-photographs/robustness.py``'s cache
            (``CACHE/ROOM/mitsuba-d6-sppSPP/NNNNN.npz``): ``robustness.py --mitsuba SPP`` reads them.
"""

from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path

import numpy as np

from nlos_spotlight.data.store import atomic_npz
from nlos_spotlight.render.mitsuba_ref import PHOTOGRAPH_DEPTH


def export(model: Path, people: int, out: Path, face: int | None) -> None:
    """``face``: the spot, for a fit still rendering its people (the aim as ``nlos fit`` will print
    it; the held-out people by the split rule, which ``unpack`` checks once the people exist)."""
    from nlos_spotlight.fit.run import finished_model, room_builder
    from nlos_spotlight.fit.spot import spot_record
    from nlos_spotlight.fit.train import split_period

    if face is None:
        cfg, aim, builder, dcfg = finished_model(model)
    else:
        from nlos_spotlight.fit.config import FitConfig

        cfg = FitConfig.from_record(json.loads((model / "fit.json").read_text())["settings"])
        builder, dcfg = room_builder(model, cfg)
        aim = np.asarray(spot_record(model, face)["aim"], np.float64)
    scene, _ = builder._room()
    specs = builder._specs(scene)
    images = dcfg.samples_per_scene - dcfg.transport_samples_per_scene  # all static in a fit
    period = split_period(images, cfg.heldout)
    idx = [p + dcfg.transport_samples_per_scene for p in range(period - 1, images, period)][:min(people, cfg.heldout)]
    verts, faces, nv, nf, albedo = [], [], [], [], []
    for k in idx:
        _, person, t = builder._person(specs[k], scene.hidden_region.floor_z)
        m = person.translated_mesh(t)
        verts.append(np.asarray(m.vertices, np.float64))
        faces.append(np.asarray(m.faces, np.int64))
        nv.append(len(m.vertices))
        nf.append(len(m.faces))
        albedo.append(np.asarray(specs[k]["params"].albedo, np.float64))
    out.mkdir(parents=True, exist_ok=True)
    shutil.copytree(model / "room", out / "room", dirs_exist_ok=True)
    np.savez_compressed(out / "people.npz", indices=np.asarray(idx), aim=aim, albedo=np.stack(albedo),
                        vertices=np.concatenate(verts), faces=np.concatenate(faces),
                        num_vertices=np.asarray(nv), num_faces=np.asarray(nf))
    print(f"{len(idx)} held-out people of {model} -> {out}")


def _load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _people(bundle: Path):
    from nlos_spotlight.scene.format import Human, TriMesh

    p = _load(bundle / "people.npz")
    ov, of = np.concatenate([[0], np.cumsum(p["num_vertices"])]), np.concatenate([[0], np.cumsum(p["num_faces"])])
    humans = [Human("human.ply", p["albedo"][n], TriMesh(p["vertices"][ov[n]:ov[n + 1]], p["faces"][of[n]:of[n + 1]]))
              for n in range(len(p["indices"]))]
    return p["indices"], p["aim"], humans


def _one(scene, human, aim, spp: int, k: int, depth: int = PHOTOGRAPH_DEPTH,
         protocol: str = "presence") -> tuple[np.ndarray, float]:
    import dataclasses

    from nlos_spotlight.render.mitsuba_ref import mitsuba_photograph

    return mitsuba_photograph(dataclasses.replace(scene, human=human), aim, spp, seed=1000 * int(k), max_depth=depth,
                              protocol=protocol)


def render(bundle: Path, out: Path, spp: int, people: int, seconds: float, device: str, max_spp: int,
           start: int = 0, depth: int = PHOTOGRAPH_DEPTH, protocol: str = "presence") -> None:
    from nlos_spotlight.render.mitsuba_ref import GPU_CHUNK_SPP, use_mitsuba
    from nlos_spotlight.scene.io import load_scene

    t0 = time.perf_counter()
    mi = use_mitsuba(device)
    scene = load_scene(bundle / "room")
    scene.human = None
    idx, aim, humans = _people(bundle)
    idx, humans = idx[start:], humans[start:]  # another machine's share
    people = min(people, len(idx))
    chunk = GPU_CHUNK_SPP if mi.variant().startswith("cuda") else 4096
    if spp <= 0:  # one person at two chunks a half sets the rate, then the samples that fit
        probe = 4 * chunk
        ts = time.perf_counter()
        _one(scene, humans[0], aim, probe, int(idx[0]))
        per_spp = (time.perf_counter() - ts) / probe
        spp = min(max_spp, int((seconds - (time.perf_counter() - t0)) / people / per_spp)) // (2 * chunk) * 2 * chunk
        print(f"probe: {per_spp * 1e6:.2f} us a sample a pixel a person -> {spp} samples a pixel", flush=True)
        if spp < 2 * chunk:
            raise SystemExit(f"{people} people do not fit in {seconds:.0f} s at {chunk} samples a pixel")
    imgs, noise, secs = [], [], []
    meta = {"spp": spp, "depth": depth, "variant": mi.variant(), "integrator": "ptracer",
            "protocol": protocol, "seed_rule": "1000 k + 500 h, h the half", "bundle": str(bundle)}
    for n in range(people):
        if time.perf_counter() - t0 > seconds:
            break
        ts = time.perf_counter()
        img, e = _one(scene, humans[n], aim, spp, int(idx[n]), depth, protocol)
        imgs.append(img)
        noise.append(e)
        secs.append(time.perf_counter() - ts)
        atomic_npz(out, presence=np.stack(imgs), noise=np.asarray(noise), indices=idx[:len(imgs)], aim=aim,
                   seconds=np.asarray(secs), meta=np.array(json.dumps(meta)))
        print(f"{n + 1}/{people} people, {secs[-1]:.1f} s, Monte Carlo noise {100 * e:.1f}%", flush=True)


def unpack(photographs: Path, cache: Path, room: str, model: Path) -> None:
    """Check the photographs are of ``model``'s held-out people under its spot, then unpack."""
    from nlos_spotlight.fit.run import finished_model
    from nlos_spotlight.fit.train import heldout_indices

    p = _load(photographs)
    cfg, aim, _, _ = finished_model(model)
    want = heldout_indices(model, cfg)[:len(p["indices"])]
    if list(p["indices"]) != want or not np.allclose(p["aim"], aim, atol=1e-9):
        raise SystemExit(f"{photographs}: not {model}'s held-out people under its spot")
    meta = json.loads(str(p["meta"]))
    d = cache / room / f"mitsuba-d{meta['depth']}-spp{meta['spp']}"
    d.mkdir(parents=True, exist_ok=True)
    for img, e, k in zip(p["presence"], p["noise"], p["indices"]):
        atomic_npz(d / f"{int(k):05d}.npz", presence=img, noise=np.float64(e))
    print(f"{len(p['indices'])} people ({meta['variant']}, {meta['spp']} samples a pixel, Monte Carlo noise median "
          f"{100 * np.median(p['noise']):.1f}%) -> {d}; read with robustness.py --mitsuba {meta['spp']} "
          f"--mitsuba-people {len(p['indices'])}")


def compare(photographs: Path, camera: Path, bounce: Path, out: Path | None) -> str:
    """Ours (the camera photographs' person light and shadow, plus the fifth bounce times 0, 1 and
    ``BOUNCE_TAIL``) against Mitsuba's on the same people: the least-squares gain over all people
    (zero-mean Monte Carlo noise does not bias it) with a bootstrap 95% interval over the people, the
    residual after that gain relative to Mitsuba's light with Mitsuba's own noise removed in quadrature,
    and the median per-person correlation."""
    from nlos_spotlight.render.bounce import BOUNCE_TAIL

    m, cam, bn = _load(photographs), _load(camera), _load(bounce)
    n = len(m["indices"])
    if list(cam["indices"][:n]) != list(m["indices"]) or list(bn["indices"][:n]) != list(m["indices"]):
        raise SystemExit("the camera photographs, the bounce and Mitsuba's are not of the same people")
    mits = m["presence"].astype(np.float64).reshape(n, -1)
    noise2 = (m["noise"] * np.linalg.norm(mits, axis=1)) ** 2  # each image's Monte Carlo error, squared
    rng = np.random.default_rng(0)
    meta = json.loads(str(m["meta"]))
    lines = [f"{n} people, Mitsuba {meta['spp']} samples a pixel, depth {meta['depth']}, "
             f"its Monte Carlo noise median {100 * np.median(m['noise']):.1f}%",
             "ours                                   gain (95%)            residual  correlation (median)"]
    for k in (0.0, 1.0, BOUNCE_TAIL):
        ours = (cam["cam_nlos"][:n] + k * bn["bounce_nlos"][:n] + cam["cam_nlos_shadow"][:n]).reshape(n, -1)
        gain = lambda i: float((ours[i] * mits[i]).sum() / (ours[i] ** 2).sum())
        boot = [gain(rng.integers(0, n, n)) for _ in range(2000)]
        g = gain(np.arange(n))
        resid = np.sqrt(max(float(((mits - g * ours) ** 2).sum() - noise2.sum()), 0.0) / (mits ** 2).sum())
        corr = np.median([np.corrcoef(o, t)[0, 1] for o, t in zip(ours, mits)])
        name = "three bounces + shadow" if k == 0 else f"+ the fifth bounce x{k:g}"
        lines.append(f"{name:38s} {g:5.3f} ({np.percentile(boot, 2.5):.3f}-{np.percentile(boot, 97.5):.3f})"
                     f"   {100 * resid:5.1f}%     {corr:.3f}")
    three = (cam["cam_nlos"][:n] + cam["cam_nlos_shadow"][:n]).reshape(n, -1)
    fifth = bn["bounce_nlos"][:n].reshape(n, -1)
    joint = lambda i: np.linalg.lstsq(np.stack([three[i].ravel(), fifth[i].ravel()], 1), mits[i].ravel(), rcond=None)[0]
    jb = np.array([joint(rng.integers(0, n, n)) for _ in range(500)])
    j, lo, hi = joint(np.arange(n)), np.percentile(jb, 2.5, 0), np.percentile(jb, 97.5, 0)
    lines.append(f"both at once: Mitsuba = {j[0]:.3f} ({lo[0]:.3f}-{hi[0]:.3f}) x (three bounces + shadow) + "
                 f"{j[1]:.3f} ({lo[1]:.3f}-{hi[1]:.3f}) x the fifth bounce")
    text = "\n".join(lines)
    if out is not None:
        out.write_text(text + "\n")
    print(text)
    return text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="step", required=True)
    e = sub.add_parser("export")
    e.add_argument("--model", type=Path, required=True)
    e.add_argument("--people", type=int, default=100)
    e.add_argument("--out", type=Path, required=True)
    e.add_argument("--face", type=int, default=None, help="the spot of a fit still rendering (else its report's)")
    r = sub.add_parser("render")
    r.add_argument("--bundle", type=Path, required=True)
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--spp", type=int, default=0, help="samples a pixel (0: what fits --seconds)")
    r.add_argument("--people", type=int, default=100)
    r.add_argument("--seconds", type=float, default=3600.0)
    r.add_argument("--device", default="auto", choices=("auto", "cpu", "cuda"))
    r.add_argument("--depth", type=int, default=PHOTOGRAPH_DEPTH, help="Mitsuba's max_depth (4: our three bounces)")
    r.add_argument("--protocol", default="presence", choices=("presence", "scatter", "blocked"),
                   help="the photograph (presence) or one part of it: the light off the body (scatter), the light it stops (blocked)")
    r.add_argument("--start", type=int, default=0, help="skip the first people (rendered elsewhere)")
    r.add_argument("--max-spp", type=int, default=1 << 22, help="at most this many samples a pixel (--spp 0)")
    u = sub.add_parser("unpack")
    u.add_argument("--photographs", type=Path, required=True)
    u.add_argument("--cache", type=Path, required=True)
    u.add_argument("--room", required=True)
    u.add_argument("--model", type=Path, required=True, help="the room model the photographs are of")
    c = sub.add_parser("compare")
    c.add_argument("--photographs", type=Path, required=True)
    c.add_argument("--camera", type=Path, required=True, help="robustness.py's cached camera photographs (camera-*.npz)")
    c.add_argument("--bounce", type=Path, required=True, help="robustness.py's cached fifth bounce (bounce-*.npz)")
    c.add_argument("--out", type=Path, default=None)
    a = ap.parse_args()
    if a.step == "export":
        export(a.model, a.people, a.out, a.face)
    elif a.step == "render":
        render(a.bundle, a.out, a.spp, a.people, a.seconds, a.device, a.max_spp, a.start, a.depth, a.protocol)
    elif a.step == "compare":
        compare(a.photographs, a.camera, a.bounce, a.out)
    else:
        unpack(a.photographs, a.cache, a.room, a.model)


if __name__ == "__main__":
    main()
