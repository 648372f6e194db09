"""``nlos verify``: every file of a dataset against its recorded digest, and every array's shape.

A scene's ``done.json`` lists the SHA-256 of each of its files (``data.store.file_digest``); the
manifest's ``content_sha256`` hashes them all. Shapes: ``static.npz`` fixes the candidate count T
and the image size (H, W); every full-transport sample must hold ``transport_u`` (T, r),
``transport_v`` (r, H, W, 3) and the (H, W, 3) images, every image sample ``nlos_spots`` (K, H, W, 3)
with K the room's stored spots. Problems are reported one line each, never raised one at a time.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import NlosError
from .store import content_sha256, file_digest, read_manifest


def digest_problems(scene_dir: Path) -> list[tuple[Path, str]]:
    """(file, why) for every file of a finished scene whose digest does not match ``done.json``."""
    scene_dir = Path(scene_dir)
    try:
        rec = json.loads((scene_dir / "done.json").read_text())
        digests = dict(rec["digests"])
    except (OSError, ValueError, KeyError, TypeError):
        return [(scene_dir / "done.json", "missing or corrupted")]
    out = []
    for rel, dig in digests.items():
        p = scene_dir / rel
        if not p.exists():
            out.append((p, "missing"))
            continue
        try:
            same = file_digest(p) == dig
        except NlosError:  # a torn .npz cannot even be hashed array by array
            same = False
        if not same:
            out.append((p, "content does not match its digest (truncated, corrupted or edited)"))
    for sub in ("samples", "images"):
        for p in sorted((scene_dir / sub).glob("*.npz")) if (scene_dir / sub).is_dir() else []:
            if f"{sub}/{p.name}" not in digests:
                out.append((p, STRAY))
    return out


STRAY = "not part of the dataset (a stray file)"


def _shape_problems(scene_dir: Path) -> list[tuple[Path, str]]:
    out = []
    from .static import read_static, static_path

    try:
        st = read_static(scene_dir, "direct", "ambient")
        t, (h, w) = st["direct"].shape[0], st["ambient"].shape[:2]
    except NlosError as exc:
        return [(static_path(scene_dir), str(exc).split(": ", 1)[-1])]
    k = None
    try:
        k = len(json.loads((scene_dir / "spots.json").read_text())["spots"])
    except (OSError, ValueError, KeyError, TypeError):
        pass
    img = (h, w, 3)
    for p in sorted((scene_dir / "samples").glob("*.npz")):
        out += _check(p, {"transport_u": (t, None), "transport_v": (None, *img), "nlos_ambient": img,
                          "position": (2,)})
    for p in sorted((scene_dir / "images").glob("*.npz")) if (scene_dir / "images").exists() else []:
        out += _check(p, {"nlos_spots": (k, *img), "nlos_ambient": img, "position": (2,)})
    return out


def _check(path: Path, shapes: dict) -> list[tuple[Path, str]]:
    try:
        with np.load(path) as z:
            arrays = {k: z[k] for k in shapes}
    except KeyError as exc:
        return [(path, f"lacks array {exc}")]
    except Exception as exc:
        return [(path, f"unreadable ({type(exc).__name__})")]
    for name, want in shapes.items():
        got = arrays[name].shape
        if len(got) != len(want) or any(w is not None and g != w for g, w in zip(got, want)):
            return [(path, f"{name} has shape {got}, expected {tuple('*' if w is None else w for w in want)}")]
        if not np.all(np.isfinite(arrays[name])):
            return [(path, f"{name} holds NaN or infinity")]
    return []


def dataset_problems(data: Path, shapes: bool = True) -> tuple[list[tuple[Path, str]], int]:
    """Every problem of a dataset directory, and how many files were checked."""
    data = Path(data)
    if not (data / "manifest.json").exists():
        return [(data / "manifest.json", "missing (dataset incomplete; rerun nlos generate)")], 0
    try:
        manifest = read_manifest(data)
    except NlosError:
        return [(data / "manifest.json", "corrupted")], 0
    scenes = [s["id"] for split in manifest["splits"].values() for s in split]
    problems, digests, n = [], {}, 0
    for sid in scenes:
        d = data / "scenes" / sid
        bad = digest_problems(d)
        problems += bad
        if shapes:
            problems += [p for p in _shape_problems(d) if p[0] not in {b[0] for b in bad}]
        try:
            rec = json.loads((d / "done.json").read_text())["digests"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        n += len(rec)
        digests.update({f"scenes/{sid}/{k}": v for k, v in rec.items()})
    if not problems and content_sha256(digests) != manifest.get("content_sha256"):
        problems.append((data / "manifest.json", "content_sha256 does not match the scenes' digests"))
    return problems, n
