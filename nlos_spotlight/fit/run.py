"""``nlos fit``: a room in, a trained room model out (scan -> spot -> synthetic people -> network).

Steps, each resumable (a rerun with ``--resume`` skips what is finished and continues what is not):

1. **room**: :func:`.room.room_setup`, saved as ``ROOM_MODEL/room/`` (an nlos-scene/1 directory).
2. **people**: ``nlos generate`` on that room (``DatasetConfig.room``): the first
   ``transport_people`` under every candidate spot, then the rest as image samples under the
   stored spots, rendered by ``workers`` processes (``SceneBuilder.build(part=...)``).
3. **spot**: the policy's face among the candidates, and how to aim the projector at it.
   The room's static light under that spot at sub-pixel resolution is rendered once
   (``ROOM_MODEL/layers.npz``, ``render.layers``): what camera motion and drift move. Then the
   light each person's body blocks under that spot (``ROOM_MODEL/shadow/``, ``fit/shadow.py``).
   A method without a spot (``FitConfig.light``: the flash, the projector off) has none of these:
   its record says what to photograph and what the fit leaves out (``spot.light_record``).
4. **train**: the seen-rooms recipe (``train.recipe``) with the fit's capture (a burst of
   ``burst_frames``) and its capture variation (``capture_preset``), best weights kept as
   ``ROOM_MODEL/final.pt``.
5. **report**: the room's ceiling (``fit/ceiling.py``: an ideal observer's posture accuracy and the
   position Cramer-Rao bound on ``ceiling_people`` held-out people), the held-out people scored
   (``report.json``, ``report.html``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import multiprocessing as mp
import os
import shutil
import time
from pathlib import Path

from ..errors import NlosError
from .config import FitConfig, auto_workers, recorded

FORMAT = "nlos-room-model/1"
RESUMABLE_CHANGES = ("workers", "render_device")
"""Settings a resumed fit may change: the process count (the output is byte-identical) and the
rendering device (the same numbers to float rounding)."""
TRAINING_ONLY = ("capture_preset", "project_nuisance", "epochs", "min_steps", "workers", "render_device", "shadow_samples", "shadow_relay", "bounce",
                 "bounce_scale", "shadow_depth", "bounce_body_samples", "clothing", "world_variation", "ceiling_people", "method")
"""Settings that leave the room and its rendered people as they are (``--people-from`` may differ in them;
also ``policy`` between fixed policies, whose spots every room stores: only the IEN adds spots)."""


def dataset_config(cfg: FitConfig, room_dir: Path, extra_spots: list[int] | None = None):
    """The one-room dataset of a fit (``DatasetConfig`` over the saved room, named relative to the
    dataset directory ``ROOM_MODEL/data``, so the room model can move)."""
    from ..data.config import DatasetConfig

    return DatasetConfig(name="fit", seed=cfg.seed, train_scenes=1, val_scenes=0, test_scenes=0,
                         samples_per_scene=cfg.samples, transport_samples_per_scene=cfg.transport_people,
                         trajectories_per_test_scene=0, trajectories_per_train_scene=0, resolution=cfg.resolution,
                         los_vertices=cfg.los_vertices, body_faces=cfg.body_faces,
                         render=dataclasses.replace(cfg.render), room=str(Path("..") / room_dir.name),
                         extra_spots=list(extra_spots or []))


def room_builder(out: Path, cfg: FitConfig):
    """(``SceneBuilder``, ``DatasetConfig``) of a room model's one room: its people drawn again as the
    fit drew them (``SceneBuilder.rerender``), the room named by its absolute path."""
    from ..data.generate import plan
    from ..data.scene_builder import SceneBuilder

    out = Path(out)
    dcfg = dataclasses.replace(dataset_config(cfg, out / "room"), room=str((out / "room").resolve()))
    return SceneBuilder(dcfg, plan(dcfg)[0], out / "data"), dcfg


def finished_model(out: Path):
    """(``FitConfig``, the spot's aim (3,), ``SceneBuilder``, ``DatasetConfig``) of a finished room
    model that aims a spot (studies that render its people again), or a one-line ``NlosError``."""
    import numpy as np

    out = Path(out)
    try:
        report = json.loads((out / "report.json").read_text())
        cfg = FitConfig.from_record(json.loads((out / "fit.json").read_text())["settings"])
    except (OSError, ValueError, KeyError, TypeError):
        raise NlosError(f"{out}: not a finished room model (no readable report.json and fit.json)") from None
    if not isinstance(report.get("spot"), dict):
        raise NlosError(f"{out}: the room model aims no spot (--method {cfg.method})")
    builder, dcfg = room_builder(out, cfg)
    return cfg, np.asarray(report["spot"]["aim"], np.float64), builder, dcfg


def heldout_model(out: Path, people: int):
    """:func:`finished_model`'s four and the indices (at most ``people``) of the room model's first
    held-out people: what the studies that render a fit's held-out people again start from."""
    from .train import heldout_indices

    cfg, aim, builder, dcfg = finished_model(out)
    return cfg, aim, builder, dcfg, heldout_indices(Path(out), cfg)[:people]


def die_with_parent() -> None:
    """This process ends when the fit that started it does (Linux: the parent-death signal; elsewhere
    the callers notice a dead parent themselves)."""
    import signal

    try:
        import ctypes

        ctypes.CDLL("libc.so.6").prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _part(dcfg, data: str, i: int, n: int, device: str = "cpu", peak=None) -> None:
    """One rendering process: its share of the image samples (after part 0 stored the spots); its
    own peak memory goes to ``peak`` (a shared value) as it ends. It dies with the fit (Linux: the
    parent-death signal), and fails with one line, not a traceback."""
    import sys

    die_with_parent()  # not Linux: the wait below still notices a dead parent
    from ..data.generate import generate, plan

    try:
        spots = Path(data) / "scenes" / plan(dcfg)[0].id / "spots.json"
        parent = os.getppid()
        while not spots.exists():
            if os.getppid() != parent:  # the fit was killed: nothing to wait for
                return
            time.sleep(1.0)
        generate(dcfg, data, progress=False, part=(i, n), device=device)
    except Exception as exc:  # the main process reports the failure; this is its reason
        print(f"error: rendering process {i}: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}",
              file=sys.stderr)
        sys.exit(2)
    finally:
        if peak is not None:
            peak.value = own_peak_mb()


def render_people(dcfg, data: Path, workers: int, progress: bool, device: str = "cpu") -> None:
    """Generate the fit's dataset with ``workers`` processes sharing the one room, on ``device``."""
    from ..data.generate import generate

    if workers <= 1 or (data / "manifest.json").exists():
        generate(dcfg, data, progress=progress, device=device)
        return
    from ..data.store import remove_stale_temporaries

    data.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(data)  # before any part writes: later, another's temporary may be in flight
    ctx = mp.get_context("spawn")
    peaks = [ctx.Value("d", 0.0, lock=False) for _ in range(1, workers)]  # written once, read after join
    procs = [ctx.Process(target=_part, args=(dcfg, str(data), i, workers, device, peaks[i - 1]), daemon=True)
             for i in range(1, workers)]
    for p in procs:
        p.start()
    try:
        generate(dcfg, data, progress=progress, part=(0, workers), device=device)
    except BaseException:  # an error or Ctrl-C: stop the other parts too (their files are kept)
        for p in procs:
            p.terminate()
        raise
    finally:
        for p in procs:
            p.join()
        WORKER_PEAKS_MB.extend(v.value for v in peaks if v.value > 0)
    bad = [p.exitcode for p in procs if p.exitcode != 0]
    if bad:
        raise NlosError(f"{data}: a rendering process failed (exit {bad[0]}); rerun with --resume to continue")
    generate(dcfg, data, progress=False, device=device)  # every part is there: done.json and the manifest


def check_out(out: Path, record: dict, resume: bool) -> None:
    """Refuse to mix fits: the directory ``out`` holds nothing but the lock, or (with ``resume``) a fit
    with the same settings. Nothing is written here (``fit_room`` refused a file ``out`` before its
    lock, and removes what the lock made when this refuses)."""
    path = out / "fit.json"
    if path.exists():
        try:
            old = json.loads(path.read_text())
        except json.JSONDecodeError:
            raise NlosError(f"{path}: corrupted (invalid JSON); remove {out} to start over") from None
        if not resume:
            raise NlosError(f"{out} already holds a fit: pass --resume to continue it, or choose another --out")
        a, b = recorded(old.get("settings", {})), recorded(record["settings"])
        diff = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k) and k not in RESUMABLE_CHANGES)
        if diff:
            raise NlosError(f"{out} holds a fit with other settings (differs in: {', '.join(diff)}; a fit made "
                            f"under older defaults resumes with the flags it had, or choose another --out)")
        return
    if out.exists() and any(p.name != LOCK for p in out.iterdir()):
        raise NlosError(f"--out: {out} exists and is not a room model; choose an empty or new directory")


