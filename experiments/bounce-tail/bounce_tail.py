"""Every bounce past the fourth in a photograph, split into the light off the body and the light
the body stops, by Mitsuba 3 against ours (issue 35: what ``--bounce-scale`` should be, per room).

``scenes``  the reference scenes: Mitsuba's particle tracer at ``max_depth`` 4 and ``--depth``,
            ``scatter`` (the person minus a black person: the light off the body) and ``blocked``
            (the black person minus no person: the light the body stops), same seeds; ours
            ``nlos``, ``nlos_shadow``, ``nlos_bounce`` and the room's relay ratios
            (``render.tail.room_tail``) -> a text table.
``cost``    the time a person of the shadow to depth 10 against 4, on a bundle's people.
``room``    a fitted room's held-out people from ``experiments/mitsuba-photographs`` files
            (``presence`` and ``blocked`` at depths 4 and ``--depth``, same seeds) beside ours of the
            same people (``experiments/camera-photographs/robustness.py``'s cached camera photographs and fifth bounce)
            and the room's relay ratios -> the same table.

Each entry is a least-squares gain of Mitsuba's light onto ours (zero-mean Monte Carlo noise does
not bias it); for a room, with a bootstrap 95% interval over the people.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

COLUMNS = ("scatter past the fourth / ours' fifth", "blocked at 4 / ours' shadow",
           "blocked past the fourth / ours' shadow", "ours' shadow past the fourth / ours' shadow",
           "blocked past the fourth / ours' shadow past the fourth",
           "photograph / ours (three + shadow to the depth + 1.9 x fifth)",
           "photograph / ours before (three + shadow + 1.9 x fifth)",
           "the room's power ratios r_0 + r_0 r_1 + ... (render.tail.RelayTransfer.ratios) to the depth")


def power_tail(r, depth: int) -> float:
    """T - 1 of a scalar tail model: the room's relay power ratios from the spot's first relay
    (``RelayTransfer.ratios``), summed as a geometric series to ``depth``; a renderer at that
    ``shadow_depth``."""
    from nlos_spotlight.render.bounce import spot_radiance
    from nlos_spotlight.render.shadow import SpotShadow

    y = r.spot_vector(0)
    sh = SpotShadow(r, 0.5)
    room = sh.room(y)
    ratios = room.transfer.ratios(spot_radiance(sh, y)[:, ::len(sh.h["pos"]) // len(room.pos)].cpu(), depth - 5)
    return float(np.cumprod(ratios).sum())


def gain(ours: np.ndarray, ref: np.ndarray) -> float:
    """The g minimising |ref - g ours|^2 over all pixels (and people)."""
    return float((ours * ref).sum() / (ours ** 2).sum())


def legend() -> list[str]:
    return ["columns: " + "; ".join(f"({k + 1}) {c}" for k, c in enumerate(COLUMNS)),
            _row("", [f"({k + 1})" for k in range(len(COLUMNS))])]


def _row(name: str, vals: list[str]) -> str:
    return f"{name:16s} " + "  ".join(f"{v:>18s}" for v in vals)


def scenes(names: list[str], spp: int, res: int, depth: int) -> list[str]:
    import torch

    from nlos_spotlight.render.bounce import BOUNCE_TAIL
    from nlos_spotlight.render.mitsuba_ref import mitsuba_nlos
    from nlos_spotlight.render.person import Person
    from nlos_spotlight.render.transport import Renderer, RenderSettings
    from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene

    settings = RenderSettings(pixel_samples=2, transport_pixel_samples=2, spot_samples=128, person_samples=1024,
                              shadow_samples=4096, dtype="float64")
    lines = [f"# python experiments/bounce-tail/bounce_tail.py scenes --spp {spp} --res {res} --depth {depth}",
             *legend()]
    print("\n".join(lines), flush=True)
    for name in names:
        t0 = time.perf_counter()
        sc = corner_scene(name, res)
        r = Renderer(sc, settings, aim_points=SPOT_TARGET[None])
        person = Person.from_mesh(sc.human.mesh, sc.human.albedo, settings.person_samples)
        y = r.spot_vector(0)
        rd = Renderer(sc, dataclasses.replace(settings, shadow_depth=depth), aim_points=SPOT_TARGET[None])
        with torch.no_grad():
            ours = {k: v.numpy() for k, v in r.render(y, person, components=("nlos", "nlos_shadow", "nlos_bounce")).components.items()}
            ours["shadow_d"] = rd.render(y, person, components=("nlos_shadow",))["nlos_shadow"].numpy()
        m = {(p, d): mitsuba_nlos(sc, SPOT_TARGET, spp, seed=3, max_depth=d, protocol=p, integrator="ptracer")
             for p in ("scatter", "blocked") for d in (4, depth)}
        photo = {d: m["scatter", d] + m["blocked", d] for d in (4, depth)}
        three, sh, fifth, tail = ours["nlos"], ours["nlos_shadow"], ours["nlos_bounce"], ours["shadow_d"] - ours["nlos_shadow"]
        vals = [gain(fifth, m["scatter", depth] - m["scatter", 4]), gain(sh, m["blocked", 4]),
                gain(sh, m["blocked", depth] - m["blocked", 4]), gain(sh, tail),
                gain(tail, m["blocked", depth] - m["blocked", 4]),
                gain(three + sh + tail + BOUNCE_TAIL * fifth, photo[depth]),
                gain(three + sh + BOUNCE_TAIL * fifth, photo[depth]), power_tail(rd, depth)]
        lines.append(_row(name, [f"{v:.3f}" for v in vals]) + f"   ({time.perf_counter() - t0:.0f} s)")
        print(lines[-1], flush=True)
    return lines


def _load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def ours_tail(bundle: Path, n: int, depth: int) -> tuple[np.ndarray, float]:
    """(n, H * W * 3) ours' shadow past the first relay (``shadow_depth`` ``depth`` minus 4, the same
    relay points) of the bundle's first n people, at the fit's sampling; the room's :func:`power_tail`."""
    import torch

    from nlos_spotlight.render.person import Person
    from nlos_spotlight.render.transport import Renderer, RenderSettings
    from nlos_spotlight.scene.format import Human, TriMesh
    from nlos_spotlight.scene.io import load_scene

    scene = load_scene(bundle / "room")
    scene.human = None
    p = _load(bundle / "people.npz")
    aim = np.asarray(p["aim"]).reshape(1, 3)
    ov, of = np.concatenate([[0], np.cumsum(p["num_vertices"])]), np.concatenate([[0], np.cumsum(p["num_faces"])])
    base = RenderSettings(pixel_footprint=8, shadow_samples=4096, person_samples=1500)
    rs = [Renderer(scene, dataclasses.replace(base, shadow_depth=d), aim_points=aim) for d in (4, depth)]
    out = []
    for k in range(n):
        h = Human("human.ply", p["albedo"][k], TriMesh(p["vertices"][ov[k]:ov[k + 1]], p["faces"][of[k]:of[k + 1]]))
        person = Person.from_mesh(h.mesh, h.albedo, 1500, "faces")
        with torch.no_grad():
            sh = [r.render(r.spot_vector(0), person, components=("nlos_shadow",))["nlos_shadow"].numpy() for r in rs]
        out.append((sh[1] - sh[0]).ravel())
    return np.stack(out).astype(np.float64), power_tail(rs[1], depth)


