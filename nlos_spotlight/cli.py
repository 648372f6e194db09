"""The ``nlos`` command line (DESIGN section 10).

Every user-facing failure is one line on stderr (``error: ...``) and exit
code 2; a bare traceback only appears with ``NLOS_DEBUG=1``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
from pathlib import Path

import numpy as np

from .args import parse_numbers
from .errors import NlosError
from .paths import input_dir, output_dir, output_file
from .render.settings import DEVICES


def _point(text: str, flag: str = "--spot-point") -> np.ndarray:
    return parse_numbers(text, "X,Y,Z", flag)


def cmd_render(args: argparse.Namespace) -> None:
    import torch

    from .render.person import Person
    from .render.sensor import SensorConfig, auto_exposure, sensor_capture
    from .render.transport import COMPONENTS, RENDER_PRESETS, Renderer
    from .scene import load_scene

    comps = tuple(c.strip() for c in args.components.split(",")) if args.components else COMPONENTS
    bad = [c for c in comps if c not in COMPONENTS]
    if bad:
        raise NlosError(f"--components: unknown component '{bad[0]}' (choose from {', '.join(COMPONENTS)})")
    out = output_file(args.out, "--out")
    if out.suffix != ".npy":
        raise NlosError(f"--out: expected a .npy path, got {out}")
    if not 0 <= args.seed < 2 ** 63:
        raise NlosError(f"--seed: expected an integer from 0 to 2^63 - 1, got {args.seed}")
    if args.burst is not None and args.noise != "sensor":
        raise NlosError("--burst: frames are averaged only in a sensor capture; add --noise sensor")
    if args.burst is not None and not 1 <= args.burst <= 1000:
        raise NlosError(f"--burst: expected a frame count from 1 to 1000, got {args.burst}")
    base = RENDER_PRESETS[args.preset]  # the flags' defaults: one place, render/settings.py
    counts = {"pixel_samples": "pixel_samples", "transport_samples": "transport_pixel_samples",
              "person_samples": "person_samples", "spot_samples": "spot_samples"}
    for flag, field_name in counts.items():
        v = getattr(args, flag)
        if v is None:
            setattr(args, flag, v := getattr(base, field_name))
        if not 1 <= v <= 100_000:
            raise NlosError(f"--{flag.replace('_', '-')}: expected a count from 1 to 100000, got {v}")
    scene = load_scene(args.scene_dir, human_mesh=args.human)
    if args.spot_point is not None:
        aim = _point(args.spot_point)
    else:
        n = scene.num_faces
        if not 0 <= args.spot_face < n:
            raise NlosError(f"--spot-face: {args.spot_face} out of range (scene has {n} faces)")
        aim = scene.static_mesh()[0].centroids()[args.spot_face]
    if np.linalg.norm(aim - scene.projector.position) < 1e-6:
        raise NlosError(f"--spot-point: {aim.tolist()} is the projector's own position; aim at a surface")
    if not 0 <= args.pixel_footprint <= 64:
        raise NlosError(f"--pixel-footprint: expected 0 (off) to 64, got {args.pixel_footprint}")
    settings = dataclasses.replace(base, pixel_footprint=args.pixel_footprint,
                                   **{f: getattr(args, flag) for flag, f in counts.items()})
    r = Renderer(scene, settings, aim_points=aim[None])
    if not r.spot_landed[0]:
        raise NlosError(f"projector: aimed at nothing (no surface along the beam toward {aim.tolist()})")
    person = Person.sampled(scene.human.mesh, scene.human.albedo, settings) \
        if scene.human is not None else None
    y = r.spot_vector(0)
    result = r.render(y, person, components=comps)
    image = result.image
    if args.noise == "sensor":
        cfg = SensorConfig.for_scene(scene, None if args.burst is None else {"burst_frames": args.burst})
        # the camera meters the person-free scene, whatever components are written
        metered = ("direct", "ambient") + (("interreflection",) if "interreflection" in comps else ())
        ref = r.render(y, None, components=metered).image
        exposure = auto_exposure(ref, cfg)
        gen = torch.Generator(device=image.device).manual_seed(args.seed)
        image = sensor_capture(image.clamp(min=0), exposure, cfg, generator=gen).radiance
    arr = image.detach().cpu().numpy().astype(np.float32)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp.npy")
    try:
        np.save(tmp, arr)
        tmp.replace(out)
    finally:
        tmp.unlink(missing_ok=True)
    from .console import console

    sums = ", ".join(f"{k}={float(v.sum()):.4g}" for k, v in result.components.items())
    console.print(f"wrote {out} {arr.shape} float32; per-component totals (W sr^-1 m^-2 summed over pixels): {sums}")


def _shard(text: str) -> tuple[int, int]:
    try:
        i, n = (int(v) for v in text.split("/"))
    except ValueError:
        raise NlosError(f"--shard: expected I/N (e.g. 0/4), got {text!r}") from None
    return i, n


def cmd_generate(args: argparse.Namespace) -> None:
    from .console import console
    from .data.config import load_config
    from .data.generate import generate

    cfg = load_config(args.config)
    if args.seed is not None:
        if args.seed < 0:
            raise NlosError(f"--seed: expected a non-negative integer, got {args.seed}")
        cfg.seed = args.seed
    rec = generate(cfg, output_dir(args.out, "--out"), _shard(args.shard), progress=not args.quiet, fuse=args.fuse,
                   device=args.device)
    manifest = Path(args.out) / "manifest.json"
    state = f"complete: {manifest}" if manifest.exists() else "other shards pending (manifest written by the last)"
    console.print(f"shard {rec['shard']}: {len(rec['scenes'])} scenes in {rec['seconds']:.1f} s; dataset {state}")


def cmd_verify(args: argparse.Namespace) -> None:
    from .console import console
    from .data.verify import dataset_problems

    data = Path(args.data_dir)
    if not data.is_dir():
        raise NlosError(f"{data}: no such dataset directory")
    if (data / "fit.json").is_file():  # a room model: its rendered people
        data = data / "data"
    if not (data / "manifest.json").exists():
        if not (data / "config.json").exists():
            raise NlosError(f"{data}: not a dataset (no config.json or manifest.json); give a directory "
                            "that nlos generate or nlos fit wrote")
        raise NlosError(f"{data}: an unfinished dataset (no manifest.json yet); rerun the same nlos generate "
                        "command to finish it")
    problems, n = dataset_problems(data, shapes=not args.digests_only)
    for path, why in problems:
        print(f"bad: {path}: {why}", file=sys.stderr)
    if problems:
        raise NlosError(f"{data}: {len(problems)} bad file{'s' * (len(problems) != 1)} (rerun nlos generate "
                        "with the same config to render them again)")
    console.print(f"{data}: {n} files match their digests and shapes; content_sha256 matches the manifest")


def cmd_train(args: argparse.Namespace) -> None:
    from .console import console
    from .train.config import load_train_config
    from .train.loop import train

    if args.method == "floor-net":
        return _train_floor_net(args)
    cfg = load_train_config(args.config)
    if args.seed is not None:
        if args.seed < 0:
            raise NlosError(f"--seed: expected a non-negative integer, got {args.seed}")
        cfg.seed = args.seed
    out = output_dir(args.out, "--out")
    if args.resume and not (out / "checkpoint.pt").exists():
        console.print(f"note: --resume: {out / 'checkpoint.pt'} does not exist; starting the run from step 0")
    tr = train(cfg, input_dir(args.data, "--data", "dataset directory"), out, resume=args.resume,
               progress=not args.quiet)
    if tr.rank == 0:
        console.print(f"trained {tr.step} steps; run in {Path(args.out).resolve()} (config.json, metrics.csv, final.pt)")


def _train_floor_net(args: argparse.Namespace) -> None:
    """``nlos train --method floor-net``: FloorNet across the dataset's rooms (``train/floor_net.py``)."""
    from .config_file import load_config_file
    from .console import QUIET, console
    from .train.floor_net import PRESETS, train_run

    if args.resume:
        raise NlosError("--resume: FloorNet trains in minutes and does not resume; run it again")
    cfg, _ = load_config_file(args.config, PRESETS, default_base="default")
    if args.seed is not None:
        if args.seed < 0:
            raise NlosError(f"--seed: expected a non-negative integer, got {args.seed}")
        cfg.seed = args.seed
    cfg.check()
    out = output_dir(args.out, "--out")
    log = None if (args.quiet or QUIET) else console.print
    run = train_run(cfg, input_dir(args.data, "--data", "dataset directory"), out, log)
    console.print(f"FloorNet trained {cfg.steps} steps, validation {run.best_cm:.1f} cm; run in {out.resolve()} "
                  "(floor_net.pt, floor_net.json)")


