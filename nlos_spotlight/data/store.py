"""On-disk layout of ``nlos-dataset/2`` (see docs/dataset-format.md): paths, atomic writes, hashes.

Content hashes are taken over logical content (array names, dtypes, shapes and bytes; canonical
JSON), not file bytes, because zip containers carry timestamps.
"""

from __future__ import annotations

import hashlib
import json
import os
import zipfile
from pathlib import Path

import numpy as np

from ..errors import NlosError

FORMAT = "nlos-dataset/2"
"""Written by this version: /1 plus image samples (``images/``, ``spots.json``)."""
READABLE = ("nlos-dataset/1", FORMAT)
"""Formats this version reads (a /1 dataset is a /2 dataset without image samples)."""


def read_manifest(data_dir: str | Path) -> dict:
    """A dataset's ``manifest.json``, checked to hold its splits of scene records; NlosError naming
    the file when it is missing (the dataset is unfinished) or corrupted."""
    path = Path(data_dir) / "manifest.json"
    try:
        manifest = json.loads(path.read_text())
        [s["id"] for split in manifest["splits"].values() for s in split]
    except FileNotFoundError:
        raise NlosError(f"{data_dir}: no manifest.json (dataset unfinished: rerun nlos generate)") from None
    except (ValueError, KeyError, TypeError, AttributeError):
        raise NlosError(f"{path}: corrupted (not a dataset manifest)") from None
    return manifest


def scene_id(split: str, index: int) -> str:
    return f"{split}-{index:05d}"


def atomic_write_bytes(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def atomic_csv(path: Path, columns: list[str], rows: list[dict]) -> None:
    """A CSV of dict rows written atomically, its folder made (a killed job leaves the previous
    file whole)."""
    import csv
    import io

    text = io.StringIO()
    w = csv.DictWriter(text, columns)
    w.writeheader()
    w.writerows(rows)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, text.getvalue().encode())


def atomic_json(path: Path, obj) -> None:
    atomic_write_bytes(path, (json.dumps(obj, indent=1, sort_keys=True) + "\n").encode())


def atomic_npz(path: Path, **arrays) -> None:
    """Write a deflate-compressed .npz atomically. Lossless and read by plain ``np.load``; the NLOS
    images are mostly exact zeros (pixels that do not see the person), so on the demo preset an
    image sample shrinks 77 -> 12-57 kB and a full-transport one 690 -> 150-500 kB, for 1-5 ms."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.npz")
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, path)


def remove_stale_temporaries(root: Path) -> int:
    """Delete temporaries left by a killed writer; returns how many."""
    n = 0
    for p in root.rglob(".*.tmp*"):
        p.unlink(missing_ok=True)
        n += 1
    return n


def npz_digest(path: Path) -> str:
    """sha256 over the arrays of an .npz (sorted names, dtype, shape, bytes)."""
    h = hashlib.sha256()
    try:
        with np.load(path, allow_pickle=False) as z:
            for name in sorted(z.files):
                a = np.ascontiguousarray(z[name])
                h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
                h.update(a.tobytes())
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise NlosError(f"{path}: corrupted dataset file ({type(exc).__name__})") from None
    return h.hexdigest()


def file_digest(path: Path) -> str:
    if path.suffix == ".npz":
        return npz_digest(path)
    if path.suffix == ".json":
        try:
            obj = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise NlosError(f"{path}: corrupted dataset file (invalid JSON)") from None
        return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()
    return hashlib.sha256(path.read_bytes()).hexdigest()


def content_sha256(digests: dict[str, str]) -> str:
    """One hash over (relative path, digest) pairs in sorted order."""
    h = hashlib.sha256()
    for rel in sorted(digests):
        h.update(f"{rel} {digests[rel]}\n".encode())
    return h.hexdigest()


def f16_encode(a: np.ndarray, per_first_axis: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Radiance as float16 with a power-of-two float32 scale: ``a ~ half * scale``.

    NLOS radiance sits around 1e-6 W sr^-1 m^-2, deep in float16's subnormals, so it is scaled
    first: the largest |value| (per slice along axis 0 with ``per_first_axis``) maps into
    (2^14, 2^15], which leaves 2^-11 relative precision down to 2e-9 of it. Decoding
    (:func:`f16_decode`) is exact multiplication by a power of two.
    """
    a = np.asarray(a, np.float64)
    amax = np.abs(a).reshape(len(a), -1).max(axis=1) if per_first_axis else np.abs(a).max(keepdims=False)
    exp = np.where(amax > 0, np.ceil(np.log2(np.where(amax > 0, amax, 1.0))) - 15, 0.0)
    scale = np.exp2(exp).astype(np.float32)
    shape = (-1,) + (1,) * (a.ndim - 1) if per_first_axis else ()
    half = (a / scale.astype(np.float64).reshape(shape)).astype(np.float16)
    return half, scale


def f16_decode(z, name: str) -> np.ndarray:
    """Array ``name`` of an open .npz as float32: ``name * name_scale`` when it was stored by
    :func:`f16_encode`, else the array itself."""
    a = z[name]
    if f"{name}_scale" not in z.files:
        return np.asarray(a, np.float32)
    scale = np.asarray(z[f"{name}_scale"], np.float32)
    return a.astype(np.float32) * scale.reshape(scale.shape + (1,) * (a.ndim - scale.ndim))
