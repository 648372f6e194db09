"""Material classes of real rooms, a per-scene palette, and vertex-color textures.

Every piece of the world takes its material from a *class* that matches its shape, the way real
rooms do (DESIGN section 7: the IEN can only learn what correlates): painted walls are matte,
cabinets are wood, a refrigerator is glossy metal, mirrors and glass are nearly pure specular,
whiteboards are bright and glossy, screens and lamp shades emit. :data:`CLASSES` holds each
class's parameter ranges (the renderer's two-sided diffuse + GGX material, DESIGN section 4) and
:data:`KIND_CLASSES` which classes a kind of object may use; the tests read both.

Textures are per-vertex colors that multiply the material's diffuse albedo (DESIGN section 3):
wood grain and floor planks, wallpaper stripes, tiles, posters, book spines.
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass, field

import numpy as np

from ..scene.format import Material
from .geometry import Texture


@dataclass(frozen=True)
class MaterialClass:
    """Ranges of one material class (each sampled uniformly)."""

    diffuse: tuple[float, float]
    """Range of the diffuse albedo's brightness (max channel for colored classes)."""
    specular: tuple[float, float] = (0.0, 0.0)
    """Range of the GGX lobe weight (gray)."""
    roughness: tuple[float, float] = (0.3, 0.3)
    """Range of the GGX alpha."""
    emission: tuple[float, float] = (0.0, 0.0)
    """Range of the emitted radiance's brightness (max channel), W sr^-1 m^-2."""
    hue: str = "gray"
    """Color family of the diffuse albedo: gray, tint (slightly off-white), brown, green, terracotta, any."""


CLASSES: dict[str, MaterialClass] = {
    "paint": MaterialClass((0.5, 0.85), hue="tint"),
    "ceiling": MaterialClass((0.75, 0.9), hue="tint"),
    "trim": MaterialClass((0.6, 0.85), (0.03, 0.08), (0.2, 0.4), hue="tint"),
    "wood": MaterialClass((0.3, 0.55), (0.02, 0.06), (0.3, 0.5), hue="brown"),
    "floor_wood": MaterialClass((0.25, 0.5), (0.03, 0.08), (0.2, 0.4), hue="brown"),
    "carpet": MaterialClass((0.12, 0.4), hue="any"),
    "tile": MaterialClass((0.4, 0.7), (0.05, 0.12), (0.1, 0.25), hue="tint"),
    "steel": MaterialClass((0.03, 0.08), (0.5, 0.8), (0.1, 0.3)),
    "glass": MaterialClass((0.01, 0.05), (0.3, 0.9), (0.02, 0.08)),
    "window": MaterialClass((0.01, 0.04), (0.5, 0.8), (0.02, 0.05)),
    "whiteboard": MaterialClass((0.75, 0.85), (0.05, 0.15), (0.05, 0.15)),
    "screen": MaterialClass((0.01, 0.03), (0.03, 0.06), (0.05, 0.1), (0.1, 0.6), hue="gray"),
    "lampshade": MaterialClass((0.6, 0.8), emission=(0.5, 2.5), hue="tint"),
    "plastic_black": MaterialClass((0.03, 0.06), (0.03, 0.08), (0.2, 0.4)),
    "aluminum": MaterialClass((0.2, 0.35), (0.3, 0.5), (0.25, 0.4)),
    "enamel": MaterialClass((0.7, 0.85), (0.05, 0.12), (0.2, 0.35), hue="tint"),
    "painted_metal": MaterialClass((0.3, 0.7), (0.08, 0.2), (0.3, 0.5), hue="tint"),
    "laminate": MaterialClass((0.5, 0.8), (0.03, 0.08), (0.2, 0.4), hue="tint"),
    "stone": MaterialClass((0.2, 0.6), (0.08, 0.2), (0.08, 0.2), hue="tint"),
    "fabric": MaterialClass((0.05, 0.45), hue="any"),
    "leaves": MaterialClass((0.12, 0.3), hue="green"),
    "terracotta": MaterialClass((0.35, 0.55), hue="terracotta"),
    "ceramic": MaterialClass((0.6, 0.85), (0.1, 0.2), (0.1, 0.2), hue="tint"),
    "paper": MaterialClass((0.7, 0.85), hue="tint"),
    "concrete": MaterialClass((0.35, 0.55), hue="tint"),
    "cardboard": MaterialClass((0.35, 0.5), hue="brown"),
    "diffuser": MaterialClass((0.8, 0.9), (0.02, 0.05), (0.2, 0.3), hue="tint"),
    "sign": MaterialClass((0.1, 0.3), (0.03, 0.06), (0.1, 0.2), (0.3, 1.0), hue="green"),
}
"""Material classes and their parameter ranges."""