def cmd_evaluate(args: argparse.Namespace) -> None:
    import shlex

    from .console import console
    from .evaluate.experiment import run_all
    from .evaluate.write import write_all

    methods = [m.strip() for m in args.methods.split(",")] if args.methods else None
    input_dir(args.data, "--data", "dataset directory")
    output_dir(args.out, "--out")
    test_data = None
    if args.test_data:
        input_dir(args.test_data, "--test-data", "dataset directory")
        test_data = Path(args.test_data)
    ev = run_all(Path(args.run_dir), Path(args.data), args.seeds, methods, progress=not args.quiet,
                 test_data=test_data)
    command = "nlos " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv[1:] else "nlos evaluate"
    md = write_all(ev, Path(args.data), Path(args.run_dir), Path(args.out), command)
    console.print(f"report: {md.resolve()} (and report.html, raw.csv, summary.csv beside it)")


def cmd_spotlight(args: argparse.Namespace) -> None:
    from .apps.spotlight import print_result, spotlight, write_json
    from .scene.setup import load_setup
    from .console import console
    from .train.checkpoint import load_trained

    pt = {k: None if getattr(args, k) is None else _point(getattr(args, k), "--" + k.replace("_", "-"))
          for k in ("camera_position", "camera_look_at", "projector_position")}
    checkpoint = args.checkpoint or os.environ.get("NLOS_CHECKPOINT")
    if not checkpoint:
        raise NlosError("no trained run: pass --checkpoint RUN_OR_FILE (or set NLOS_CHECKPOINT)")
    for flag in ("json", "png"):
        if getattr(args, flag):
            output_file(getattr(args, flag), f"--{flag}")
    models = load_trained(checkpoint)
    setup = load_setup(args.mesh_or_scene, pt["camera_position"], pt["camera_look_at"], pt["projector_position"],
                       args.up)
    result = spotlight(models, setup, args.target_vertices, args.top_k)
    print_result(result, console)
    if args.json:
        write_json(result, Path(args.json))
        console.print(f"wrote {args.json}")
    if args.png:
        from .apps.plots import spotlight_figure

        spotlight_figure(result, Path(args.png))
        console.print(f"wrote {args.png}")


