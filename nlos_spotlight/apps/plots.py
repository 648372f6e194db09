"""Figures of ``nlos spotlight`` and ``nlos predict`` (PNG, matplotlib's Agg backend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plotting import pyplot, save_figure
from ..render.camera import camera_frame, project
from .predict import Predictions
from .spotlight import SpotlightResult


def spotlight_figure(r: SpotlightResult, path: Path) -> None:
    """Two panels: the LOS mesh as the camera sees it, and from above; faces colored by IEN
    probability (grey: the projector cannot reach them), the chosen spot starred, the beam drawn."""
    plt = pyplot()
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import Normalize

    cam, los = r.setup.camera, r.los
    tri = los.vertices[los.faces]  # (F, 3, 3)
    # the color range spans the reachable faces' probabilities: an IEN that is unsure spreads them
    # over hundreds of faces, and a range starting at 0 would paint them all the same
    lo, hi = float(r.probabilities[r.reachable].min()), float(r.probabilities.max())
    norm = Normalize(vmin=lo, vmax=max(hi, lo * (1 + 1e-6) + 1e-12))
    cmap = plt.get_cmap("magma")
    colors = np.where(r.reachable[:, None], cmap(norm(r.probabilities))[:, :3], 0.78)
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 5.4), layout="constrained")

    # camera view, painter's order (far faces first)
    fwd = camera_frame(cam)[0]
    depth = (tri - cam.position) @ fwd  # (F, 3)
    keep = np.flatnonzero((depth > 1e-3).all(axis=1))
    keep = keep[np.argsort(-depth[keep].mean(axis=1))]
    px = project(cam, tri[keep].reshape(-1, 3)).reshape(-1, 3, 2)[:, :, ::-1]  # (row, col) -> (x=col, y=row)
    ax0.add_collection(PolyCollection(px, facecolors=colors[keep], edgecolors=(0, 0, 0, 0.25), linewidths=0.3))
    spot = project(cam, r.centroid[None])[0]
    ax0.plot(spot[1], spot[0], "*", ms=16, mec="black", mfc="cyan")
    ax0.set_xlim(0, cam.width)
    ax0.set_ylim(cam.height, 0)
    ax0.set_aspect("equal")
    ax0.set_xticks([])
    ax0.set_yticks([])
    ax0.set_title(f"camera view: spot on face {r.face} (p = {r.probabilities[r.face]:.3f})", fontsize=10)

    # top view, lower faces first so walls and furniture tops stay visible
    zorder = np.argsort(tri[:, :, 2].mean(axis=1))
    ax1.add_collection(PolyCollection(tri[zorder][:, :, :2], facecolors=colors[zorder],
                                      edgecolors=(0, 0, 0, 0.2), linewidths=0.3))
    p, c = r.setup.projector, r.centroid
    ax1.plot([p[0], c[0]], [p[1], c[1]], "-", color="cyan", lw=1.5, label="projector beam")
    ax1.plot(*c[:2], "*", ms=16, mec="black", mfc="cyan", label="spot")
    ax1.plot(*p[:2], "s", ms=7, color="tab:green", label="projector")
    ax1.plot(*cam.position[:2], "^", ms=8, color="tab:blue", label="camera")
    reach = 0.5 * max(np.ptp(los.vertices[:, 0]), np.ptp(los.vertices[:, 1]), 1.0)
    ax1.annotate("", xy=cam.position[:2] + reach * 0.3 * fwd[:2] / max(np.linalg.norm(fwd[:2]), 1e-9),
                 xytext=cam.position[:2], arrowprops={"arrowstyle": "->", "color": "tab:blue"})
    pts = np.concatenate([los.vertices[:, :2], p[None, :2], cam.position[None, :2]])
    pad = 0.3
    ax1.set_xlim(pts[:, 0].min() - pad, pts[:, 0].max() + pad)
    ax1.set_ylim(pts[:, 1].min() - pad, pts[:, 1].max() + pad)
    ax1.set_aspect("equal")
    ax1.set_xlabel("x (m)")
    ax1.set_ylabel("y (m)")
    ax1.set_title(f"from above: pan {r.aim.pan_deg:+.1f} deg, tilt {r.aim.tilt_deg:+.1f} deg", fontsize=10)
    ax1.legend(fontsize=8, loc="best")
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=[ax0, ax1], shrink=0.8, label="IEN probability (grey: unreachable)")
    save_figure(fig, path)
    plt.close(fig)


def trajectory_figure(p: Predictions, path: Path) -> None:
    """Left: positions from above as the camera sees them (raw points, smoothed line). Right: x and
    y against time (or frame), raw and smoothed, with the most probable posture per frame."""
    plt = pyplot()
    from ..world.body import POSTURES

    t = p.times if p.times is not None else np.arange(len(p), dtype=float)
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 4.5))
    ax0.plot(p.xy[:, 1], p.xy[:, 0], "x", color="tab:red", ms=5, label="per frame")
    if p.smoothed is not None:
        ax0.plot(p.smoothed[:, 1], p.smoothed[:, 0], "-", color="tab:blue", lw=2,
                 label=f"Savitzky-Golay (window {p.window}, order {p.order})")
    ax0.plot(0, 0, "^", ms=9, color="black", label="camera (floor point)")
    ax0.set_xlabel("left of view (m)")
    ax0.set_ylabel("along view (m)")
    ax0.invert_xaxis()  # as seen from behind the camera: left on the left
    ax0.set_aspect("equal", adjustable="datalim")
    ax0.legend(fontsize=8)
    ax0.set_title("floor positions (camera ground frame)", fontsize=10)
    for k, (name, color) in enumerate((("x (along view)", "tab:purple"), ("y (left)", "tab:orange"))):
        ax1.plot(t, p.xy[:, k], "x", color=color, ms=4, label=f"{name}")
        if p.smoothed is not None:
            ax1.plot(t, p.smoothed[:, k], "-", color=color, lw=2)
    ax1.set_xlabel("time (s)" if p.times is not None else "frame")
    ax1.set_ylabel("m")
    post = p.probabilities.argmax(axis=1)
    ax2 = ax1.twinx()
    ax2.plot(t, post, ".", color="grey", ms=4)
    ax2.set_yticks(range(len(POSTURES)), POSTURES, fontsize=7)
    ax2.set_ylim(-0.5, len(POSTURES) - 0.5)
    ax2.set_ylabel("most probable posture (grey dots)", fontsize=8)
    ax1.legend(fontsize=8, loc="upper left")
    ax1.set_title("position and posture over time", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
