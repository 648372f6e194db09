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


MAX_COORDINATE_M = 1e6
"""Largest coordinate a flag may give, m (a room is tens of meters)."""


__all__ = ["parse_numbers"]
