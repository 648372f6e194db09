"""``make demo``: the product end to end at demo scale, then its report.

1. render the bundled example scene (one PNG per image component, magnitudes printed);
2. ``nlos fit`` in a real scan (the copy room of ``../shared/data/real-scans``, the camera of
   ``benchmarks/configs/rooms/copyroom.yaml``) at the ``demo`` preset: 600 synthetic people rendered
   in the scan, the spot chosen, the network trained, 60 held-out people scored (``report.html``);
3. ``nlos predict`` on held-out photographs (one person of each posture): what the room model says,
   beside the truth.

``--paper`` runs the paper's pipeline instead (procedural rooms): ``nlos generate demo``, ``nlos
train demo`` (IEN + ResNet-18 end to end through the stored transport), ``nlos evaluate`` (Tables
1-3, Figs. 5-7) and one procedural room with a thousand people (the seen-rooms recipe).

Every step resumes, so an interrupted demo continues where it stopped.

    python -m nlos_spotlight.demo --out out/demo [--paper [--seeds N]] [--render-only]
"""

from __future__ import annotations

import argparse
import json
import os
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


def render_example(out: Path, seed: int) -> None:
    import torch

    from . import __version__
    from .render.person import Person
    from .render.sensor import SensorConfig, auto_exposure, sensor_capture
    from .render.transport import COMPONENTS, Renderer, RenderSettings
    from .scene import load_scene
    from .scene.examples import SPOT_TARGET

    out.mkdir(parents=True, exist_ok=True)
    scene = load_scene(bundled_scene())
    settings = RenderSettings()
    t0 = time.perf_counter()
    r = Renderer(scene, settings, aim_points=SPOT_TARGET[None])
    t_pre = time.perf_counter() - t0
    person = Person.sampled(scene.human.mesh, scene.human.albedo, settings)
    t0 = time.perf_counter()
    res = r.render(r.spot_vector(0), person, components=COMPONENTS)
    t_render = time.perf_counter() - t0
    cfg = SensorConfig.for_scene(scene)
    exposure = auto_exposure(r.render(r.spot_vector(0), components=("direct", "interreflection", "ambient")).image,
                             cfg)
    noisy = sensor_capture(res.image, exposure, cfg, generator=torch.Generator().manual_seed(seed))
    summary = {}
    for name, img in list(res.components.items()) + [("total", res.image), ("sensor", noisy.radiance)]:
        a = img.numpy()
        save_png(a, out / f"{name}.png", signed=name in ("nlos_ambient", "nlos_shadow"))
        np.save(out / f"{name}.npy", a.astype(np.float32))
        summary[name] = {"sum": float(a.sum()), "max": float(np.abs(a).max()), "mean": float(a.mean())}
    _overview(out, ["direct", "ambient", "nlos", "nlos_ambient", "total", "sensor"])
    table = "\n".join(f"  {k:16s} sum {v['sum']:12.5g}   max|.| {v['max']:11.4g}" for k, v in summary.items())
    ratio = summary["nlos"]["sum"] / max(summary["direct"]["sum"], 1e-30)
    run = {"version": __version__, "python": platform.python_version(), "torch": torch.__version__,
           "scene": str(bundled_scene()), "spot_target": SPOT_TARGET.tolist(), "settings": vars(settings),
           "seed": seed, "exposure_s": exposure, "timing_s": {"precompute": t_pre, "render": t_render},
           "components": summary}
    (out / "run.json").write_text(json.dumps(run, indent=1))
    console.print(f"[bold]nlos-spotlight demo[/bold]: example scene, spot at {SPOT_TARGET.tolist()}")
    console.print(table)
    console.print(f"  nlos / direct = {ratio:.3g}; sensor exposure {exposure:.3g} s; "
                  f"precompute {t_pre:.2f} s, render {t_render:.2f} s")
    console.print(f"rendered: {out.resolve()} (overview.png, a PNG and .npy per component, run.json)")


def _step(title: str, argv: list[str]) -> None:
    from .cli import main as nlos

    console.rule(title)
    t0 = time.perf_counter()
    if nlos(argv) != 0:
        raise SystemExit(f"demo: step failed: nlos {' '.join(argv)}")
    console.print(f"{title}: {time.perf_counter() - t0:.0f} s")


def seen_room(data: Path, out: Path, progress: bool, min_steps: int = 600) -> Path:
    """Step 5: the seen-rooms recipe (``train.recipe``) on the room of ``data``; writes seen-room.md."""
    from .train.recipe import run_seen, seen_config, split_room
    from .data.tensors import load_split

    rooms = [split_room(s) for s in load_split(data, "train", ["normals"], samples="images")]
    n = min(r.pool.num_samples for r in rooms)
    lines = ["| capture | people trained on | posture (6) | upright/sitting/crouching | error | mean answer |",
             "|---|---|---|---|---|---|"]
    for capture, noise in (("noise-free", False), ("default", True)):
        r = run_seen(seen_config(len(rooms), noise=noise), rooms, n, out / capture, 10.0, progress=progress,
                     min_steps=min_steps)
        lines.append(f"| {capture} | {n} | {r.posture_accuracy:.1f}% | {r.posture3_accuracy:.1f}% "
                     f"| {r.error_cm:.1f} cm | {r.mean_answer_cm:.1f} cm |")
    table = "\n".join(lines)
    path = out / "seen-room.md"
    path.write_text(f"# One room, new people (oracle spot, {rooms[0].test.num_samples} test people)\n\n{table}\n")
    console.print(table)
    return path