def room(mitsuba: Path, room_name: str, spp: int, depth: int, camera: Path, bounce: Path, bundle: Path) -> list[str]:
    """Mitsuba's files ``mitsuba/ROOM-{d4,dD}-sppSPP.npz`` (presence) and
    ``ROOM-blocked-{d4,dD}-sppSPP.npz``; ours' shadow past the first relay rendered from the bundle."""
    from nlos_spotlight.render.bounce import BOUNCE_TAIL

    f = {(p, d): _load(mitsuba / f"{room_name}{'-blocked' if p == 'blocked' else ''}-d{d}-spp{spp}.npz")
         for p in ("presence", "blocked") for d in (4, depth)}
    n = min(len(v["indices"]) for v in f.values())
    idx = list(f["presence", 4]["indices"][:n])
    cam, bn = _load(camera), _load(bounce)
    if any(list(v["indices"][:n]) != idx for v in f.values()) or list(cam["indices"][:n]) != idx \
            or list(bn["indices"][:n]) != idx:
        raise SystemExit("Mitsuba's files and ours are not of the same people")
    m = {k: v["presence"][:n].reshape(n, -1).astype(np.float64) for k, v in f.items()}
    scat = {d: m["presence", d] - m["blocked", d] for d in (4, depth)}  # same seeds: presence = scatter + blocked
    three = cam["cam_nlos"][:n].reshape(n, -1)
    shadow = cam["cam_nlos_shadow"][:n].reshape(n, -1)
    fifth = bn["bounce_nlos"][:n].reshape(n, -1)
    tail, power = ours_tail(bundle, n, depth)
    pairs = [(fifth, scat[depth] - scat[4]), (shadow, m["blocked", 4]), (shadow, m["blocked", depth] - m["blocked", 4]),
             (shadow, tail), (tail, m["blocked", depth] - m["blocked", 4]),
             (three + shadow + tail + BOUNCE_TAIL * fifth, m["presence", depth]),
             (three + shadow + BOUNCE_TAIL * fifth, m["presence", depth])]
    rng = np.random.default_rng(0)
    vals = []
    for p in pairs:
        boot = [gain(p[0][i], p[1][i]) for i in (rng.integers(0, n, n) for _ in range(2000))]
        vals.append(f"{gain(*p):.2f} ({np.percentile(boot, 2.5):.2f}-{np.percentile(boot, 97.5):.2f})")
    vals.append(f"{power:.3f}")
    lines = [f"# python experiments/bounce-tail/bounce_tail.py room --room {room_name} --spp {spp} --depth {depth}: "
             f"{n} held-out people, Mitsuba {spp} samples a pixel",
             *legend(), _row(room_name, vals)]
    print("\n".join(lines), flush=True)
    return lines


