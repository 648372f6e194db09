"""Render the six posture classes of the hidden person side by side: writes docs/postures.png.

    python docs/figures/postures.py [--out docs/postures.png] [--cache DIR] [--seed N]

Each body is one library body (1.75 m, average build) seen from the front-left at eye level,
drawn as flat-shaded triangles with matplotlib (Agg backend, no display needed).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from nlos_spotlight.world.body import POSTURES, BodyCache, BodyParams, posed_body  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
VIEW_AZIM_DEG = -60.0     # camera azimuth of the 3D axes; the bodies face the camera obliquely
LIGHT = np.array([0.4, -0.6, 0.7]) / np.linalg.norm([0.4, -0.6, 0.7])


def shaded_colors(vertices: np.ndarray, faces: np.ndarray, albedo: np.ndarray) -> np.ndarray:
    """Two-sided Lambertian shading of each triangle under one directional light plus ambient."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    n = np.cross(b - a, c - a)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    shade = 0.25 + 0.75 * np.abs(n @ LIGHT)
    return np.clip(shade[:, None] * albedo[None, :], 0.0, 1.0)


def draw(ax, posture: str, cache: BodyCache, seed: int) -> None:
    params = BodyParams(posture, 1.75, facing_deg=-30.0, pose_seed=seed, albedo=np.array([0.75, 0.6, 0.5]))
    mesh = posed_body(params, target_faces=4000, cache=cache)
    v, f = mesh.vertices, mesh.faces
    ax.add_collection3d(Poly3DCollection(v[f], facecolors=shaded_colors(v, f, params.albedo), linewidths=0.0))
    ax.set_xlim(-0.9, 0.9)
    ax.set_ylim(-0.9, 0.9)
    ax.set_zlim(0.0, 1.8)
    ax.set_box_aspect((1, 1, 1), zoom=1.45)   # equal scale on all axes, little margin
    ax.view_init(elev=8.0, azim=VIEW_AZIM_DEG)
    ax.set_axis_off()
    height = np.ptp(v[:, 2])
    ax.set_title(f"{posture}\n{len(f)} faces, {height:.2f} m tall", fontsize=10)
    # floor outline so that "feet on z = 0" is visible
    ax.plot([-0.7, 0.7, 0.7, -0.7, -0.7], [-0.7, -0.7, 0.7, 0.7, -0.7], [0, 0, 0, 0, 0], color="0.7", lw=0.8)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "postures.png")
    parser.add_argument("--cache", type=Path, default=None, help="body library folder (default: $NLOS_CACHE/bodies)")
    parser.add_argument("--seed", type=int, default=3, help="pose_seed of every body")
    args = parser.parse_args()
    cache = BodyCache(args.cache)
    fig = plt.figure(figsize=(18, 4.4), dpi=110)
    for i, posture in enumerate(POSTURES):
        draw(fig.add_subplot(1, len(POSTURES), i + 1, projection="3d"), posture, cache, args.seed)
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.0, top=0.88, wspace=0.0)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