DEMO_ROOM = Path("benchmarks/configs/rooms/copyroom.yaml")
"""The demo's room: the copy room scan and the camera a user would set up in it (from the repository root)."""


def heldout_predictions(model: Path, out: Path) -> Path:
    """Step 3: ``nlos predict`` on the fit's held-out photographs (the first person of each posture
    among the held-out people, each a burst averaged as the room model's capture takes it), written as
    ``.npy`` files a user could hand in; the answers beside the truth in ``predictions.md``."""
    from .world.body import POSTURES

    hp = np.load(model / "train" / "heldout.npz")
    out.mkdir(parents=True, exist_ok=True)
    lines = ["| posture (truth) | nlos predict | position (truth), m | nlos predict, m | error |", "|---|---|---|---|---|"]
    for p, name in enumerate(POSTURES):
        if np.isnan(hp["photo_image"][p, 0, 0, 0]):
            continue
        np.save(out / f"{name}.npy", hp["photo_image"][p])
        np.save(out / f"{name}-empty.npy", hp["photo_background"][p])
        said = out / f"{name}.json"
        _step(f"3/3 predict: {name}", ["predict", str(model), str(out / f"{name}.npy"), "--background",
                                       str(out / f"{name}-empty.npy"), "--burst", "1", "--json", str(said)])
        frame = json.loads(said.read_text())["frames"][0]
        guess = np.array([frame["x_m"], frame["y_m"]])
        line = f"| {name} | {frame['posture']} | " + ("-" if "photo_xy" not in hp.files else
            f"({hp['photo_xy'][p][0]:+.2f}, {hp['photo_xy'][p][1]:+.2f}) | ({guess[0]:+.2f}, {guess[1]:+.2f}) | "
            f"{100 * np.linalg.norm(guess - hp['photo_xy'][p]):.0f} cm |")
        lines.append(line)
    table = "\n".join(lines)
    path = out / "predictions.md"
    path.write_text("# nlos predict on held-out photographs (positions in the room model's frame: along the "
                    f"camera's view, to its left)\n\n{table}\n")
    console.print(table)
    return path


def fit_demo(out: Path, seed: int, quiet: list[str]) -> Path:
    """Step 2: ``nlos fit --preset demo`` in the demo's room; returns the room model directory."""
    if not DEMO_ROOM.is_file():
        raise SystemExit(f"demo: {DEMO_ROOM} not found: run make demo from the repository's root")
    from .config_file import load_room_config

    room = load_room_config(str(DEMO_ROOM))["room"]
    if not Path(room).is_file():
        raise SystemExit(f"demo: the copy room scan {room} is missing (expected ../shared/data/real-scans "
                         "beside the repository); python -m nlos_spotlight.demo --paper runs without it")
    model = out / "room-model"
    _step("2/3 fit a room model in the copy room scan", ["fit", "--config", str(DEMO_ROOM), "--preset", "demo",
          "--out", str(model), "--seed", str(seed), *(["--resume"] if (model / "fit.json").exists() else []), *quiet])
    return model


def paper(out: Path, args, quiet: list[str]) -> None:
    """``--paper``: the paper's pipeline in procedural rooms, and one room of a thousand people."""
    _step("2/5 generate", ["generate", "demo", "--out", str(out / "data"), "--seed", str(args.seed), *quiet])
    run = out / "run"
    _step("3/5 train", ["train", "demo", "--data", str(out / "data"), "--out", str(run), "--seed", str(args.seed),
                        *(["--resume"] if (run / "config.json").exists() else []), *quiet])
    _step("4/5 evaluate", ["evaluate", str(run), "--data", str(out / "data"), "--out", str(out / "report"),
                           "--seeds", str(args.seeds), *quiet])
    _step("5/5 one room, a thousand people", ["generate", "demo-room", "--out", str(out / "room-data"),
                                              "--seed", str(args.seed), *quiet])
    seen = seen_room(out / "room-data", out / "seen-room", progress=not quiet)
    console.print(f"report: {(out / 'report' / 'report.html').resolve()} (and report.md); seen room: {seen.resolve()}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="out/demo")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--paper", action="store_true", help="the paper's pipeline in procedural rooms instead")
    ap.add_argument("--seeds", type=int, default=1, help="--paper: training seeds per method in the evaluation")
    ap.add_argument("--render-only", action="store_true", help="only step 1")
    args = ap.parse_args(argv)
    out = Path(args.out)
    t0 = time.perf_counter()
    console.rule("1/3 render the example scene" if not args.paper else "1/5 render the example scene")
    render_example(out / "render", args.seed)
    if args.render_only:
        return
    quiet = ["--quiet"] if os.environ.get("CI", "").lower() == "true" else []
    if args.paper:
        paper(out, args, quiet)
    else:
        model = fit_demo(out, args.seed, quiet)
        said = heldout_predictions(model, out / "heldout")
        h = json.loads((model / "report.json").read_text())["heldout"]
        console.print(f"room model: {h['people']} held-out people, six-way posture {100 * h['posture_accuracy']:.0f}% "
                      f"(chance 17%), upright/sitting/crouching {100 * h['posture3_accuracy']:.0f}%, position "
                      f"{h['error_cm']:.1f} cm (the mean answer: {h['mean_answer_cm']:.1f} cm)")
        console.print(f"report: {(model / 'report.html').resolve()}; predictions: {said.resolve()}")
    console.print(f"[bold]demo done in {(time.perf_counter() - t0) / 60:.1f} min[/bold]")

if __name__ == "__main__":
    main()