def cmd_fit(args: argparse.Namespace) -> None:
    from .config_file import apply_fields, flatten, merged, nest
    from .fit.config import PRESETS, FitConfig
    from .fit.run import fit_room

    if args.preset not in PRESETS:
        raise NlosError(f"--preset: expected one of {', '.join(PRESETS)}, got {args.preset!r}")
    base = PRESETS[args.preset]
    where, prefix = (args.config, "fit.") if args.config else ("nlos fit", "")
    given = nest(FitConfig, _config_file(args), where, prefix) if args.config else {}  # flags win over it
    if args.room is None:
        raise NlosError("fit: give the room (a scan or scene directory) or --config ROOM.yaml with a room")
    flags = _fit_flags(args)
    settings = merged(FitConfig, given, nest(FitConfig, flags))
    flat = flatten(FitConfig, settings)  # what is set, by field name, as the flags name them
    if isinstance(flat.get("method"), str):
        implied = _method_defaults(flat["method"], set(flat), "policy" not in flat)
        settings = merged(FitConfig, nest(FitConfig, implied), settings)
    flat = flatten(FitConfig, settings)
    if flat.get("shadow_samples") == 0 and "bounce" not in flat:
        settings["bounce"] = False  # the bounce goes through the shadow's relay points: none, no bounce
    bounce = settings.get("bounce", base.bounce)
    shadow = flat.get("shadow_samples", base.shadow.shadow_samples)
    given_flat = {**flatten(FitConfig, given), **flags}  # what the file or a flag says, not a default
    why = ", or a method without a spot" if flat.get("method") not in (None, "ours") else ""
    for k, off, leaves in (("bounce_scale", not bounce, f"the bounce, which this fit leaves out (--bounce off{why})"),
                           ("bounce_body_samples", not bounce, f"the bounce, which this fit leaves out (--bounce off{why})"),
                           ("shadow_depth", not shadow, f"the shadow, which this fit leaves out (--shadow-samples 0{why})")):
        if k in given_flat and off:
            v = given_flat[k]
            shown = f"{v:g}" if isinstance(v, (int, float)) and not isinstance(v, bool) else repr(v)
            raise NlosError(f"--{k.replace('_', '-')} {shown} sets {leaves}")
    cfg = apply_fields(base, settings, where, prefix)
    places = {k: getattr(args, k) for k in ("camera_position", "camera_look_at", "projector_position")
              if getattr(args, k) is not None}
    places = {k: _point(v, "--" + k.replace("_", "-")).tolist() for k, v in places.items()}
    if args.hidden_region is not None:
        places["hidden_region"] = args.hidden_region
    if args.up is not None:
        places["up"] = args.up
    fit_room(args.room, output_dir(args.out, "--out"), cfg, places, resume=args.resume, progress=not args.quiet,
             people_from=Path(args.people_from) if args.people_from else None)


def _fit_flags(args: argparse.Namespace) -> dict:
    """The ``FitConfig`` fields the command line gives (those not given are absent)."""
    out = {k: getattr(args, k) for k in ("people", "policy", "seed", "workers", "capture_preset", "pixel_footprint",
                                         "shadow_samples", "shadow_relay", "bounce_scale", "bounce_body_samples",
                                         "shadow_depth", "clothing", "world_variation", "ceiling_people", "render_device", "method",
                                         "epochs")
           if getattr(args, k) is not None}
    if args.burst is not None:
        out["burst_frames"] = args.burst
    if args.footprint_sampling is not None:
        out["footprint_jitter"] = args.footprint_sampling == "jittered"
    if args.bounce is not None:
        out["bounce"] = args.bounce == "on"
    if args.no_projection:
        out["project_nuisance"] = False
    if args.checkpoint:
        out["checkpoint"] = args.checkpoint
    return out


