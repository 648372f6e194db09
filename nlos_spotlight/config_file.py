"""Dataset and training configs read the same way: a preset name, or a YAML file of fields on top
of a preset (``base: NAME``), every key and type checked into one-line errors."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from .errors import NlosError


def load_config_file(spec: str, presets: dict, default_base: str = "tiny"):
    """``(config, path)``: a copy of preset ``spec``, or the YAML file ``spec`` applied to its
    ``base`` preset with ``name`` = the file's stem (path None for a preset)."""
    if spec in presets:
        return dataclasses.replace(presets[spec]), None
    path = Path(spec)
    if not path.is_file():
        raise NlosError(f"config: '{spec}' is neither a preset ({', '.join(presets)}) nor a file")
    d = _yaml_mapping(path)  # an alias repeats a subtree: a few hundred bytes expand to billions of nodes
    base = d.pop("base", default_base)
    if not isinstance(base, str) or base not in presets:
        raise NlosError(f"{path}: base '{base}' is not a preset ({', '.join(presets)})")
    cfg = apply_fields(dataclasses.replace(presets[base], name=path.stem), d, str(path))
    return cfg, path


ROOM_KEYS = ("room", "camera_position", "camera_look_at", "projector_position", "hidden_region", "up", "fit")
"""Keys of a room config (``nlos fit --config``): the room, its setup, and ``fit`` settings."""


def load_room_config(path: str) -> dict:
    """A room config file (``nlos fit --config``): the room (a path relative to the file), the
    camera, projector, hidden region and up axis as ``nlos fit``'s flags take them, and ``fit``, a
    mapping of ``FitConfig`` fields. Flag-style values come back as the flags' strings."""
    p = Path(path)
    if not p.is_file():
        raise NlosError(f"--config: {path} is not a file")
    d = _yaml_mapping(p)
    unknown = sorted(set(d) - set(ROOM_KEYS))
    if unknown:
        raise NlosError(f"{p}: unknown key '{unknown[0]}' (a room config holds {', '.join(ROOM_KEYS)})")
    out = {}
    if "room" in d:
        if not isinstance(d["room"], str) or not d["room"]:
            raise NlosError(f"{p}: room must be a path (relative to the config file)")
        out["room"] = str((p.parent / d["room"]).resolve()) if not Path(d["room"]).is_absolute() else d["room"]
    sizes = {"camera_position": 3, "camera_look_at": 3, "projector_position": 3, "hidden_region": 4}
    for k, n in sizes.items():
        if k in d:
            v = d[k]
            if not isinstance(v, list) or len(v) != n or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                                 for x in v):
                raise NlosError(f"{p}: {k} must be a list of {n} numbers, got {v!r}")
            out[k] = ",".join(str(int(x)) if float(x).is_integer() else repr(float(x)) for x in v)  # as typed
    if "up" in d:
        out["up"] = str(d["up"])
    fit = d.get("fit", {})
    if not isinstance(fit, dict):
        raise NlosError(f"{p}: fit must be a mapping of fit settings, got {fit!r}")
    out["fit"] = fit
    return out


def _yaml_mapping(path: Path) -> dict:
    """A YAML file's top-level mapping, aliases refused (see :func:`load_config_file`)."""
    import yaml

    try:
        text = path.read_text()
        if any(isinstance(e, yaml.AliasEvent) for e in yaml.parse(text, Loader=yaml.SafeLoader)):
            raise NlosError(f"{path}: YAML aliases (*name) are not allowed in a config file; write the values out")
        d = yaml.safe_load(text) or {}
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise NlosError(f"{path}: invalid YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(d, dict):
        raise NlosError(f"{path}: expected a mapping of config fields")
    return d


def apply_fields(cfg, values: dict, where: str, prefix: str = ""):
    """A copy of dataclass ``cfg`` with ``values`` set, each checked against the field's current
    type (an int is a float; a bool is only a bool); nested configs take a mapping of their own
    fields, dict fields are merged."""
    fields = {f.name for f in dataclasses.fields(cfg)}
    changes = {}
    for k, v in values.items():
        key = f"{prefix}{k}"
        if not isinstance(k, str) or k not in fields:
            raise NlosError(f"{where}: unknown key '{key}'")
        cur = getattr(cfg, k)
        if dataclasses.is_dataclass(cur):
            if not isinstance(v, dict):
                raise NlosError(f"{where}: {key} must be a mapping of its fields, got {v!r}")
            changes[k] = apply_fields(cur, v, where, key + ".")
            continue
        if isinstance(cur, dict):
            if not isinstance(v, dict):
                raise NlosError(f"{where}: {key} must be a mapping, got {v!r}")
            changes[k] = {**cur, **v}
            continue
        expected = type(cur)
        if expected is float and isinstance(v, int) and not isinstance(v, bool):
            v = float(v)
        if expected in (list, tuple) and isinstance(v, (list, tuple)):
            v = expected(v)
        if cur is not None and (not isinstance(v, expected) or isinstance(v, bool) != (expected is bool)):
            raise NlosError(f"{where}: {key} must be {expected.__name__}, got {v!r}")
        changes[k] = v
    try:
        return dataclasses.replace(cfg, **changes)
    except (TypeError, ValueError) as exc:
        raise NlosError(f"{where}: {exc}") from None


__all__ = ["apply_fields", "load_config_file"]
