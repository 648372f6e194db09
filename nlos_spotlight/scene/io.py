"""Read and write ``nlos-scene/1`` directories."""

from __future__ import annotations

import json
from pathlib import Path


from ..errors import NlosError
from .format import (FORMAT, REQUIRED_TOP, TOP_KEYS, Ambient, Camera, HiddenRegion, Human, Material,
                     Projector, Scene, Shape, _check_keys, _vec)
from .meshio import load_mesh, save_mesh


def load_scene(directory: str | Path, human_mesh: str | Path | None = None) -> Scene:
    """Load and validate a scene directory; ``human_mesh`` overrides the scene's person mesh."""
    directory = Path(directory)
    path = directory / "scene.json"
    if not directory.is_dir():
        raise NlosError(f"scene directory not found: {directory}")
    if not path.is_file():
        raise NlosError(f"{directory}: no scene.json")
    try:
        d = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise NlosError(f"{path}: invalid JSON ({exc})") from None
    scene = scene_from_dict(d, directory, human_mesh)
    return scene


def scene_from_dict(d: dict, directory: Path, human_mesh: str | Path | None = None) -> Scene:
    _check_keys(d, TOP_KEYS, "scene.json", REQUIRED_TOP)
    if d["format"] != FORMAT:
        raise NlosError(f"scene.json: format is {d['format']!r}, this reader supports {FORMAT!r}")
    if d.get("units", "meters") != "meters":
        raise NlosError(f"scene.json: units {d['units']!r} unsupported (use 'meters')")
    if not isinstance(d["materials"], dict):
        raise NlosError(f"materials: expected a JSON object of named materials, got {type(d['materials']).__name__}")
    materials = {name: Material.from_dict(m, f"materials.{name}") for name, m in d["materials"].items()}
    if not isinstance(d["shapes"], list) or not d["shapes"]:
        raise NlosError("shapes: expected a non-empty list")
    shapes = []
    for i, s in enumerate(d["shapes"]):
        where = f"shapes[{i}]"
        _check_keys(s, {"mesh", "material"}, where, ("mesh", "material"))
        inside(directory, s["mesh"], f"{where}.mesh")
        if _name(s["material"], f"{where}.material") not in materials:
            raise NlosError(f"{where}: unknown material '{s['material']}'")
        shapes.append(Shape(s["mesh"], s["material"], load_mesh(directory / s["mesh"], f"{where} ({s['mesh']})")))
    scene = Scene(shapes, materials, Camera.from_dict(d["camera"]), Projector.from_dict(d["projector"]))
    if "ambient" in d:
        scene.ambient = Ambient.from_dict(d["ambient"])
    if "hidden_region" in d:
        scene.hidden_region = HiddenRegion.from_dict(d["hidden_region"])
    if "human" in d or human_mesh is not None:
        h = d.get("human", {})
        _check_keys(h, {"mesh", "albedo"}, "human")
        albedo = _vec(h.get("albedo", [0.5, 0.5, 0.5]), "human.albedo", lo=0.0, hi=1.0)
        if human_mesh is not None:
            mesh_file, mesh = Path(human_mesh).name, load_mesh(human_mesh, "--human")
        elif "mesh" in h:
            inside(directory, h["mesh"], "human.mesh")
            mesh_file, mesh = h["mesh"], load_mesh(directory / h["mesh"], f"human ({h['mesh']})")
        else:
            raise NlosError("human: missing key 'mesh'")
        scene.human = Human(mesh_file, albedo, mesh)
    if "sensor" in d:
        from ..render.sensor import SensorConfig

        try:
            SensorConfig.from_dict(d["sensor"])
        except (ValueError, TypeError) as exc:
            raise NlosError(f"sensor: {str(exc).splitlines()[0]}") from None
        scene.sensor = dict(d["sensor"])
    return scene


def _name(value, where: str) -> str:
    """A file or material name: a non-empty string."""
    if not isinstance(value, str) or not value:
        raise NlosError(f"{where}: expected a non-empty name, got {value!r}")
    return value


def inside(directory: Path, name, where: str) -> Path:
    """``directory / name`` for a mesh name that stays inside ``directory``: a relative name that does
    not leave it, symlinks resolved (a scene is a shared file: reading or rewriting it must never
    touch a file elsewhere)."""
    from pathlib import PurePath

    _name(name, where)
    if PurePath(name).is_absolute() or "\\" in name or ":" in PurePath(name).parts[0]:
        raise NlosError(f"{where}: {name!r} is an absolute path; name a file inside the scene directory")
    root = Path(directory).resolve()
    target = (root / name).resolve()
    if target == root or root not in target.parents:
        raise NlosError(f"{where}: {name!r} leaves the scene directory; name a file inside it")
    return target


def scene_to_dict(scene: Scene) -> dict:
    d = {"format": FORMAT, "units": "meters",
         "shapes": [{"mesh": s.mesh_file, "material": s.material} for s in scene.shapes],
         "materials": {k: m.to_dict() for k, m in scene.materials.items()},
         "camera": scene.camera.to_dict(), "projector": scene.projector.to_dict()}
    if scene.ambient is not None:
        d["ambient"] = scene.ambient.to_dict()
    if scene.hidden_region is not None:
        d["hidden_region"] = scene.hidden_region.to_dict()
    if scene.human is not None:
        d["human"] = {"mesh": scene.human.mesh_file, "albedo": scene.human.albedo.tolist()}
    if scene.sensor is not None:
        d["sensor"] = scene.sensor
    return d


def save_scene(scene: Scene, directory: str | Path) -> Path:
    """Write ``scene.json`` and every mesh; the JSON goes last and atomically."""
    directory = Path(directory)
    names = [(s.mesh, s.mesh_file, f"shapes[{i}].mesh") for i, s in enumerate(scene.shapes)]
    if scene.human is not None:
        names.append((scene.human.mesh, scene.human.mesh_file, "human.mesh"))
    paths = [(mesh, inside(directory, name, where)) for mesh, name, where in names]  # all checked first
    directory.mkdir(parents=True, exist_ok=True)
    for mesh, path in paths:
        path.parent.mkdir(parents=True, exist_ok=True)
        save_mesh(mesh, path)
    tmp = directory / "scene.json.tmp"
    tmp.write_text(json.dumps(scene_to_dict(scene), indent=1))
    tmp.replace(directory / "scene.json")
    return directory / "scene.json"


