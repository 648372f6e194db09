"""Six generated rooms, one per row: a 3D overview and the camera image of each component.

    python docs/figures/scenes.py [--out docs/scenes.png] [--resolution 64] [--seed 0]

Overview: the static meshes (ceiling left out, walls see-through) as flat-shaded triangles in
their material's color times the vertex colors, the camera (black dot, line to its look-at point)
and the projector (red dot, line to the spot, a red star), the hidden region (blue rectangle), and
a capsule mannequin (orange) at the best-lit of 16 positions drawn by ``person_positions``.
Images, rendered with ``Renderer`` (2x2 sub-samples per pixel, 64 spot rays, 512 body samples):
``direct``, ``ambient``, ``nlos`` and ``nlos_ambient`` with the spot on ``Room.aim_point`` (the
center of the camera-visible relay area). Each is tone-mapped by its own percentile (99.5th;
90th for ``ambient``, whose lamps and screens are far brighter than the walls) with gamma 2.2, the
value printed; ``nlos`` also gives its total relative to the ``direct`` total; ``nlos_ambient``
(the person's light minus the hidden background it blocks, mostly negative) is shown signed.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection  # noqa: E402

from nlos_spotlight.render.person import Person  # noqa: E402
from nlos_spotlight.render.transport import Renderer, RenderSettings  # noqa: E402
from nlos_spotlight.scene.builders import mannequin  # noqa: E402
from nlos_spotlight.world.rooms import RoomConfig, generate_room, person_positions  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
ROWS = [("partitioned_room", 1), ("cluttered_office", 2), ("doorway", 3), ("l_corner", 4),
        ("corridor_junction", 5), ("cluttered_office", 6)]
LIGHT = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
COMPONENTS = ("direct", "ambient", "nlos", "nlos_ambient")


def overview(ax, room, person_xy) -> None:
    scene = room.scene
    polys, cols, wpolys, wcols = [], [], [], []
    for shape, kind in zip(scene.shapes, room.kinds):
        if kind in ("ceiling", "ceiling_light"):
            continue
        m = shape.mesh
        mat = scene.materials[shape.material]
        tri = m.vertices[m.faces]
        vc = m.vertex_colors[m.faces].mean(1) if m.vertex_colors is not None else np.ones((len(m.faces), 3))
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
        shade = 0.35 + 0.65 * np.abs(n @ LIGHT)
        base = np.clip(mat.diffuse + 0.6 * mat.specular + np.minimum(mat.emission, 1.0), 0, 1)
        col = np.clip(shade[:, None] * base[None] * vc, 0, 1)
        if kind in ("wall", "baseboard"):  # see-through walls so the furniture shows
            wpolys.append(tri)
            wcols.append(np.concatenate([col, np.full((len(col), 1), 0.12)], 1))
        else:
            polys.append(tri)
            cols.append(col)
    ax.computed_zorder = False  # draw in this order: furniture, person, see-through walls, markers
    ax.add_collection3d(Poly3DCollection(np.concatenate(polys), facecolors=np.concatenate(cols), edgecolors="none"))
    body = mannequin([person_xy[0], person_xy[1], scene.hidden_region.floor_z], 1.75)
    ax.add_collection3d(Poly3DCollection(body.vertices[body.faces], facecolors=(0.95, 0.45, 0.1), edgecolors="none"))
    ax.add_collection3d(Poly3DCollection(np.concatenate(wpolys), facecolors=np.concatenate(wcols),
                                         edgecolors=(0.2, 0.2, 0.2, 0.04), linewidths=0.2))
    reg = scene.hidden_region
    rx = [reg.min[0], reg.max[0], reg.max[0], reg.min[0], reg.min[0]]
    ry = [reg.min[1], reg.min[1], reg.max[1], reg.max[1], reg.min[1]]
    ax.plot(rx, ry, [reg.floor_z + 0.03] * 5, color="blue", lw=2.5, zorder=10)
    cam, pr = scene.camera, scene.projector
    for p, tgt, c in ((cam.position, cam.look_at, "black"), (pr.position, room.aim_point, "red")):
        ax.scatter(*p, color=c, s=60, depthshade=False, edgecolors="white", zorder=11)
        ax.add_collection3d(Line3DCollection([[p, tgt]], colors=c, linewidths=2.0, zorder=11))
    ax.scatter(*room.aim_point, color="red", marker="*", s=60, depthshade=False)
    v = np.concatenate([s.mesh.vertices for s in scene.shapes])
    lo, hi = v.min(0), v.max(0)
    c = (lo + hi) / 2
    r = (hi - lo).max() / 2
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(0, r)
    ax.set_box_aspect((1, 1, 0.5), zoom=1.5)
    d = cam.look_at - cam.position
    ax.view_init(elev=50, azim=float(np.degrees(np.arctan2(d[1], d[0]))) + 180 - 20)
    ax.set_axis_off()
    fam = room.family.replace("_", " ")
    w, h = reg.max - reg.min
    ax.set_title(f"{fam} (seed {room.seed})\n{room.stats['faces']} faces, region {w:.1f} x {h:.1f} m", fontsize=8)


def _lit_position(room, cands: np.ndarray) -> np.ndarray:
    """Of the candidate positions, the one whose body axis the spot sees best (so the figure shows a
    person in the light; the dataset uses every position, lit or not)."""
    from nlos_spotlight.world.placement import segment_points, visible
    from nlos_spotlight.world.rooms import scene_geometry

    geo = scene_geometry(room.scene)
    aim = room.aim_point + 0.02 * (room.scene.camera.position - room.aim_point) / np.linalg.norm(
        room.scene.camera.position - room.aim_point)
    pts = segment_points(cands, room.scene.hidden_region.floor_z, (0.3, 0.8, 1.3, 1.6))
    seen = visible(geo.engine, aim, pts).reshape(len(cands), -1).mean(1)
    return cands[int(np.argmax(seen))]


def tone(img: np.ndarray, q: float = 99.5) -> tuple[np.ndarray, float]:
    s = float(np.percentile(img, q))
    if s <= 0:
        return np.zeros_like(img), s
    return np.clip(img / s, 0, 1) ** (1 / 2.2), s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "scenes.png"))
    ap.add_argument("--resolution", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0, help="offset added to every row's room seed")
    args = ap.parse_args()
    fig = plt.figure(figsize=(15, 2.75 * len(ROWS)))
    gs = fig.add_gridspec(len(ROWS), 6, width_ratios=[1.3, 1, 1, 1, 1, 0.02], wspace=0.05)
    settings = RenderSettings(pixel_samples=2, transport_pixel_samples=2, spot_samples=64, person_samples=512,
                              device="cpu")
    for r, (family, seed) in enumerate(ROWS):
        t0 = time.perf_counter()
        room = generate_room(seed + args.seed, RoomConfig(families=[family], resolution=args.resolution))
        t_room = time.perf_counter() - t0
        rng = np.random.default_rng(seed)
        xy = _lit_position(room, person_positions(room.scene, rng, 16))
        ax = fig.add_subplot(gs[r, 0], projection="3d")
        overview(ax, room, xy)
        t1 = time.perf_counter()
        rend = Renderer(room.scene, settings, aim_points=room.aim_point[None])
        body = mannequin([0.0, 0.0, 0.0], 1.75, facing_deg=float(rng.uniform(0, 360)))
        person = Person.from_mesh(body, np.array([0.6, 0.5, 0.4]), settings.person_samples)
        t = np.array([xy[0], xy[1], room.scene.hidden_region.floor_z])
        out = rend.render(rend.spot_vector(0), person, translation=t, components=COMPONENTS)
        imgs = {c: out[c].detach().cpu().numpy() for c in COMPONENTS}
        t_render = time.perf_counter() - t1
        peak = float(imgs["direct"].max())
        for j, c in enumerate(COMPONENTS):
            a = fig.add_subplot(gs[r, 1 + j])
            img = imgs[c]
            if c == "nlos_ambient":  # signed: the person's light minus the background it hides
                s = float(np.abs(img).max()) or 1.0
                a.imshow(np.clip(0.5 + 0.5 * img.mean(-1) / s, 0, 1), cmap="coolwarm", vmin=0, vmax=1)
                label = f"nlos_ambient  |max| {s:.2e}"
            else:
                q = 90 if c == "ambient" else 99.5
                t, s = tone(img, q)
                a.imshow(t)
                label = f"{c}  p{q:g} {s:.2e}"
                if c == "nlos":
                    label += f"\nsum/direct sum {img.sum() / max(imgs['direct'].sum(), 1e-30):.1e}"
            a.set_title(label, fontsize=7)
            a.set_xticks([])
            a.set_yticks([])
        print(f"{family:18s} seed {seed}: room {t_room:.2f} s, render {t_render:.1f} s, faces {room.stats['faces']}, "
              f"nlos total {imgs['nlos'].sum():.3e}, direct peak {peak:.3e}")
    fig.subplots_adjust(left=0.005, right=0.995, top=0.975, bottom=0.005, hspace=0.22)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=90)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