def _config_file(args: argparse.Namespace) -> dict:
    """The room config's fit settings (checked when applied with the flags); its room setup goes
    into ``args`` unless a flag says otherwise."""
    from .config_file import load_room_config

    rc = load_room_config(args.config)
    for k in ("room", "camera_position", "camera_look_at", "projector_position", "hidden_region", "up"):
        if k in rc and getattr(args, k) is None:
            setattr(args, k, rc[k])
    return dict(rc["fit"])


def _method_defaults(method: str, given: set[str], policy_free: bool) -> dict:
    """The fit settings ``--method`` implies where neither a flag nor the config file sets them: a
    baseline's own policy, and for one without a spot the settings without a spot term
    (``fit.config.UNAIMED_DEFAULTS``; one given otherwise is refused by name)."""
    from .evaluate.methods import UNAIMED, fit_method
    from .fit.config import UNAIMED_DEFAULTS

    m = fit_method(method)
    out = {"policy": m.policy} if method != "ours" and policy_free else {}
    if m.policy in UNAIMED:
        out.update({k: v for k, v in UNAIMED_DEFAULTS.items() if k not in given})
    return out


def _outputs_not_inputs(args: argparse.Namespace) -> None:
    """Refuse --csv / --json / --plot naming a file predict reads (a frame, the background, the model)."""
    from .apps.images import expand_inputs

    reads = set()
    for item in [*args.inputs, *([args.background] if args.background else [])]:
        try:
            reads |= {f.resolve() for f in expand_inputs([item])}
        except NlosError:  # reported when the frames are read
            pass
    ck = Path(args.checkpoint)
    reads |= {f.resolve() for f in (ck.rglob("*") if ck.is_dir() else [ck]) if f.is_file()}
    for flag in ("csv", "json", "plot"):
        out = getattr(args, flag)
        if out and Path(out).resolve() in reads:
            raise NlosError(f"--{flag}: {out} is one of this command's inputs; choose another file")


def _burst(flag: int | None, room, frames: int) -> int:
    """Frames averaged per capture: the flag, else the room model's burst where the frames split
    into it (a still person's capture), else 1 (each input is already one capture)."""
    if flag is not None:
        return flag
    if room is not None and room.burst_frames > 1 and frames % room.burst_frames == 0:
        return room.burst_frames
    return 1


def cmd_predict(args: argparse.Namespace) -> None:
    from .apps.images import load_frames
    from .apps.predict import predict, print_table, write_csv, write_json
    from .console import console
    from .fit.model import load_room_model
    from .train.checkpoint import load_trained

    for flag in ("csv", "json", "plot"):
        if getattr(args, flag):
            output_file(getattr(args, flag), f"--{flag}")
    _outputs_not_inputs(args)
    room = load_room_model(args.checkpoint)
    models = load_trained(args.checkpoint)
    if room is not None:
        room.check_network(models.config.policy)
    if args.burst is not None and args.burst < 1:
        raise NlosError(f"--burst: expected a positive frame count, got {args.burst}")
    if args.max_rows < 0:
        raise NlosError(f"--max-rows: expected a count of at least 0, got {args.max_rows}")
    loaded = load_frames(args.inputs, models.image_shape, args.linear, args.fps)
    small = [hw for hw in loaded.native_shapes if hw[0] < models.image_shape[0] or hw[1] < models.image_shape[1]]
    if small:
        raise NlosError(f"inputs of {small[0][0]}x{small[0][1]} pixels are smaller than the network's "
                        f"{models.image_shape[0]}x{models.image_shape[1]} input; give the camera's full frames")
    burst = _burst(args.burst, room, len(loaded))
    frames = loaded.bursts(burst)
    background = background_clipped = None
    if args.background:  # an empty-room burst: its frames averaged
        empty = load_frames([args.background], models.image_shape, args.linear)
        if empty.native_shapes != loaded.native_shapes:
            raise NlosError(f"--background: frames of {empty.native_shapes} (H, W) pixels, the captures "
                            f"{loaded.native_shapes}: photograph the empty room with the same camera settings")
        background = empty.images.mean(axis=0)
        background_clipped = None if empty.clipped is None else empty.clipped.any(axis=0)
    if args.batch_size < 1:
        raise NlosError(f"--batch-size: expected a positive count, got {args.batch_size}")
    tol = None
    if room is not None and getattr(models.net, "nuisance", None) is not None and background is not None:
        from .apps.drift import tolerance
        from .render.variation import load_layers

        layers = load_layers(room.path / "layers.npz")
        tol = tolerance(models.config.variation, burst, layers.f_px, layers.depth_m)
        if models.net.nuisance.person.numel() == 0:
            console.print("note: this room model predates the drift fit's people directions, so a person's own light "
                          f"can read as room-light drift; `nlos fit ... --out {room.path} --resume` adds them")
    if room is not None:
        console.print(room.describe())
        if args.burst is None and burst == room.burst_frames > 1:
            console.print(f"averaging consecutive bursts of {burst} frames, as the room model's capture "
                          "(--burst 1 reads each frame alone)")
        elif burst != room.burst_frames:
            console.print(f"note: the model was trained on bursts of {room.burst_frames} frames; "
                          f"{len(loaded)} frames read in bursts of {burst}" + (
                              "" if args.burst is not None else f" (not a multiple of {room.burst_frames})"))
    res = predict(models, frames, smooth=not args.no_smooth, window=args.smooth_window, order=args.smooth_order,
                  batch_size=args.batch_size, background=background, background_clipped=background_clipped,
                  backend=args.backend, drift_tolerance=tol)
    if room is not None:
        res.room_xy = room.room_xy(res.xy)
    aspects = {round(w / h, 2) for h, w in frames.native_shapes}
    if aspects - {round(models.image_shape[1] / models.image_shape[0], 2)}:
        console.print(f"note: inputs of size {frames.native_shapes} (H, W) were stretched to the network's "
                      f"{models.image_shape}; crop them to its aspect ratio for best results")
    print_table(res, console, args.max_rows)
    if res.drift is not None:
        flagged = res.drift.flagged
        for i in range(len(res))[:args.max_rows]:
            console.print(f"{i}: {res.drift.line(i)}")
        console.print(f"drift: {int(flagged.sum())} of {len(res)} captures beyond what the room model tolerates")
    if res.smoothed is None and len(res) > 1 and not args.no_smooth:
        console.print(f"{len(res)} frames: too few to smooth (need at least 5)")
    for flag, write in (("csv", write_csv), ("json", write_json)):
        if getattr(args, flag):
            write(res, Path(getattr(args, flag)))
            console.print(f"wrote {getattr(args, flag)}")
    if args.plot:
        from .apps.plots import trajectory_figure

        trajectory_figure(res, Path(args.plot))
        console.print(f"wrote {args.plot}")