KIND_CLASSES: dict[str, tuple[str, ...]] = {
    "wall": ("paint",), "floor": ("floor_wood", "carpet", "tile"), "ceiling": ("ceiling",),
    "baseboard": ("trim", "wood"), "partition": ("paint",),
    "door": ("wood", "trim"), "door_frame": ("trim", "wood"),
    "cabinet": ("wood",), "shelf": ("wood",), "desk": ("wood", "laminate"), "table": ("wood",),
    "countertop": ("stone", "laminate"), "bench": ("wood",),
    "fridge": ("steel",), "handle": ("steel", "aluminum"),
    "glass": ("glass",), "mirror": ("glass",), "window": ("window",), "window_frame": ("trim", "aluminum"),
    "whiteboard": ("whiteboard",), "whiteboard_frame": ("aluminum",),
    "monitor": ("screen",), "monitor_body": ("plastic_black",), "keyboard": ("plastic_black",),
    "lamp": ("lampshade",), "lamp_stand": ("aluminum", "plastic_black"),
    "radiator": ("enamel",), "picture": ("paper",), "picture_frame": ("wood", "plastic_black", "aluminum"),
    "books": ("paper",), "chair": ("fabric",), "chair_frame": ("aluminum", "plastic_black", "wood"),
    "sofa": ("fabric",), "plant": ("leaves",), "pot": ("terracotta", "ceramic"),
    "pillar": ("paint", "concrete"), "coat_rack": ("wood", "aluminum"), "coat": ("fabric",),
    "filing_cabinet": ("painted_metal",), "box": ("cardboard",), "bin": ("plastic_black", "painted_metal"),
    "ceiling_light": ("diffuser",), "sill": ("stone", "trim"), "sign": ("sign",),
}
"""Which material classes each kind of object may wear."""

EMISSIVE_KINDS = ("monitor", "lamp", "sign")
"""Kinds that emit light (self-illuminating screens and lamp shades)."""


def _albedo(rng: np.random.Generator, c: MaterialClass) -> np.ndarray:
    v = rng.uniform(*c.diffuse)
    if c.hue == "gray":
        return np.full(3, v)
    if c.hue == "tint":  # slightly off-white: a random hue at low saturation
        h, s = rng.uniform(), rng.uniform(0.0, 0.12)
    elif c.hue == "brown":
        h, s = rng.uniform(0.05, 0.1), rng.uniform(0.45, 0.7)
    elif c.hue == "green":
        h, s = rng.uniform(0.22, 0.38), rng.uniform(0.5, 0.8)
    elif c.hue == "terracotta":
        h, s = rng.uniform(0.02, 0.06), rng.uniform(0.5, 0.7)
    else:
        h, s = rng.uniform(), rng.uniform(0.1, 0.7)
    return np.array(colorsys.hsv_to_rgb(h, s, v))


def sample_material(rng: np.random.Generator, cls: str) -> Material:
    """A material of class ``cls`` with parameters drawn from its ranges."""
    c = CLASSES[cls]
    kd = _albedo(rng, c)
    ks = np.full(3, rng.uniform(*c.specular)) if c.specular[1] > 0 else np.zeros(3)
    alpha = float(rng.uniform(*c.roughness))
    em = np.zeros(3)
    if c.emission[1] > 0:
        e = rng.uniform(*c.emission)
        h = {"lampshade": rng.uniform(0.07, 0.12), "sign": rng.uniform(0.3, 0.38)}.get(cls, rng.uniform(0.55, 0.65))
        sat = rng.uniform(0.6, 0.9) if cls == "sign" else rng.uniform(0.05, 0.3)
        em = e * np.array(colorsys.hsv_to_rgb(h, sat, 1.0))
    return Material(kd, ks, alpha, em)