def _atomic_json(path: Path, obj) -> None:
    from ..data.store import atomic_json

    atomic_json(path, obj)


class StepClock:
    """Seconds each step has run, summed over every run of a resumed fit (``timing.json``)."""

    def __init__(self, out: Path):
        self.path = Path(out) / "timing.json"
        self.seconds = json.loads(self.path.read_text()) if self.path.exists() else {}
        self.t = time.perf_counter()

    def lap(self, step: str) -> None:
        now = time.perf_counter()
        self.seconds[step] = self.seconds.get(step, 0.0) + now - self.t
        self.t = now
        if self.path.parent.exists():
            _atomic_json(self.path, self.seconds)

    @property
    def total(self) -> float:
        return sum(v for k, v in self.seconds.items() if k != "total_s")


def own_peak_mb() -> float:
    """This process's own peak resident memory, MB (MiB): the kernel's ``VmHWM`` on Linux (since
    :func:`reset_peak`), elsewhere ``ru_maxrss``. Not ``ru_maxrss`` on Linux: a process started by
    fork and exec (multiprocessing's ``spawn``) reads there at least its parent's peak so far, and
    so does its parent's ``RUSAGE_CHILDREN``
    (``tests/fit/test_fit.py::test_a_process_reads_its_own_peak_memory_not_its_parents``: a spawned
    child of a process holding 1 GiB reads its own peak here)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except (OSError, ValueError, IndexError):
        pass
    import resource
    import sys

    per_mb = 2 ** 20 if sys.platform == "darwin" else 2 ** 10  # ru_maxrss counts bytes on macOS, kB on Linux
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / per_mb


def reset_peak() -> None:
    """Start this process's ``VmHWM`` again from its present size (Linux's ``clear_refs`` 5), so
    that a fit in a long-lived process (the demo, a notebook, a study's loop) reports its own peak;
    where the kernel refuses, the peak stays the process's."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


WORKER_PEAKS_MB: list[float] = []
"""The own peaks (:func:`own_peak_mb`) this fit's rendering processes reported at their end (the
people's and the shadow step's; emptied when a fit starts)."""


def peak_memory_mb() -> dict:
    """Peak resident memory, MB, of this fit's process since the fit began (:func:`reset_peak`) and
    of the largest rendering process it started in this run, each its own (:func:`own_peak_mb`).
    The second is None when this run started none (one worker, or a resumed fit whose people and
    shadows an earlier run rendered) and counts only this run's processes when a fit is resumed.
    The two measure what ``fit.config.WORKER_BYTES`` sets aside a process."""
    return {"fit_process": round(own_peak_mb()),
            "rendering_process": round(max(WORKER_PEAKS_MB)) if WORKER_PEAKS_MB else None}


def reuse_people(source: Path, out: Path, record: dict) -> None:
    """Start ``out`` from the room and rendered people of the room model ``source`` (same room, people
    and render settings; other :data:`TRAINING_ONLY` settings): its ``room/`` copied, its ``data/``
    and ``shadow/`` hard-linked where the file system allows (files are only ever replaced, never
    written in place, so the two fits cannot change each other's; the shadow step keeps the blocks
    only where their spot and settings are this fit's), its ``ceiling.json`` copied (a function of
    the room, its people and the render, all shared, and of the spot, the ceiling's people, the
    burst and the light, which ``fit.ceiling.ceiling_record`` checks: 4-7 min a fit on 2 cores).
    Nothing is written outside ``out``."""
    import shutil

    source = Path(source)
    try:
        old = json.loads((source / "fit.json").read_text())["settings"]
    except (OSError, json.JSONDecodeError, KeyError, TypeError):
        raise NlosError(f"--people-from: {source} is not a room model (no readable fit.json)") from None
    old, new = recorded(old), recorded(record["settings"])
    fixed = "ien" not in (old.get("policy"), new.get("policy"))
    diff = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k) and k not in TRAINING_ONLY
                  and not (k == "policy" and fixed))
    if diff:
        raise NlosError(f"--people-from: {source} was fitted with other settings (differs in: {', '.join(diff)})")
    if not (source / "data" / "manifest.json").exists() or not (source / "room.json").exists():
        raise NlosError(f"--people-from: {source} has not finished rendering its people; resume it first")

    def link(src, dst):
        try:
            os.link(src, dst)
        except OSError:  # another file system: a copy
            shutil.copy2(src, dst)

    out.mkdir(parents=True, exist_ok=True)
    shutil.copytree(source / "room", out / "room")
    shutil.copytree(source / "data", out / "data", copy_function=link)
    if (source / "shadow").is_dir() and new.get("shadow_samples"):  # no spot: no shadow to keep
        shutil.copytree(source / "shadow", out / "shadow", copy_function=link)
    shutil.copy2(source / "room.json", out / "room.json")
    if (source / "ceiling.json").exists():  # the room, its people and the render: ceiling_record checks the rest
        shutil.copy2(source / "ceiling.json", out / "ceiling.json")
    _atomic_json(out / "fit.json", record)


