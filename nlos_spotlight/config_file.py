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
    fields (or those fields by their own names, :func:`nest`), dict fields are merged."""
    values = nest(type(cfg), values, where, prefix)
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


def apply_assignments(cfg, items: list[str], where: str = "--set"):
    """``FIELD=VALUE`` strings (each value read as YAML, e.g. ``person_samples=4000``) applied with
    :func:`apply_fields`: the benchmarks' ``--set``."""
    import yaml

    values = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise NlosError(f"{where}: expected FIELD=VALUE, got {item!r}")
        try:
            values[key] = yaml.safe_load(value)
        except yaml.YAMLError:
            raise NlosError(f"{where}: {key}: unreadable value {value!r}") from None
    return apply_fields(cfg, values, where)


def as_block(value, default, where: str):
    """A config's block as its dataclass: ``value`` itself, or a mapping of its fields over
    ``default`` (as a record writes them); anything else, or an unknown field, a one-line
    ``NlosError`` naming ``where`` ('fit: render')."""
    if isinstance(value, dict):
        try:
            return dataclasses.replace(default, **value)
        except (TypeError, ValueError) as exc:
            raise NlosError(f"{where}: {exc}") from None
    if not isinstance(value, type(default)):
        raise NlosError(f"{where} must be a mapping of {type(default).__name__} fields, got {value!r}")
    return value


def blocks(cls) -> dict[str, type]:
    """The blocks of dataclass ``cls`` whose fields may also be given by their own names: those it
    lists in ``FLAT_BLOCKS`` (the sampling blocks, ``render`` and ``shadow``; not a training
    config's ``net`` or ``ien``), field name -> its dataclass, read from each field's default."""
    names = getattr(cls, "FLAT_BLOCKS", ())
    out = {}
    for f in dataclasses.fields(cls):
        default = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
        if f.name in names and dataclasses.is_dataclass(default):
            out[f.name] = type(default)
    return out


def nest(cls, values: dict, where: str = "config", prefix: str = "") -> dict:
    """``values`` with every key that names a field of one of ``cls``'s :func:`blocks` moved into
    that block's mapping: a record written before the blocks (flat), or the command line's flags,
    read as the nested config. A block given as its dataclass becomes its mapping; a block that is
    neither, or a field given both ways, is refused in one line."""
    own, kinds = {f.name for f in dataclasses.fields(cls)}, blocks(cls)
    owner = {name: block for block, kind in kinds.items() for name in (f.name for f in dataclasses.fields(kind))
             if name not in own}
    out = {}
    for k, v in values.items():
        if k in owner:
            continue
        if k in kinds:
            if dataclasses.is_dataclass(v) and not isinstance(v, type):
                v = dataclasses.asdict(v)
            if not isinstance(v, dict):  # before a flag's block can replace it unseen
                raise NlosError(f"{where}: {prefix}{k} must be a mapping of its fields, got {v!r}")
            v = dict(v)
        out[k] = v
    for k, v in values.items():
        if k not in owner:
            continue
        block = out.setdefault(owner[k], {})
        if not isinstance(block, dict):
            raise NlosError(f"{where}: {prefix}{owner[k]} must be a mapping of its fields, got {block!r}")
        if k in block:
            raise NlosError(f"{where}: {prefix}{k} given twice (on its own and under {prefix}{owner[k]})")
        block[k] = v
    return out


def merged(cls, a: dict, b: dict) -> dict:
    """Nested settings ``a`` with ``b``'s on top, block by block (the flags over a config file's)."""
    out = {**a, **b}
    for k in blocks(cls):
        if isinstance(a.get(k), dict) and isinstance(b.get(k), dict):
            out[k] = {**a[k], **b[k]}
    return out


def with_fields(cfg, **changes):
    """``dataclasses.replace`` taking a block's fields by their own names too (``with_fields(fit,
    shadow_samples=0)`` for ``fit.shadow.shadow_samples``), the rest of each block kept."""
    changes = nest(type(cfg), changes, "with_fields")
    for k in blocks(type(cfg)):
        if isinstance(changes.get(k), dict):
            changes[k] = dataclasses.replace(getattr(cfg, k), **changes[k])
    return dataclasses.replace(cfg, **changes)


def flatten(cls, values: dict) -> dict:
    """The inverse of :func:`nest`: ``cls``'s blocks' fields lifted to the top (their names are
    unique), as settings are compared (a resumed fit, reused people, a dataset's config)."""
    kinds = blocks(cls)
    out = {k: v for k, v in values.items() if not (k in kinds and isinstance(v, dict))}
    for k in kinds:
        if isinstance(values.get(k), dict):
            out.update(values[k])
    return out


__all__ = ["apply_assignments", "apply_fields", "as_block", "blocks", "flatten", "load_config_file", "merged", "nest", "with_fields"]
