"""The report's figures (PNG, matplotlib Agg): tracking (Fig. 5), each policy's spot (Fig. 6),
accuracy and error against mesh decimation (Fig. 7)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plotting import pyplot


def tone_map(img: np.ndarray) -> np.ndarray:
    """Linear radiance (H, W, 3) -> display RGB in [0, 1]: 99.5th-percentile white, gamma 2.2."""
    s = float(np.percentile(img, 99.5)) or 1.0
    return np.clip(img / s, 0, 1) ** (1 / 2.2)


def tracking_figure(tracks: list[dict], path: Path) -> None:
    """Fig. 5. ``tracks``: dicts with 'true', 'raw', 'smooth' (F, 2) arrays in m and a 'title'."""
    plt = pyplot()
    n = max(1, len(tracks))
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 4), squeeze=False)
    for ax, t in zip(axes[0], tracks):
        err = {k: 100 * np.linalg.norm(t[k] - t["true"], axis=1).mean() for k in ("raw", "smooth")}
        ax.plot(t["true"][:, 1], t["true"][:, 0], "k-o", ms=3, label="ground truth")
        ax.plot(t["raw"][:, 1], t["raw"][:, 0], "x", color="tab:red", ms=4, label=f"raw ({err['raw']:.1f} cm)")
        ax.plot(t["smooth"][:, 1], t["smooth"][:, 0], "-", color="tab:blue", lw=2,
                label=f"Savitzky-Golay ({err['smooth']:.1f} cm)")
        ax.set_xlabel("left of view (m)")
        ax.set_ylabel("along view (m)")
        ax.set_title(t["title"], fontsize=9)
        ax.invert_xaxis()  # as seen from the camera: left on the left
        ax.set_aspect("equal", adjustable="datalim")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def policy_figure(panels: list[dict], path: Path) -> None:
    """Fig. 6. ``panels``: dicts with 'name', 'image' (H, W, 3), 'nlos' (H, W, 3), 'spot' (row, col) or None."""
    plt = pyplot()
    n = len(panels)
    fig, axes = plt.subplots(2, n, figsize=(2.1 * n, 4.4), squeeze=False)
    for k, p in enumerate(panels):
        axes[0, k].imshow(tone_map(p["image"]))
        axes[1, k].imshow(tone_map(np.abs(p["nlos"])))  # |.|: under ambient light the person is a shadow
        if p["spot"] is not None:
            axes[0, k].plot(p["spot"][1] - 0.5, p["spot"][0] - 0.5, "+", color="cyan", ms=10, mew=2)
        axes[0, k].set_title(p["name"], fontsize=8)
        for ax in axes[:, k]:
            ax.set_xticks([])
            ax.set_yticks([])
    axes[0, 0].set_ylabel("photograph", fontsize=8)
    axes[1, 0].set_ylabel("|person's light|", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def decimation_figure(ratios, acc: np.ndarray, err: np.ndarray, path: Path) -> None:
    """Fig. 7. ``acc``, ``err``: (seeds, ratios) posture accuracy (%) and mean error (cm)."""
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(8, 3.2))
    for ax, v, label in ((a, acc, "posture accuracy (%)"), (b, err, "localization error (cm)")):
        m, s = v.mean(0), v.std(0)
        ax.errorbar(ratios, m, yerr=s, marker="o", capsize=3)
        ax.set_xlabel("decimation ratio (vertices kept)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