def fit_room(room: str, out: Path, cfg: FitConfig, flags: dict, resume: bool = False, progress: bool = True,
             people_from: Path | None = None) -> dict:
    """Run every step (module docstring); returns ``report.json``'s content. ``people_from``: a room
    model of the same room whose rendered people this fit trains on (:func:`reuse_people`)."""
    from ..data.generate import versions

    out = Path(out)
    WORKER_PEAKS_MB.clear()  # this fit's rendering processes only
    reset_peak()  # and this fit's own peak
    record = {"format": FORMAT, "settings": {"room": str(Path(room).resolve()), **flags, **cfg.to_dict()},
              "versions": versions()}
    from ..render.settings import resolve_device

    resolve_device(cfg.render_device)  # --device cuda without a GPU: refused before anything is written
    if cfg.policy == "ien":  # a bad checkpoint is refused before anything is written
        from .spot import check_ien_run

        check_ien_run(cfg.checkpoint)
    if out.exists() and not out.is_dir():
        raise NlosError(f"--out: {out} is a file, not a directory")
    existed = out.exists()
    with out_lock(out):  # first: a fit running in ``out`` is named as such, not as a stranger's files
        try:
            check_out(out, record, resume)
        except BaseException:
            _clear(out, existed)
            raise
        fresh = not (out / "fit.json").exists()
        return _fit_steps(room, out, cfg, flags, record, (fresh, existed), progress, people_from)


