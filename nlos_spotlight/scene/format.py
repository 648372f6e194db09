"""In-memory form of the ``nlos-scene/1`` directory format (DESIGN section 3).

Everything is validated on construction from JSON so that downstream code can
trust finite numbers, albedos in [0, 1] and non-empty meshes. Meshes are held
as numpy arrays in world coordinates (meters, z up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import NlosError

FORMAT = "nlos-scene/1"
TOP_KEYS = {"format", "units", "shapes", "materials", "camera", "projector",
            "ambient", "hidden_region", "human", "sensor"}
REQUIRED_TOP = ("format", "shapes", "materials", "camera", "projector")


def _check_keys(d: dict, allowed: set[str], where: str, required: tuple[str, ...] = ()) -> None:
    if not isinstance(d, dict):
        raise NlosError(f"{where}: expected a JSON object, got {type(d).__name__}")
    for k in d:
        if k not in allowed:
            raise NlosError(f"{where}: unknown key '{k}' (allowed: {', '.join(sorted(allowed))})")
    for k in required:
        if k not in d:
            raise NlosError(f"{where}: missing key '{k}'")


def _vec(value, where: str, n: int = 3, lo: float | None = None, hi: float | None = None) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise NlosError(f"{where}: expected {n} numbers, got {value!r}") from None
    if arr.shape != (n,):
        raise NlosError(f"{where}: expected {n} numbers, got {value!r}")
    if not np.all(np.isfinite(arr)):
        raise NlosError(f"{where}: non-finite number in {value!r}")
    if lo is not None and np.any(arr < lo) or hi is not None and np.any(arr > hi):
        raise NlosError(f"{where}: values {value!r} outside [{lo}, {hi}]")
    return arr


def _num(value, where: str, lo: float | None = None, hi: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise NlosError(f"{where}: expected a number, got {value!r}")
    if not math.isfinite(value):
        raise NlosError(f"{where}: non-finite number {value!r}")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise NlosError(f"{where}: {value!r} outside [{lo}, {hi}]")
    return float(value)


@dataclass
class Material:
    """Two-sided diffuse + GGX material (DESIGN section 4)."""

    diffuse: np.ndarray
    """(3,) Lambertian albedo in [0, 1]."""
    specular: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """(3,) GGX lobe weight in [0, 1]; Fresnel is 1."""
    roughness: float = 0.3
    """GGX alpha (not squared), in (0, 1]."""
    emission: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """(3,) emitted radiance, W sr^-1 m^-2."""

    @classmethod
    def from_dict(cls, d: dict, where: str) -> "Material":
        _check_keys(d, {"diffuse", "specular", "roughness", "emission"}, where, ("diffuse",))
        m = cls(diffuse=_vec(d["diffuse"], f"{where}.diffuse", lo=0.0, hi=1.0))
        if "specular" in d:
            m.specular = _vec(d["specular"], f"{where}.specular", lo=0.0, hi=1.0)
        if "roughness" in d:
            m.roughness = _num(d["roughness"], f"{where}.roughness", lo=1e-3, hi=1.0)
        if "emission" in d:
            m.emission = _vec(d["emission"], f"{where}.emission", lo=0.0)
        return m

    def to_dict(self) -> dict:
        d = {"diffuse": self.diffuse.tolist()}
        if np.any(self.specular > 0):
            d["specular"] = self.specular.tolist()
            d["roughness"] = self.roughness
        if np.any(self.emission > 0):
            d["emission"] = self.emission.tolist()
        return d


@dataclass
class Camera:
    """Pinhole camera; ``fov_deg`` is the horizontal field of view."""

    position: np.ndarray
    """(3,) center of projection, m."""
    look_at: np.ndarray
    """(3,) a point on the optical axis, m."""
    up: np.ndarray
    """(3,) up direction (need not be orthogonal to the axis)."""
    fov_deg: float
    """Horizontal field of view, degrees."""
    width: int
    """Image width, pixels."""
    height: int
    """Image height, pixels."""

    @classmethod
    def from_dict(cls, d: dict) -> "Camera":
        keys = ("position", "look_at", "up", "fov_deg", "width", "height")
        _check_keys(d, set(keys), "camera", keys)
        cam = cls(_vec(d["position"], "camera.position"), _vec(d["look_at"], "camera.look_at"),
                  _vec(d["up"], "camera.up"), _num(d["fov_deg"], "camera.fov_deg", 0.1, 179.0),
                  _int(d["width"], "camera.width"), _int(d["height"], "camera.height"))
        fwd = cam.look_at - cam.position
        if np.linalg.norm(fwd) < 1e-9:
            raise NlosError("camera: look_at equals position")
        if np.linalg.norm(np.cross(fwd, cam.up)) < 1e-9 * np.linalg.norm(fwd) * max(np.linalg.norm(cam.up), 1e-30):
            raise NlosError("camera: up is parallel to the viewing direction (or zero)")
        return cam

    def to_dict(self) -> dict:
        return {"position": self.position.tolist(), "look_at": self.look_at.tolist(), "up": self.up.tolist(),
                "fov_deg": self.fov_deg, "width": self.width, "height": self.height}


def _int(value, where: str, lo: int = 1, hi: int = 8192) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise NlosError(f"{where}: expected an integer, got {value!r}")
    if not lo <= value <= hi:
        raise NlosError(f"{where}: {value} outside [{lo}, {hi}]")
    return value


@dataclass
class Projector:
    """Point spot emitter (Mitsuba 3 ``spot``): I(theta) = intensity * f(theta)."""

    position: np.ndarray
    """(3,) emitter position, m."""
    intensity: np.ndarray
    """(3,) radiant intensity on the axis, W sr^-1 per channel."""
    beam_width_deg: float
    """Half-angle of full intensity, degrees."""
    cutoff_deg: float
    """Half-angle beyond which no light leaves, degrees."""

    @classmethod
    def from_dict(cls, d: dict) -> "Projector":
        keys = ("position", "intensity", "beam_width_deg", "cutoff_deg")
        _check_keys(d, set(keys), "projector", keys)
        p = cls(_vec(d["position"], "projector.position"), _vec(d["intensity"], "projector.intensity", lo=0.0),
                _num(d["beam_width_deg"], "projector.beam_width_deg", 0.0, 89.0),
                _num(d["cutoff_deg"], "projector.cutoff_deg", 0.01, 89.0))
        if p.cutoff_deg <= p.beam_width_deg:
            raise NlosError("projector: cutoff_deg must exceed beam_width_deg")
        return p

    def to_dict(self) -> dict:
        return {"position": self.position.tolist(), "intensity": self.intensity.tolist(),
                "beam_width_deg": self.beam_width_deg, "cutoff_deg": self.cutoff_deg}


@dataclass
class Ambient:
    """Uniform ambient light on the LOS surfaces and in the hidden region."""

    radiance: np.ndarray
    """(3,) ambient radiance reaching the LOS surfaces."""
    hidden_radiance: np.ndarray
    """(3,) radiance of the light field in the hidden region (lights the person, and is what it hides)."""

    @classmethod
    def from_dict(cls, d: dict) -> "Ambient":
        _check_keys(d, {"radiance", "hidden_radiance"}, "ambient")
        z = [0.0, 0.0, 0.0]
        return cls(_vec(d.get("radiance", z), "ambient.radiance", lo=0.0),
                   _vec(d.get("hidden_radiance", z), "ambient.hidden_radiance", lo=0.0))

    def to_dict(self) -> dict:
        return {"radiance": self.radiance.tolist(), "hidden_radiance": self.hidden_radiance.tolist()}


@dataclass
class HiddenRegion:
    """Axis-aligned floor rectangle where the person may stand."""

    min: np.ndarray
    """(2,) x, y lower corner, m."""
    max: np.ndarray
    """(2,) x, y upper corner, m."""
    floor_z: float = 0.0
    """Height of the floor, m."""

    @classmethod
    def from_dict(cls, d: dict) -> "HiddenRegion":
        _check_keys(d, {"min", "max", "floor_z"}, "hidden_region", ("min", "max"))
        h = cls(_vec(d["min"], "hidden_region.min", 2), _vec(d["max"], "hidden_region.max", 2),
                _num(d.get("floor_z", 0.0), "hidden_region.floor_z"))
        if np.any(h.max <= h.min):
            raise NlosError("hidden_region: max must exceed min in x and y")
        return h

    def to_dict(self) -> dict:
        return {"min": self.min.tolist(), "max": self.max.tolist(), "floor_z": self.floor_z}


@dataclass
class TriMesh:
    """A triangle mesh with optional colors (numpy, world coordinates)."""

    vertices: np.ndarray
    """(V, 3) float64 positions, m."""
    faces: np.ndarray
    """(F, 3) int64 vertex indices."""
    vertex_colors: np.ndarray | None = None
    """(V, 3) float64 in [0, 1], multiplies the material's diffuse; or None."""
    face_colors: np.ndarray | None = None
    """(F, 3) float64 in [0, 1], multiplies the material's diffuse; or None."""

    def face_areas(self) -> np.ndarray:
        a, b, c = (self.vertices[self.faces[:, i]] for i in range(3))
        return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)

    def face_normals(self) -> np.ndarray:
        a, b, c = (self.vertices[self.faces[:, i]] for i in range(3))
        n = np.cross(b - a, c - a)
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)

    def centroids(self) -> np.ndarray:
        return self.vertices[self.faces].mean(axis=1)


