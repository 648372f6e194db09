"""``make demo``: render the bundled example scene, one PNG per component, and report magnitudes.

    python -m nlos_spotlight.demo --out out/demo
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from importlib import resources
from pathlib import Path

import numpy as np

from .console import console


def bundled_scene() -> Path:
    return Path(str(resources.files("nlos_spotlight") / "assets" / "example_scene"))


def save_png(img: np.ndarray, path: Path, signed: bool = False) -> None:
    """Linear radiance -> 8-bit PNG: scaled by the 99.5th percentile, gamma 2.2 (signed: diverging map)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if signed:
        v = img.sum(-1)
        s = np.percentile(np.abs(v), 99.5) or 1.0
        plt.imsave(path, v, cmap="RdBu_r", vmin=-s, vmax=s)
        return
    s = np.percentile(img, 99.5) or 1.0
    plt.imsave(path, np.clip(img / s, 0, 1) ** (1 / 2.2))


def _overview(out: Path, names: list[str]) -> None:
    """One figure of every component's PNG, side by side."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(names), figsize=(2.6 * len(names), 2.9))
    for ax, name in zip(axes, names):
        ax.imshow(mpimg.imread(out / f"{name}.png"))
        ax.set_title(name)
        ax.axis("off")
    fig.savefig(out / "overview.png", dpi=80, bbox_inches="tight")
    plt.close(fig)


def main(argv=None) -> None:
    import torch

    from . import __version__
    from .render.person import Person
    from .render.sensor import SensorConfig, auto_exposure, sensor_capture
    from .render.transport import COMPONENTS, Renderer, RenderSettings
    from .scene import load_scene
    from .scene.examples import SPOT_TARGET

    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", default="out/demo")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = load_scene(bundled_scene())
    settings = RenderSettings()
    t0 = time.perf_counter()
    r = Renderer(scene, settings, aim_points=SPOT_TARGET[None])
    t_pre = time.perf_counter() - t0
    person = Person.from_mesh(scene.human.mesh, scene.human.albedo, settings.person_samples)
    t0 = time.perf_counter()
    res = r.render(r.spot_vector(0), person, components=COMPONENTS)
    t_render = time.perf_counter() - t0
    cfg = SensorConfig(width=scene.camera.width, height=scene.camera.height)
    exposure = auto_exposure(r.render(r.spot_vector(0), components=("direct", "interreflection", "ambient")).image,
                             cfg)
    noisy = sensor_capture(res.image, exposure, cfg, generator=torch.Generator().manual_seed(args.seed))
    summary = {}
    for name, img in list(res.components.items()) + [("total", res.image), ("sensor", noisy.radiance)]:
        a = img.numpy()
        save_png(a, out / f"{name}.png", signed=name == "nlos_ambient")
        np.save(out / f"{name}.npy", a.astype(np.float32))
        summary[name] = {"sum": float(a.sum()), "max": float(np.abs(a).max()), "mean": float(a.mean())}
    _overview(out, ["direct", "ambient", "nlos", "nlos_ambient", "total", "sensor"])
    table = "\n".join(f"  {k:16s} sum {v['sum']:12.5g}   max|.| {v['max']:11.4g}" for k, v in summary.items())
    ratio = summary["nlos"]["sum"] / max(summary["direct"]["sum"], 1e-30)
    run = {"version": __version__, "python": platform.python_version(), "torch": torch.__version__,
           "scene": str(bundled_scene()), "spot_target": SPOT_TARGET.tolist(), "settings": vars(settings),
           "seed": args.seed, "exposure_s": exposure, "timing_s": {"precompute": t_pre, "render": t_render},
           "components": summary}
    (out / "run.json").write_text(json.dumps(run, indent=1))
    console.print(f"[bold]nlos-spotlight demo[/bold]: example scene, spot at {SPOT_TARGET.tolist()}")
    console.print(table)
    console.print(f"  nlos / direct = {ratio:.3g}; sensor exposure {exposure:.3g} s; "
                  f"precompute {t_pre:.2f} s, render {t_render:.2f} s")
    console.print(f"report: {out.resolve()} (overview.png, a PNG and .npy per component, run.json)")


if __name__ == "__main__":
    main()
