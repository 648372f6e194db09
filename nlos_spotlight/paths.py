"""Checks of the paths a command reads and writes, before any work: one line naming the path.

A command that will write ``--out x.npy`` after a minute of rendering should say at once that
``x.npy`` is a directory, lies under a regular file, or cannot be created, not fail at the end
with a Python class name (and leave a temporary file behind).
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import NlosError


def _writable_parent(path: Path, flag: str) -> None:
    """The nearest existing ancestor of ``path`` is a directory we may create entries in."""
    parent = path.parent
    while not parent.exists():
        if parent == parent.parent:
            break
        parent = parent.parent
    if not parent.is_dir():
        raise NlosError(f"{flag}: {path} lies under {parent}, which is a file, not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise NlosError(f"{flag}: cannot create {path} (no permission to write in {parent})")
    _probe(parent, flag, path)


def _probe(directory: Path, flag: str, path: Path) -> None:
    """Create and remove an entry in ``directory``: permission bits say yes to root even where the
    file system says no (``/proc``, a read-only mount)."""
    import tempfile

    try:
        os.rmdir(tempfile.mkdtemp(prefix=".nlos-probe-", dir=directory))
    except OSError as exc:
        raise NlosError(f"{flag}: cannot create {path} ({exc.strerror or type(exc).__name__} in {directory})") from None


def output_file(path: str | Path, flag: str) -> Path:
    """A file to be written: not a directory, its directory creatable and writable."""
    path = Path(path)
    if path.is_dir():
        raise NlosError(f"{flag}: {path} is a directory; give a file name")
    if path.exists() and not os.access(path, os.W_OK):
        raise NlosError(f"{flag}: cannot overwrite {path} (no permission)")
    _writable_parent(path, flag)
    return path


def output_dir(path: str | Path, flag: str) -> Path:
    """A directory to be written into: not a file, creatable and writable."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise NlosError(f"{flag}: {path} is a file, not a directory")
    if path.is_dir():
        if not os.access(path, os.W_OK | os.X_OK):
            raise NlosError(f"{flag}: cannot write in {path} (no permission)")
        _probe(path, flag, path)
        return path
    _writable_parent(path, flag)
    return path


def input_dir(path: str | Path, flag: str, what: str = "directory") -> Path:
    """An existing directory to read."""
    path = Path(path)
    if not path.exists():
        raise NlosError(f"{flag}: {path} does not exist")
    if not path.is_dir():
        raise NlosError(f"{flag}: {path} is a file, not a {what}")
    return path