@dataclass
class Shape:
    """One static mesh with its material name."""

    mesh_file: str
    """File name relative to the scene directory."""
    material: str
    """Key into ``Scene.materials``."""
    mesh: TriMesh
    """The geometry."""


@dataclass
class Human:
    """The hidden person: a two-sided Lambertian mesh."""

    mesh_file: str
    """File name relative to the scene directory."""
    albedo: np.ndarray
    """(3,) Lambertian albedo in [0, 1]."""
    mesh: TriMesh
    """The posed body in world coordinates."""


@dataclass
class Scene:
    """A validated ``nlos-scene/1`` scene."""

    shapes: list[Shape]
    """Static geometry; faces are numbered by concatenating shapes in order."""
    materials: dict[str, Material]
    """Named materials."""
    camera: Camera
    """The RGB camera."""
    projector: Projector
    """The spot projector."""
    ambient: Ambient | None = None
    """Ambient light, or None for none."""
    hidden_region: HiddenRegion | None = None
    """Where the person may stand, or None."""
    human: Human | None = None
    """The person, or None."""
    sensor: dict | None = None
    """Camera sensor overrides (see ``render.sensor.SensorConfig``)."""

    @property
    def num_faces(self) -> int:
        return sum(len(s.mesh.faces) for s in self.shapes)

    def static_mesh(self) -> tuple[TriMesh, np.ndarray]:
        """Concatenate all shapes; returns the mesh and the (F,) shape index per face."""
        verts, faces, vcol, fcol, owner = [], [], [], [], []
        offset = 0
        for i, s in enumerate(self.shapes):
            m = s.mesh
            verts.append(m.vertices)
            faces.append(m.faces + offset)
            offset += len(m.vertices)
            vcol.append(m.vertex_colors if m.vertex_colors is not None else np.ones_like(m.vertices))
            fcol.append(m.face_colors if m.face_colors is not None else np.ones((len(m.faces), 3)))
            owner.append(np.full(len(m.faces), i))
        mesh = TriMesh(np.concatenate(verts), np.concatenate(faces), np.concatenate(vcol), np.concatenate(fcol))
        return mesh, np.concatenate(owner)
