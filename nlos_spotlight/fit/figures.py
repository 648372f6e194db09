"""Figures of a room model's report (PNG, matplotlib Agg)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plotting import pyplot, save_figure
from ..evaluate.figures import tone_map
from ..world.body import POSTURES

MAX_DRAWN_FACES = 6000
"""Faces drawn in the 3D view (a scan is subsampled by area beyond that: matplotlib is slow)."""


def room_3d(room_dir: Path, room: dict, spot: dict, path: Path) -> None:
    """The room's faces in 3D (colored by albedo and shaded by height), camera, projector, the beam
    to the spot (none for a fit without a spot: ``spot`` face -1), the hidden region's rectangle on
    the floor."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from ..scene.io import load_scene

    plt = pyplot()
    scene = load_scene(room_dir)
    mesh, owner = scene.static_mesh()
    tri = mesh.vertices[mesh.faces]
    col = np.ones((len(mesh.faces), 3)) * mesh.face_colors
    col *= np.stack([scene.materials[scene.shapes[o].material].diffuse for o in owner])
    col *= mesh.vertex_colors[mesh.faces].mean(axis=1)
    keep = np.arange(len(tri))
    if len(tri) > MAX_DRAWN_FACES:  # the largest faces carry the room's shape
        keep = np.argsort(-mesh.face_areas())[:MAX_DRAWN_FACES]
    cam, proj = np.asarray(room["camera"]["position"]), np.asarray(room["projector"]["position"])
    hr = room["hidden_region"]
    fig = plt.figure(figsize=(9, 7))
    ax = fig.add_subplot(projection="3d")
    top = tri[keep, :, 2].mean(axis=1) > hr["floor_z"] + 2.2  # ceilings hide the room from above
    shown = keep[~top]
    ax.add_collection3d(Poly3DCollection(tri[shown], facecolors=np.clip(col[shown] ** (1 / 2.2), 0, 1),
                                         edgecolors=(0, 0, 0, 0.05), linewidths=0.2, alpha=0.55))
    x0, y0 = hr["min"]
    x1, y1 = hr["max"]
    z = hr["floor_z"] + 0.01
    ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], [z] * 5, color="tab:red", lw=2, label="hidden region")
    if spot["face"] >= 0:
        aim = np.asarray(spot["aim"])
        ax.plot(*zip(proj, aim), color="cyan", lw=2, label="beam")
        ax.scatter(*aim, marker="*", s=200, color="cyan", edgecolors="black", label=f"spot (face {spot['face']})")
    ax.scatter(*cam, marker="^", s=80, color="tab:blue", label="camera")
    ax.scatter(*proj, marker="s", s=60, color="tab:green", label="projector")
    look = np.asarray(room["camera"]["look_at"])
    ax.plot(*zip(cam, cam + 0.8 * (look - cam) / np.linalg.norm(look - cam)), color="tab:blue", lw=1.5)
    lo, hi = tri[keep].reshape(-1, 3).min(0), tri[keep].reshape(-1, 3).max(0)
    c, r = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.view_init(elev=55, azim=-60)
    ax.legend(fontsize=8, loc="upper left")
    save_figure(fig, path)
    plt.close(fig)


def error_map(true_xy: np.ndarray, err_cm: np.ndarray, room: dict, path: Path, cells: int = 6) -> None:
    """Each held-out person's error at their floor position, over the mean error per cell."""
    plt = pyplot()
    hr = room["hidden_region"]
    (x0, y0), (x1, y1) = hr["min"], hr["max"]
    aspect = (y1 - y0) / max(x1 - x0, 1e-9)  # the figure takes the region's shape: no tall empty colorbar
    fig, ax = plt.subplots(figsize=(6.5, float(np.clip(5.2 * aspect + 1.0, 2.8, 8.0))), layout="constrained")
    ex, ey = np.linspace(x0, x1, cells + 1), np.linspace(y0, y1, cells + 1)
    s, _, _ = np.histogram2d(true_xy[:, 0], true_xy[:, 1], [ex, ey], weights=err_cm)
    n, _, _ = np.histogram2d(true_xy[:, 0], true_xy[:, 1], [ex, ey])
    vmax = float(np.percentile(err_cm, 95)) if len(err_cm) else 1.0
    mean = np.where(n > 0, s / np.maximum(n, 1), np.nan)
    im = ax.pcolormesh(ex, ey, mean.T, cmap="viridis", vmin=0, vmax=vmax, alpha=0.6)
    ax.scatter(true_xy[:, 0], true_xy[:, 1], c=err_cm, cmap="viridis", vmin=0, vmax=vmax, s=22,
               edgecolors="black", linewidths=0.4)
    cam = room["camera"]["position"]
    ax.set_title(f"localization error: mean {err_cm.mean():.1f} cm over {len(err_cm)} people "
                 f"(camera at x {cam[0]:.1f}, y {cam[1]:.1f})", fontsize=9)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    fig.colorbar(im, ax=ax, label="error (cm)", shrink=float(np.clip(aspect, 0.35, 1.0)))
    save_figure(fig, path)
    plt.close(fig)


def confusion(conf: np.ndarray, path: Path) -> None:
    """Row-normalized confusion matrix with counts."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 5), layout="constrained")
    frac = conf / np.maximum(conf.sum(axis=1, keepdims=True), 1)
    im = ax.imshow(frac, cmap="Blues", vmin=0, vmax=1)
    for i in range(conf.shape[0]):
        for j in range(conf.shape[1]):
            ax.text(j, i, str(conf[i, j]), ha="center", va="center", fontsize=8,
                    color="white" if frac[i, j] > 0.5 else "black")
    ax.set_xticks(range(len(POSTURES)), POSTURES, rotation=35, ha="right", fontsize=8)
    ax.set_yticks(range(len(POSTURES)), POSTURES, fontsize=8)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    fig.colorbar(im, ax=ax, label="fraction of the row")
    save_figure(fig, path)
    plt.close(fig)


def photos(images: np.ndarray, backgrounds: np.ndarray, path: Path) -> None:
    """(6, H, W, 3) photographs and empty-room photographs: each posture's photograph, and below
    it the difference (the person's light, shown on one shared scale)."""
    plt = pyplot()
    fig, axes = plt.subplots(2, len(POSTURES), figsize=(2.2 * len(POSTURES), 4.6), layout="constrained")
    diff = images - backgrounds
    scale = float(np.nanpercentile(np.abs(diff), 99.5)) or 1.0
    for j, name in enumerate(POSTURES):
        for ax in axes[:, j]:
            ax.set_xticks([])
            ax.set_yticks([])
        axes[0, j].set_title(name, fontsize=9)
        if np.isnan(images[j]).any():
            continue
        axes[0, j].imshow(tone_map(images[j]))
        d = diff[j].mean(axis=2)
        axes[1, j].imshow(d, cmap="RdBu_r", vmin=-scale, vmax=scale)
    axes[1, 0].set_ylabel("minus empty room", fontsize=8)
    save_figure(fig, path)
    plt.close(fig)