def cost(bundle: Path, people: int) -> list[str]:
    """Seconds a person of the fit's shadow step (``nlos_shadow`` and ``nlos_bounce``, 1,024 body
    samples for the bounce) with the shadow at depth 4 and 10 (one relay set, after a first person),
    and of building the room's transfer, in one run on this machine's threads."""
    import torch

    from nlos_spotlight.render.person import Person
    from nlos_spotlight.render.shadow import SpotShadow
    from nlos_spotlight.render.transport import Renderer, RenderSettings
    from nlos_spotlight.scene.format import TriMesh
    from nlos_spotlight.scene.io import load_scene

    scene = load_scene(bundle / "room")
    scene.human = None
    p = _load(bundle / "people.npz")
    aim = np.asarray(p["aim"]).reshape(1, 3)
    ov, of = np.concatenate([[0], np.cumsum(p["num_vertices"])]), np.concatenate([[0], np.cumsum(p["num_faces"])])
    bodies = [Person.from_mesh(TriMesh(p["vertices"][ov[k]:ov[k + 1]], p["faces"][of[k]:of[k + 1]]), p["albedo"][k],
                               1500, "faces") for k in range(people + 1)]
    base = RenderSettings(pixel_footprint=8, shadow_samples=4096, person_samples=1500, bounce_body_samples=1024)
    comps = ("nlos_shadow", "nlos_bounce")
    per, build = {}, 0.0
    for d in (4, 10):
        r = Renderer(scene, dataclasses.replace(base, shadow_depth=d), aim_points=aim)
        y = r.spot_vector(0)
        with torch.no_grad():
            if d > 4:
                t0 = time.perf_counter()
                SpotShadow(r, 0.5).room(y)
                build = time.perf_counter() - t0
            r.render(y, bodies[0], components=comps)  # the relay set's static visibility
            t0 = time.perf_counter()
            for b in bodies[1:]:
                r.render(y, b, components=comps)
        per[d] = (time.perf_counter() - t0) / people
    lines = [f"# python experiments/bounce-tail/bounce_tail.py cost --people {people} ({torch.get_num_threads()} threads)",
             f"the shadow step a person (nlos_shadow + nlos_bounce): shadow to depth 4 {per[4]:.2f} s, to depth 10 "
             f"{per[10]:.2f} s (x{per[10] / per[4]:.2f}); "
             f"the room's transfer (once per renderer and spot) {build:.1f} s"]
    print("\n".join(lines), flush=True)
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="step", required=True)
    s = sub.add_parser("scenes")
    s.add_argument("--scenes", default="diffuse_corner,furniture,posed_body")
    s.add_argument("--spp", type=int, default=65536)
    s.add_argument("--res", type=int, default=16)
    s.add_argument("--depth", type=int, default=10)
    s.add_argument("--out", type=Path, default=None)
    r = sub.add_parser("room")
    r.add_argument("--mitsuba", type=Path, required=True, help="folder of the Mitsuba photographs")
    r.add_argument("--room", required=True)
    r.add_argument("--spp", type=int, required=True)
    r.add_argument("--depth", type=int, default=10)
    r.add_argument("--camera", type=Path, required=True, help="robustness.py's cached camera photographs (camera-*.npz)")
    r.add_argument("--bounce", type=Path, required=True, help="robustness.py's cached fifth bounce (bounce-*.npz)")
    r.add_argument("--bundle", type=Path, required=True, help="mitsuba_photographs.py export's bundle of the room")
    r.add_argument("--out", type=Path, default=None)
    c = sub.add_parser("cost")
    c.add_argument("--bundle", type=Path, required=True, help="mitsuba_photographs.py export's bundle of the room")
    c.add_argument("--people", type=int, default=6)
    c.add_argument("--out", type=Path, default=None)
    a = ap.parse_args()
    if a.step == "scenes":
        lines = scenes(a.scenes.split(","), a.spp, a.res, a.depth)
    elif a.step == "cost":
        lines = cost(a.bundle, a.people)
    else:
        lines = room(a.mitsuba, a.room, a.spp, a.depth, a.camera, a.bounce, a.bundle)
    if a.out is not None:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