def in_class(m: Material, cls: str, tol: float = 1e-9) -> bool:
    """The material's parameters lie inside the ranges of class ``cls``."""
    c = CLASSES[cls]
    ok = c.diffuse[0] - tol <= m.diffuse.max() <= c.diffuse[1] + tol
    ok &= c.specular[0] - tol <= m.specular.max() <= c.specular[1] + tol
    if c.specular[1] > 0:
        ok &= c.roughness[0] - tol <= m.roughness <= c.roughness[1] + tol
    ok &= c.emission[0] - tol <= m.emission.max() <= c.emission[1] + tol
    return bool(ok)


@dataclass
class Palette:
    """The materials of one scene, named ``<class>_<k>``."""

    rng: np.random.Generator
    materials: dict[str, Material] = field(default_factory=dict)
    _shared: dict[str, str] = field(default_factory=dict)

    def new(self, cls: str) -> str:
        """A freshly sampled material of class ``cls``; returns its name."""
        k = sum(1 for n in self.materials if n.rsplit("_", 1)[0] == cls)
        name = f"{cls}_{k}"
        self.materials[name] = sample_material(self.rng, cls)
        return name

    def shared(self, cls: str, tag: str = "") -> str:
        """One material per (class, tag) in the scene (e.g. the paint of one room)."""
        key = f"{cls}/{tag}"
        if key not in self._shared:
            self._shared[key] = self.new(cls)
        return self._shared[key]

    def pick(self, kind: str, shared: bool = True, tag: str = "") -> str:
        """A material for an object of ``kind`` from one of its allowed classes."""
        options = KIND_CLASSES[kind]
        cls = options[int(self.rng.integers(len(options)))]
        return self.shared(cls, tag or kind) if shared else self.new(cls)


def class_of(material_name: str) -> str:
    """The class of a palette material name ``<class>_<k>``."""
    return material_name.rsplit("_", 1)[0]


# ---------------------------------------------------------------------------------- textures
def _hash(i: np.ndarray, j: np.ndarray, seed: int) -> np.ndarray:
    """Deterministic pseudo-random [0, 1) per integer cell (i, j)."""
    x = (np.asarray(i, dtype=np.int64) * 73856093) ^ (np.asarray(j, dtype=np.int64) * 19349663) ^ (seed * 83492791)
    x = (x ^ (x >> 13)) * 1274126177
    return ((x ^ (x >> 16)) & 0xFFFFFF) / float(0x1000000)


def wood_grain(rng: np.random.Generator, vertical: bool = False) -> Texture:
    """Boards of varying shade (flat strips 8-15 cm wide) along s (or t when ``vertical``)."""
    width = rng.uniform(0.08, 0.15)
    amp = rng.uniform(0.12, 0.25)
    seed = int(rng.integers(1 << 30))

    def fn(s, t):
        k = np.floor((t if vertical else s) / width)
        v = 1 - amp * _hash(k, 0, seed)
        return np.stack([v, v * (1 - 0.05 * _hash(k, 1, seed)), v], 1)

    return Texture(fn, *((np.inf, width) if vertical else (width, np.inf)), flat=True)


def planks(rng: np.random.Generator) -> Texture:
    """Floor planks: strips along s, staggered butt joints along t, each plank its own shade."""
    width, length = rng.uniform(0.16, 0.25), rng.uniform(0.8, 1.4)
    amp = rng.uniform(0.15, 0.3)
    seed = int(rng.integers(1 << 30))
    cells = max(1, round(length / 0.5))

    def fn(s, t):
        k = np.floor(s / width)
        j = np.floor(t / length + _hash(k, 7, seed))
        v = 1 - amp * _hash(k, j, seed)
        return np.stack([v, v, v], 1)

    return Texture(fn, width, length / cells, flat=True)


