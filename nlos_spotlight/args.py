"""Command-line values read into arrays, with the one-line errors of ``errors.NlosError``."""

from __future__ import annotations

import numpy as np

from .errors import NlosError


def parse_numbers(text: str, fields: str, flag: str) -> np.ndarray:
    """``"1,2.5,-3"`` -> float array, exactly as many finite numbers as ``fields`` names
    (``"X,Y,Z"``); otherwise an error naming ``flag`` and the expected form."""
    names = fields.split(",")
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise NlosError(f"{flag}: expected {fields}, got {text!r}") from None
    if len(vals) != len(names) or not np.all(np.isfinite(vals)):
        count = {2: "two", 3: "three", 4: "four"}.get(len(names), str(len(names)))
        raise NlosError(f"{flag}: expected {count} finite numbers {fields}, got {text!r}")
    if max(abs(v) for v in vals) > MAX_COORDINATE_M:  # later arithmetic would overflow with warnings
        raise NlosError(f"{flag}: {text!r} lies beyond {MAX_COORDINATE_M:.0e} m; give meters in the room's frame")
    return np.array(vals)


def room_model_parser(description: str, people: int):
    """An ``argparse`` parser of the studies that read a finished room model's held-out people:
    ``--model`` (the ``nlos fit --out`` folder), ``--people`` (default ``people``), ``--out`` (a file)."""
    import argparse
    from pathlib import Path

    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--model", type=Path, required=True, help="a finished room model (nlos fit --out)")
    ap.add_argument("--people", type=int, default=people, help="its first held-out people")
    ap.add_argument("--out", type=Path, default=None, help="where to write the result")
    return ap


MAX_COORDINATE_M = 1e6
"""Largest coordinate a flag may give, m (a room is tens of meters)."""


__all__ = ["parse_numbers", "room_model_parser"]