class _Parser(argparse.ArgumentParser):
    """argparse with every other error's form: one line (``--help`` still prints the usage)."""

    def error(self, message: str):
        self.exit(2, f"error: {self.prog}: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    from .fit.config import CLOTHING  # a light module: dataclasses and errors only

    p = _Parser(prog="nlos", description="NLOS human localization with a projector spotlight")
    sub = p.add_subparsers(dest="command", required=True)
    from .render.settings import RENDER_PRESETS

    r = sub.add_parser("render", help="render a scene under one spot")
    r.add_argument("scene_dir")
    g = r.add_mutually_exclusive_group(required=True)
    g.add_argument("--spot-point", help="aim the projector at X,Y,Z (m)")
    g.add_argument("--spot-face", type=int, help="aim at the centroid of face K (faces of all shapes in order)")
    r.add_argument("--components", help="comma-separated subset of direct,interreflection,ambient,nlos,"
                                        "nlos_ambient (default: all)")
    r.add_argument("--human", help="body mesh (PLY/OBJ, world coordinates) replacing the scene's person")
    r.add_argument("--noise", choices=("none", "sensor"), default="none",
                   help="'sensor': a capture by the scene's camera (average metering on the person-free frame, "
                        "shot/read/quantization noise, clipping), written back in radiance units")
    r.add_argument("--burst", type=int, help="frames averaged per capture with --noise sensor (default: the "
                                            "scene's sensor setting, else 1)")
    r.add_argument("--seed", type=int, default=0, help="seed of the sensor noise")
    r.add_argument("--out", required=True, help="output .npy, float32 (height, width, 3)")
    r.add_argument("--preset", choices=[k for k in RENDER_PRESETS if k != "default"], default="single-image",
                   help="sample counts the flags below start from (single-image; fast: a frame at video rate)")
    one = RENDER_PRESETS["single-image"]
    r.add_argument("--pixel-samples", type=int, help=f"n x n sub-samples per pixel, per-scene terms ({one.pixel_samples})")
    r.add_argument("--transport-samples", type=int,
                   help=f"n x n sub-samples per pixel, person terms ({one.transport_pixel_samples})")
    r.add_argument("--pixel-footprint", type=int, default=0,
                   help="person terms over each pixel's footprint from N x N sub-samples sharing out the body "
                        "samples (about the cost of one; 0: --transport-samples instead)")
    r.add_argument("--person-samples", type=int, help=f"quadrature points on the person's body ({one.person_samples})")
    r.add_argument("--spot-samples", type=int, help=f"points sampling the spot's footprint ({one.spot_samples})")
    r.set_defaults(func=cmd_render)
    g = sub.add_parser("generate", help="generate a synthetic dataset (deterministic, sharded, resumable)")
    g.add_argument("config", help="preset (tiny, demo, demo-room, small, paper) or a YAML file of DatasetConfig fields")
    g.add_argument("--out", required=True, help="dataset directory (rerun the same command to resume)")
    g.add_argument("--shard", default="0/1", help="I/N: build scenes whose index is I mod N")
    g.add_argument("--seed", type=int, help="override the config's master seed")
    g.add_argument("--quiet", action="store_true", help="no progress bar (also NLOS_QUIET=1 or CI=true)")
    g.add_argument("--fuse", action="store_true",
                   help="compile the torch pair kernels (torch.compile) for a GPU: same data; on a CPU the "
                        "compiled pair loops (render/pair_loops.py) serve instead and this changes nothing")
    g.add_argument("--device", default="cpu", choices=DEVICES,
                   help="where people are rendered: cuda runs the pair kernels and the rays (Dr.Jit/OptiX, with "
                        "Mitsuba installed) on the GPU; auto: cuda when there is one (default cpu)")
    g.set_defaults(func=cmd_generate)
    v = sub.add_parser("verify", help="check a dataset: every file's digest and every array's shape")
    v.add_argument("data_dir", help="dataset directory from nlos generate (or a room model from nlos fit)")
    v.add_argument("--digests-only", action="store_true", help="skip reading the arrays (faster)")
    v.set_defaults(func=cmd_verify)
    t = sub.add_parser("train", help="train the IEN and the NLOS network end to end (torchrun for several processes), "
                                     "or FloorNet across rooms (--method floor-net)")
    t.add_argument("config", help="preset (tiny, demo, small, paper) or a YAML file of TrainConfig fields; "
                                  "with --method floor-net: default, tiny or a YAML file of FloorNetTraining fields")
    t.add_argument("--method", choices=("nlos-net", "floor-net"), default="nlos-net",
                   help="nlos-net: the IEN and the image network (default); floor-net: FloorNet on the backprojection, "
                        "the method for rooms no network saw")
    t.add_argument("--data", required=True, help="dataset directory from nlos generate")
    t.add_argument("--out", required=True, help="run directory")
    t.add_argument("--resume", action="store_true", help="continue from RUN/checkpoint.pt")
    t.add_argument("--seed", type=int, help="override the config's seed")
    t.add_argument("--quiet", action="store_true", help="no progress bar (also NLOS_QUIET=1 or CI=true)")
    t.set_defaults(func=cmd_train)
    e = sub.add_parser("evaluate", help="the paper's tables and figures on held-out scenes (trains the baselines)")
    e.add_argument("run_dir", help="run directory of ours (nlos train); baselines train under RUN/methods/")
    e.add_argument("--data", required=True, help="dataset directory (its test split is evaluated)")
    e.add_argument("--test-data", help="another dataset whose test split is evaluated instead (rooms of their own)")
    e.add_argument("--out", required=True, help="report directory")
    e.add_argument("--seeds", type=int, default=1, help="training seeds per method (the run's seed, then +1, ...)")
    e.add_argument("--methods", help="comma-separated subset of methods (default: all; ours always)")
    e.add_argument("--quiet", action="store_true", help="no progress bar (also NLOS_QUIET=1 or CI=true)")
    e.set_defaults(func=cmd_evaluate)
    s = sub.add_parser("spotlight", help="where to aim the projector: the IEN's choice of face on a scene or scan")
    s.add_argument("mesh_or_scene", help="nlos-scene/1 directory (its camera and projector) or a PLY/OBJ mesh (m)")
    s.add_argument("--checkpoint", help="trained run: final.pt / checkpoint.pt or the run directory "
                                        "(default: $NLOS_CHECKPOINT)")
    s.add_argument("--json", help="write everything (chosen face, top-k, aim, LOS mesh, probabilities) here")
    s.add_argument("--png", help="picture of the mesh colored by IEN probability with the spot marked")
    s.add_argument("--top-k", type=int, default=5, help="faces listed with their probabilities (default 5)")
    s.add_argument("--camera-position", help="X,Y,Z (m): camera pose for a bare mesh (default: derived from "
                                             "the mesh bounds, printed), or overriding a scene's")
    s.add_argument("--camera-look-at", help="X,Y,Z (m), with --camera-position")
    s.add_argument("--projector-position", help="X,Y,Z (m) (default for a bare mesh: 0.3 m right of and "
                                                "0.2 m below the camera)")
    s.add_argument("--target-vertices", type=int, help="decimate the camera-visible mesh to about N vertices "
                                                       "(default: the training dataset's, else 800)")
    s.add_argument("--up", help="a bare mesh's up axis: x, y, z, -x, -y, -z (default: detected)")
    s.set_defaults(func=cmd_spotlight)
    f = sub.add_parser("fit", help="a room (scan or scene) in, a trained room model out: spot, synthetic "
                                   "people, network, report")
    f.add_argument("room", nargs="?", help="nlos-scene/1 directory or a bare PLY/OBJ scan (meters, any up axis)")
    f.add_argument("--config", help="a room config (YAML): room (relative to the file), camera_position, "
                                    "camera_look_at, projector_position, hidden_region, up, and fit: settings; "
                                    "flags given here win")
    f.add_argument("--out", required=True, help="room model directory (final.pt, report.json, report.html)")
    f.add_argument("--camera-position", help="X,Y,Z (m, z-up frame): default derived from the mesh bounds, printed")
    f.add_argument("--camera-look-at", help="X,Y,Z (m), with --camera-position")
    f.add_argument("--projector-position", help="X,Y,Z (m): default 0.3 m right of and 0.2 m below the camera")
    f.add_argument("--hidden-region", help="XMIN,YMIN,XMAX,YMAX (m, floor of the z-up frame) where the person "
                                           "may be (default: the largest hidden floor rectangle found)")
    f.add_argument("--up", help="a bare scan's up axis: x, y, z, -x, -y, -z (default: detected)")
    f.add_argument("--people", type=int, help="synthetic training people (default 3000)")
    f.add_argument("--policy", help="spot policy: oracle (default), ien (with --checkpoint), adaptive, center, random")
    f.add_argument("--method", help="what is fitted (nlos evaluate's methods): ours (default: the --policy spot "
                                    "and ResNet-18), al_resnet, center_resnet, random_resnet, oracle_resnet, chandran "
                                    "(Adaptive Lighting's spot and Chandran's CNN), ien_cnn; without a spot: tancik "
                                    "(the flash, Tancik et al.'s CNN), dlnlos (projector off, DL-NLOS's CNN), which "
                                    "render no shadow, bounce or drift (--shadow-samples 0, --bounce off, --capture-preset ideal)")
    f.add_argument("--checkpoint", help="trained run whose IEN picks the spot (--policy ien)")
    f.add_argument("--burst", type=int, help="frames averaged per capture (default 16)")
    f.add_argument("--workers", type=int, help="processes rendering people (default 0: one a core, as many as the "
                        "memory holds at 1.8 GB each; one on a GPU)")
    f.add_argument("--device", dest="render_device", choices=DEVICES,
                   help="where people are rendered (default cpu): cuda runs the pair kernels and the rays on the GPU "
                        "(nlos generate --device); training uses a GPU whenever there is one")
    f.add_argument("--capture-preset", help="capture variation to train for: tripod (default), rough, or ideal "
                                            "(photographs that match to the last bit: the recipe before drift)")
    f.add_argument("--pixel-footprint", type=int, help="the person's light integrated over each pixel from N x N "
                                                       "sub-samples (default 8); 0: at the pixel's centre (the "
                                                       "recipe before it)")
    f.add_argument("--footprint", dest="footprint_sampling", choices=("grid", "jittered"),
                   help="the footprint's sub-samples at their cells' centres (grid) or jittered in them, a draw "
                        "per set of people (jittered: an unbiased pixel mean)")
    f.add_argument("--bounce", choices=("on", "off"), help="also each person's light over one more static bounce "
                   "(the room relaying the spot onto the body and the body's light to the camera), in every "
                   "training photograph (default on; off: the recipe before it)")
    f.add_argument("--bounce-scale", type=float, help="training multiplies the stored fifth bounce by this "
                   "(default 1.9: every later bounce, as Mitsuba measures them; 1: the fifth alone)")
    f.add_argument("--shadow-depth", type=int, help="the shadow counts the spot's light to this many bounces "
                   "(Mitsuba's max_depth; default 10: also the room's later relays the body stops; 4: the first "
                   "relay alone, the recipe before it)")
    f.add_argument("--bounce-body-samples", type=int, help="body samples of the bounce's exchange with the room "
                   "(default 1024; 0: the body's own quadrature, the recipe before it)")
    f.add_argument("--shadow-samples", type=int, help="static points relaying the spot light each body blocks "
                                                      "(default 4096); 0: the shadow term left out")
    f.add_argument("--shadow-relay", choices=("per-person", "fixed"), help="the shadow's relay points drawn "
                                                                           "per person (default) or one fixed set")
    f.add_argument("--epochs", type=float, help="passes over the training people (default 60; a training setting: "
                                                "--people-from a model of the same room renders nothing again)")
    f.add_argument("--ceiling", dest="ceiling_people", type=int, help="held-out people the room's ceiling (an ideal "
                   "observer's posture accuracy, the position bound) is computed on (default 6; 0: none)")
    f.add_argument("--world-variation", help="calibration error to train under: the people rendered in worlds "
                                             "off the scan by camera pose, projector aim, albedo and geometry "
                                             "(tripod, rough); ideal: in the scan itself (default)")
    f.add_argument("--clothing", choices=CLOTHING,
                   help="clothing albedos training redresses people in: camera-log (black to white fabric, "
                        "log-uniform in brightness; default), camera (the same range, uniform: dark fabric "
                        "a quarter as often) or dataset (as rendered)")
    f.add_argument("--no-projection", action="store_true", help="train under the capture variation without "
                                                                 "projecting its directions out (an ablation)")
    f.add_argument("--preset", default="default", help="default, demo (600 people: make demo), or tiny (tens of "
                   "people: a first look, tests)")
    f.add_argument("--seed", type=int, help="master seed (default 0)")
    f.add_argument("--resume", action="store_true", help="continue the fit in --out")
    f.add_argument("--people-from", help="a room model of the same room and settings whose rendered people to train "
                                         "on (another --capture-preset or epochs without rendering again)")
    f.add_argument("--quiet", action="store_true", help="no progress bar (also NLOS_QUIET=1 or CI=true)")
    f.set_defaults(func=cmd_fit)
    q = sub.add_parser("predict", help="position and posture of the hidden person from photos, a stack or a video")
    q.add_argument("checkpoint", help="trained run: final.pt / checkpoint.pt, the run directory, or a room model "
                                      "(nlos fit --out)")
    q.add_argument("inputs", nargs="+", metavar="IMAGES_OR_VIDEO",
                   help=".npy (H,W,3) or (N,H,W,3) linear radiance, PNG/JPEG (8/16-bit sRGB), a directory, "
                        "a numbered pattern (img_%%04d.png), or one video (needs imageio)")
    q.add_argument("--csv", help="per-frame table: position, posture, probabilities, smoothed position")
    q.add_argument("--json", help="the same as JSON")
    q.add_argument("--plot", help="PNG of the trajectory (and positions over time)")
    q.add_argument("--fps", type=float, help="frame rate for time stamps (default: the video's, else none)")
    q.add_argument("--linear", action="store_true", help="PNG/JPEG values are linear (do not undo sRGB)")
    q.add_argument("--smooth-window", type=int, help="Savitzky-Golay window in frames, odd "
                                                     "(default: about a fifth of the frames, at least 5)")
    q.add_argument("--smooth-order", type=int, default=2, help="Savitzky-Golay polynomial order (default 2)")
    q.add_argument("--no-smooth", action="store_true", help="no smoothed trajectory")
    q.add_argument("--background", help="empty-room image or burst (frames averaged), for networks trained with "
                                        "background subtraction (room models are)")
    q.add_argument("--burst", type=int, help="average consecutive groups of this many frames (a still capture's "
                                             "burst; a room model says its length)")
    q.add_argument("--batch-size", type=int, default=64, help="frames per forward pass")
    q.add_argument("--backend", default="eager", choices=("eager", "torch", "onnx", "onnx-int8"),
                   help="network runtime: eager PyTorch, folded channels-last PyTorch, ONNX Runtime, or ONNX "
                        "Runtime int8 calibrated on the first frames (onnx*: pip install 'nlos-spotlight[fast]'; "
                        "see benchmarks/inference_latency.py)")
    q.add_argument("--max-rows", type=int, default=40, help="frames shown on screen (all go to --csv/--json)")
    q.set_defaults(func=cmd_predict)
    return p


_POINT_FLAGS = ("--spot-point", "--camera-position", "--camera-look-at", "--projector-position", "--hidden-region")
"""Flags whose X,Y,Z value may start with a minus sign."""


def _glue_values(argv: list[str]) -> list[str]:
    """``--spot-point -0.3,0,1`` would read as an option to argparse: glue such values to their flag."""
    out, i = [], 0
    while i < len(argv):
        if argv[i] in _POINT_FLAGS and i + 1 < len(argv):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(_glue_values(sys.argv[1:] if argv is None else argv))
    try:
        args.func(args)
    except NlosError as exc:
        if os.environ.get("NLOS_DEBUG"):
            raise
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a path the checks could not foresee (a full disk, a vanished directory)
        if os.environ.get("NLOS_DEBUG"):
            raise
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"error: {where}{exc.strerror or type(exc).__name__}", file=sys.stderr)
        return 2
    except RecursionError:  # a JSON or YAML file nested absurdly deep
        print("error: an input file is nested too deeply to read (a damaged or hostile file)", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # finished work is on disk: every step resumes
        resume = " (rerun it with --resume to continue)" if getattr(args, "resume", None) is not None else ""
        print(f"error: interrupted; what was finished is kept{resume}", file=sys.stderr)
        return 130
    except (ValueError, RuntimeError, MemoryError) as exc:
        if os.environ.get("NLOS_DEBUG"):
            raise
        print(f"error: {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