def tiles(rng: np.random.Generator) -> Texture:
    """Square tiles of two alternating shades with small random variation."""
    size = rng.uniform(0.3, 0.6)
    contrast = rng.uniform(0.0, 0.35)
    seed = int(rng.integers(1 << 30))

    def fn(s, t):
        i, j = np.floor(s / size), np.floor(t / size)
        v = 1 - contrast * ((i + j) % 2) - 0.06 * _hash(i, j, seed)
        return np.stack([v, v, v], 1)

    return Texture(fn, size, size, flat=True)


def mottle(rng: np.random.Generator, amount: float = 0.08, cell: float = 0.5) -> Texture:
    """Smooth low-contrast value noise (carpet, concrete, worn paint) on the existing grid."""
    seed = int(rng.integers(1 << 30))

    def fn(s, t):
        v = 1 - amount * _hash(np.round(s / cell * 2), np.round(t / cell * 2), seed)
        return np.stack([v, v, v], 1)

    return Texture(fn, cell, cell)


def wallpaper(rng: np.random.Generator) -> Texture:
    """Vertical stripes of two tints (flat), optionally a darker dado band below 0.9 m."""
    width = rng.uniform(0.1, 0.25)
    a = np.array(colorsys.hsv_to_rgb(rng.uniform(), rng.uniform(0.05, 0.3), 1.0))
    b = a * rng.uniform(0.75, 0.92)
    dado = rng.uniform() < 0.4
    low = np.array(colorsys.hsv_to_rgb(rng.uniform(), rng.uniform(0.1, 0.4), rng.uniform(0.55, 0.8)))

    def fn(s, t):
        k = np.floor(s / width) % 2
        c = np.where(k[:, None] > 0, b, a)
        if dado:
            c = np.where((t < 0.9)[:, None], low, c)
        return c

    return Texture(fn, width, 0.9 if dado else np.inf, flat=True)


def poster(rng: np.random.Generator, w: float, h: float) -> Texture:
    """A picture: a background color with a few random blocks of saturated colors."""
    nu, nv = int(rng.integers(3, 7)), int(rng.integers(3, 7))
    bg = np.array(colorsys.hsv_to_rgb(rng.uniform(), rng.uniform(0.0, 0.5), rng.uniform(0.5, 1.0)))
    cols = np.array([colorsys.hsv_to_rgb(rng.uniform(), rng.uniform(0.3, 1.0), rng.uniform(0.2, 1.0))
                     for _ in range(nu * nv)])
    use = rng.uniform(size=nu * nv) < 0.5

    def fn(s, t):
        i = np.clip((s / w * nu).astype(int), 0, nu - 1)
        j = np.clip((t / h * nv).astype(int), 0, nv - 1)
        k = i * nv + j
        return np.where(use[k][:, None], cols[k], bg)

    return Texture(fn, w / nu, h / nv, flat=True)


def book_spines(rng: np.random.Generator) -> Texture:
    """Books side by side: flat strips 3-6 cm wide in random cloth colors."""
    width = rng.uniform(0.03, 0.06)
    seed = int(rng.integers(1 << 30))

    def fn(s, t):
        k = np.floor(s / width)
        h = _hash(k, 3, seed)
        sat = 0.3 + 0.6 * _hash(k, 4, seed)
        val = 0.25 + 0.75 * _hash(k, 5, seed)
        return np.array([colorsys.hsv_to_rgb(a, b, c) for a, b, c in zip(h, sat, val)]).reshape(-1, 3)

    return Texture(fn, width, np.inf, flat=True)


def quantize_colors(c: np.ndarray | None) -> np.ndarray | None:
    """Round colors to 8 bits (what a PLY file stores), so that save/load round-trips exactly."""
    return None if c is None else np.round(np.clip(c, 0, 1) * 255) / 255