def _clear(out: Path, existed: bool, everything: bool = False) -> None:
    """Remove what a refused fit wrote: ``out`` itself if it made it; else the lock file, or with
    ``everything`` all that ``out`` holds (it held nothing when the fit began)."""
    if not existed:
        shutil.rmtree(out, ignore_errors=True)
        return
    for p in out.iterdir() if everything else [out / LOCK]:
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)


LOCK = ".fit.lock"
"""File in ``--out`` a running fit holds locked (``out_lock``)."""


@contextlib.contextmanager
def out_lock(out: Path):
    """Hold ``out/.fit.lock`` for the fit's duration; a second fit into ``out`` is refused in one line
    instead of both writing the same files. The OS drops the lock when the process dies."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / LOCK
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            import fcntl

            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:  # no advisory locks on this platform: run unguarded
            pass
        except OSError:
            other = os.pread(fd, 32, 0).decode(errors="replace").strip() or "another process"
            raise NlosError(f"{out}: another nlos fit (pid {other}) is writing to it; wait for it to finish, "
                            "or choose another --out") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield
    finally:
        os.close(fd)


def _fit_steps(room: str, out: Path, cfg: FitConfig, flags: dict, record: dict, state: tuple[bool, bool],
               progress: bool, people_from: Path | None) -> dict:
    """Steps 1-5 under the lock (``fit_room``); ``state``: (no fit in ``out`` yet, ``out`` existed)."""
    from ..console import console

    fresh, existed = state
    try:
        if people_from is not None and fresh:
            reuse_people(people_from, out, record)
        clock = StepClock(out)
        console.rule("1/5 room")
        setup = _room(room, out, cfg, flags, record)
        clock.lap("room_s")
        console.rule("2/5 people")
        extra = _ien_spot(cfg, out / "room") if cfg.policy == "ien" else []
        render_people(dataset_config(cfg, out / "room", extra), out / "data", auto_workers(cfg.workers, cfg.render_device),
                      progress, cfg.render_device)
        clock.lap("generate_s")
    except BaseException as exc:  # refused input, a hostile file, Ctrl-C
        if fresh and not _has_people(out):  # no work worth keeping: the corrected rerun starts clean
            _clear(out, existed, everything=True)
            if isinstance(exc, NlosError):
                raise NlosError(f"{exc} (nothing was kept in {out})") from None
        raise
    console.rule("3/5 spot" if cfg.light == "spot" else f"3/5 light: {cfg.light}, no spot")
    from .train import room_split, train_room

    split = room_split(out, cfg, ["normals"])
    spot, layers = _spot_step(out, cfg, split, extra)
    clock.lap("spot_s")
    if cfg.shadow.shadow_samples > 0:  # the light each body blocks, under the chosen spot
        from .shadow import render_shadows

        console.rule("3/5 spot: shadow")
        render_shadows(out, cfg, spot, progress)
        split = room_split(out, cfg, ["normals"], shadow_spot=int(spot["face"]))
        clock.lap("shadow_s")
    console.rule("4/5 train")
    result = train_room(cfg, out, progress, split, layers)
    if result.spots[0] != spot["face"]:
        raise NlosError(f"the trained network used spot {result.spots[0]}, not the chosen {spot['face']}")
    clock.lap("train_s")
    console.rule("5/5 report")
    from .ceiling import ceiling_record
    from .report import write_fit_report

    ceiling = ceiling_record(out, cfg, spot, progress)
    clock.lap("ceiling_s")
    report = write_fit_report(out, cfg, setup, spot, result, {**clock.seconds, "total_s": clock.total}, ceiling,
                              peak_memory_mb())
    clock.lap("report_s")
    h = report["heldout"]
    console.print(f"held-out people: {h['people']}, posture {100 * h['posture_accuracy']:.1f}% (upright/sitting/"
                  f"crouching {100 * h['posture3_accuracy']:.1f}%), error {h['error_cm']:.1f} cm; fit "
                  f"{report['timing_s']['total_s'] / 60:.1f} min before the report; room model: {out.resolve()} "
                  "(final.pt, report.json, report.html)")
    return report


def _spot_step(out: Path, cfg: FitConfig, split, extra: list[int]) -> tuple[dict, object]:
    """Step 3 before the shadow: (the spot's record, the room's static layers under it); without a
    spot (``cfg.light``) the light's record (``spot.light_record``) and no layers, saying what the
    fit leaves out."""
    from ..console import console
    from .spot import light_record, policy_face, spot_policies, spot_record
    from .train import room_layers

    if cfg.light == "spot":
        spot = spot_record(out, extra[0] if extra else policy_face(cfg, split))
    else:
        spot = light_record(cfg)
    console.print(spot["explain"])
    for step, why in spot.get("not_rendered", {}).items():
        console.print(f"left out: {step}: {why}")
    spot["policies"] = spot_policies(out, cfg, split, spot["face"])
    console.print("spot SNR over the best candidate's: " + ", ".join(
        f"{k}{' (' + v['light'] + ')' if 'light' in v else ''} {v['snr_over_best']:.2f}"
        for k, v in spot["policies"]["policies"].items()))
    if cfg.light != "spot":
        return spot, None
    return spot, room_layers(out, spot["aim"])  # the static light the capture variation moves


def _has_people(out: Path) -> bool:
    """Whether ``out`` holds a rendered person (work a failed fit must keep for --resume)."""
    return any((out / "data").rglob("*.npz"))


def _room(room: str, out: Path, cfg: FitConfig, flags: dict, record: dict) -> dict:
    """Step 1: the room, saved once (a rerun reads it back)."""
    from ..console import console
    from ..scene.io import load_scene, save_scene
    from .room import room_setup

    path = out / "room.json"
    if (out / "room" / "scene.json").exists() and path.exists():
        rec = json.loads(path.read_text())
        load_scene(out / "room")  # still readable
        console.print(f"room: {out / 'room'} (from the first run)")
        return rec
    s = room_setup(room, cfg.resolution, flags.get("camera_position"), flags.get("camera_look_at"),
                   flags.get("projector_position"), flags.get("hidden_region"), flags.get("up"))
    out.mkdir(parents=True, exist_ok=True)  # the input is good: from here on every step is kept
    if not (out / "fit.json").exists():
        _atomic_json(out / "fit.json", record)
    save_scene(s.scene, out / "room")
    sc = s.scene
    mesh = sc.static_mesh()[0]
    rec = {"camera": {"position": sc.camera.position.tolist(), "look_at": sc.camera.look_at.tolist(),
                      "fov_deg": sc.camera.fov_deg, "source": s.sources["camera"]},
           "projector": {"position": sc.projector.position.tolist(), "source": s.sources["projector"]},
           "hidden_region": {**sc.hidden_region.to_dict(), "source": s.sources["hidden_region"]},
           "materials": s.sources["materials"], "hidden_check": s.hidden,
           "file_to_world": s.file_to_world.tolist(), "faces": sc.num_faces,
           "extent": {"min": mesh.vertices.min(0).tolist(), "max": mesh.vertices.max(0).tolist()}}
    _atomic_json(path, rec)
    _print_room(rec, console)
    return rec


def _print_room(rec: dict, console) -> None:
    v = lambda a: "(" + ", ".join(f"{x:+.2f}" for x in a) + ")"
    note = {"flags": "from flags", "scene": "from the scene", "default": "default: set it with a flag to change it"}
    hr, ex = rec["hidden_region"], rec["extent"]
    console.print(f"room: {rec['faces']} faces, z up; x {ex['min'][0]:.2f}..{ex['max'][0]:.2f}, y {ex['min'][1]:.2f}.."
                  f"{ex['max'][1]:.2f}, z {ex['min'][2]:.2f}..{ex['max'][2]:.2f} m")
    console.print(f"camera ({note[rec['camera']['source']]}): at {v(rec['camera']['position'])} looking at "
                  f"{v(rec['camera']['look_at'])}")
    console.print(f"projector ({note[rec['projector']['source']]}): at {v(rec['projector']['position'])}")
    console.print(f"hidden region ({note[hr['source']]}): x {hr['min'][0]:.2f}..{hr['max'][0]:.2f}, "
                  f"y {hr['min'][1]:.2f}..{hr['max'][1]:.2f} m, floor z {hr['floor_z']:.2f} m; "
                  f"hidden check: camera sees {rec['hidden_check']['seen_by_camera']}, projector "
                  f"{rec['hidden_check']['seen_by_projector']} of {rec['hidden_check']['points']} points")
    console.print(f"materials: {rec['materials']}")


def _ien_spot(cfg: FitConfig, room_dir: Path) -> list[int]:
    """The face a trained run's IEN picks on the room's candidates (computed like the dataset's)."""
    from ..scene.los import los_mesh
    from ..render.surface import StaticSurfaces
    from ..scene.io import load_scene
    from .spot import check_ien_run, ien_face

    models = check_ien_run(cfg.checkpoint)
    scene = load_scene(room_dir)
    surf = StaticSurfaces(scene)
    los = los_mesh(surf.mesh, surf.engine, scene.camera, cfg.los_vertices)
    return [ien_face(models, scene, los)]


__all__ = ["FORMAT", "dataset_config", "finished_model", "fit_room", "render_people", "reuse_people", "room_builder"]
