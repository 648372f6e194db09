"""On-disk layout of ``nlos-dataset/1`` (see docs/dataset-format.md): paths, atomic writes, hashes.

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

FORMAT = "nlos-dataset/1"


def scene_id(split: str, index: int) -> str:
    return f"{split}-{index:05d}"


def atomic_write_bytes(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def atomic_json(path: Path, obj) -> None:
    atomic_write_bytes(path, (json.dumps(obj, indent=1, sort_keys=True) + "\n").encode())


def atomic_npz(path: Path, **arrays) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.npz")
    np.savez(tmp, **arrays)
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
