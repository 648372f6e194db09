"""Furniture and fittings, each built from parts that wear the materials of their shape.

Pieces are built in a local frame: x along the wall they stand against (0..width), y out of the
wall into the room (0..depth), z up from the floor. Free-standing pieces (chairs, plants, lamps,
pillars, coat racks) are centered on the local origin. :func:`place` maps a piece into the room.
Every part has a *kind* (what it is: 'fridge', 'whiteboard', 'glass', ...) and a material drawn
from the classes that kind may wear (:data:`~nlos_spotlight.world.materials.KIND_CLASSES`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene.format import TriMesh
from .geometry import Texture, blob, box, cylinder, merge, panel, rot_z, transform
from .materials import Palette, book_spines, mottle, poster, wood_grain


@dataclass
class Part:
    """One mesh of one kind and one material."""

    mesh: TriMesh
    """Geometry (local frame while building, world frame once placed)."""
    kind: str
    """What it is ('wall', 'fridge', 'glass', ...)."""
    material: str
    """Palette material name."""
    role: str = "furniture"
    """'shell' (walls, floor, ceiling), 'furniture', or 'occluder' (stands between camera and wall)."""


@dataclass
class Kit:
    """What every builder needs: randomness, the scene's palette and the texture switch."""

    rng: np.random.Generator
    pal: Palette
    texture: bool = True
    cell: float = 0.4

    def tex(self, t: Texture) -> Texture | None:
        return t if self.texture else None

    def u(self, lo: float, hi: float) -> float:
        return float(self.rng.uniform(lo, hi))

    def chance(self, p: float) -> bool:
        return bool(self.rng.uniform() < p)


@dataclass
class Frame:
    """Local -> world: p = origin + x tangent + y normal + z up (tangent, normal horizontal units)."""

    origin: np.ndarray
    tangent: np.ndarray
    normal: np.ndarray

    @classmethod
    def at(cls, x: float, y: float, tangent, normal, z: float = 0.0) -> "Frame":
        t, n = np.asarray(tangent, dtype=np.float64), np.asarray(normal, dtype=np.float64)
        return cls(np.array([x, y, z], dtype=np.float64), np.array([t[0], t[1], 0.0]), np.array([n[0], n[1], 0.0]))

    @classmethod
    def yaw(cls, x: float, y: float, yaw: float, z: float = 0.0) -> "Frame":
        r = rot_z(yaw)
        return cls(np.array([x, y, z], dtype=np.float64), r[:, 0], r[:, 1])

    def matrix(self) -> np.ndarray:
        return np.stack([self.tangent, self.normal, [0.0, 0.0, 1.0]], axis=1)

    def point(self, p) -> np.ndarray:
        return self.origin + self.matrix() @ np.asarray(p, dtype=np.float64)


def place(parts: list[Part], frame: Frame, role: str | None = None) -> list[Part]:
    """The parts moved into the world by ``frame``."""
    r = frame.matrix()
    return [Part(transform(p.mesh, r, frame.origin), p.kind, p.material, role or p.role) for p in parts]


def footprint(parts: list[Part]) -> tuple[float, float, float, float, float]:
    """(x0, y0, x1, y1, top) axis-aligned floor footprint and height of placed parts."""
    v = np.concatenate([p.mesh.vertices for p in parts])
    return (float(v[:, 0].min()), float(v[:, 1].min()), float(v[:, 0].max()), float(v[:, 1].max()),
            float(v[:, 2].max()))


# ------------------------------------------------------------------------------- helpers
def _handle(k: Kit, x: float, y: float, z: float, vertical: bool = True, length: float = 0.12) -> TriMesh:
    if vertical:
        return box([x - 0.01, y, z - length / 2], [x + 0.01, y + 0.03, z + length / 2])
    return box([x - length / 2, y, z - 0.01], [x + length / 2, y + 0.03, z + 0.01])


def _wood_box(k: Kit, lo, hi, vertical=False, skip=("-y",)) -> TriMesh:
    return box(lo, hi, math.inf, k.tex(wood_grain(k.rng, vertical)), skip=skip, tex_faces=("+y", "+z", "-x", "+x"))


# ------------------------------------------------------------------------- against a wall
def cabinet(k: Kit, w: float, d: float, h: float, glass: bool = False, back: bool = False) -> list[Part]:
    """A wooden cabinet or sideboard with handles; ``glass`` puts a glass door in its upper half."""
    wood = k.pal.pick("cabinet")
    parts = [Part(_wood_box(k, [0, 0, 0], [w, d, h], vertical=h > 1.2, skip=() if back else ("-y",)), "cabinet", wood)]
    doors = max(1, int(round(w / 0.5)))
    handles = []
    for i in range(doors):
        x = (i + 0.5) * w / doors + (0.18 if i % 2 == 0 else -0.18) * w / doors
        handles.append(_handle(k, x, d, min(h - 0.15, 0.8 if h > 1.2 else h - 0.12)))
    parts.append(Part(merge(handles), "handle", k.pal.pick("handle")))
    if glass and h > 1.2:
        g = panel([0.05, d + 0.004, h * 0.5], [w - 0.1, 0, 0], [0, 0, h * 0.45])
        parts.append(Part(g, "glass", k.pal.pick("glass")))
    return parts


def kitchen_counter(k: Kit, w: float, ceiling: float) -> list[Part]:
    """Base cabinets with a stone or laminate top and, often, wall cabinets above."""
    parts = cabinet(k, w, 0.58, 0.86)
    parts.append(Part(box([0, 0, 0.86], [w, 0.62, 0.9], skip=("-y",)), "countertop", k.pal.pick("countertop")))
    if k.chance(0.7) and ceiling > 2.3:
        top = min(ceiling - 0.05, 2.2)
        upper = cabinet(k, w, 0.34, top - 1.45)
        for p in upper:
            p.mesh.vertices[:, 2] += 1.45
        parts += upper
    return parts


def bookshelf(k: Kit, w: float, d: float, h: float, back: bool = True) -> list[Part]:
    """An open shelf with a back panel, boards and rows of books."""
    wood = k.pal.pick("shelf")
    t = 0.02
    m = [box([0, 0, 0], [t, d, h]), box([w - t, 0, 0], [w, d, h]), box([0, 0, h - t], [w, d, h]),
         box([0, 0, 0], [w, d, 0.08])]
    if back:
        m.append(box([0, 0, 0], [w, 0.015, h]))
    n = max(2, int(h / 0.38))
    books = []
    for i in range(1, n):
        z = 0.08 + i * (h - 0.08) / n
        m.append(box([t, 0, z - t], [w - t, d, z]))
    for i in range(n):
        z0 = 0.08 + i * (h - 0.08) / n
        gap = (h - 0.08) / n - t
        if k.chance(0.8):
            x0 = k.u(t, 0.3 * w)
            x1 = k.u(x0 + 0.25 * w, w - t)
            bh = min(gap - 0.03, k.u(0.18, 0.32))
            if bh > 0.1 and x1 - x0 > 0.1:
                b = box([x0, 0.03, z0], [x1, d - k.u(0.02, 0.08), z0 + bh], math.inf, k.tex(book_spines(k.rng)),
                        skip=("-y", "-z"), tex_faces=("+y",))
                books.append(b)
    parts = [Part(merge(m), "shelf", wood)]
    if books:
        parts.append(Part(merge(books), "books", k.pal.pick("books")))
    return parts


def fridge(k: Kit, w: float, d: float, h: float) -> list[Part]:
    """A refrigerator of glossy metal with long handles and a freezer door line."""
    steel = k.pal.pick("fridge")
    body = box([0, 0, 0.02], [w, d, h], cell=0.5, skip=("-y",))
    split = k.u(0.55, 0.7) * h
    door_gap = box([0.01, d, split - 0.006], [w - 0.01, d + 0.004, split + 0.006])
    hx = 0.08 if k.chance(0.5) else w - 0.08
    handles = merge([_handle(k, hx, d, split + 0.3, True, 0.35), _handle(k, hx, d, split - 0.35, True, 0.5)])
    return [Part(body, "fridge", steel), Part(merge([handles, door_gap]), "handle", k.pal.pick("handle"))]


def filing_cabinet(k: Kit, w: float, d: float, h: float) -> list[Part]:
    """Painted metal drawers with handles."""
    mat = k.pal.pick("filing_cabinet")
    n = max(2, int(h / 0.33))
    hs = [_handle(k, w / 2, d, (i + 0.7) * h / n, False, 0.14) for i in range(n)]
    return [Part(box([0, 0, 0], [w, d, h], skip=("-y",)), "filing_cabinet", mat),
            Part(merge(hs), "handle", k.pal.pick("handle"))]


def desk(k: Kit, w: float, d: float, monitor: bool = True, lamp: bool = False, chair: bool = True) -> list[Part]:
    """A desk with legs, often a glowing monitor and keyboard, a desk lamp and a chair in front."""
    h = k.u(0.72, 0.76)
    top = box([0, 0, h - 0.03], [w, d, h], math.inf, k.tex(wood_grain(k.rng)), tex_faces=("+z", "+y"))
    legs = [box([x, y, 0], [x + 0.05, y + 0.05, h - 0.03]) for x in (0.03, w - 0.08) for y in (0.03, d - 0.08)]
    mat = k.pal.pick("desk")
    parts = [Part(merge([top, *legs]), "desk", mat)]
    if monitor:
        mw = k.u(0.5, 0.7)
        mh = mw * k.u(0.55, 0.62)
        x0 = k.u(0.1, max(0.11, w - mw - 0.1))
        y0 = k.u(0.1, 0.25)
        z0 = h + k.u(0.1, 0.18)
        body = merge([box([x0, y0, z0], [x0 + mw, y0 + 0.04, z0 + mh]),
                      box([x0 + mw / 2 - 0.03, y0 - 0.02, h], [x0 + mw / 2 + 0.03, y0 + 0.02, z0]),
                      box([x0 + mw / 2 - 0.12, y0 - 0.08, h], [x0 + mw / 2 + 0.12, y0 + 0.1, h + 0.015])])
        screen = panel([x0 + 0.015, y0 + 0.042, z0 + 0.015], [mw - 0.03, 0, 0], [0, 0, mh - 0.03])
        screen.faces = screen.faces[:, ::-1].copy()  # facing +y
        parts += [Part(body, "monitor_body", k.pal.pick("monitor_body")),
                  Part(screen, "monitor", k.pal.pick("monitor", shared=False))]
        kb = box([x0 + mw / 2 - 0.22, y0 + 0.2, h], [x0 + mw / 2 + 0.22, y0 + 0.35, h + 0.025], skip=("-z",))
        parts.append(Part(kb, "keyboard", k.pal.pick("keyboard")))
    if lamp:
        parts += [Part(p.mesh, p.kind, p.material) for p in _desk_lamp(k, w - 0.2, 0.15, h)]
    if chair:
        c = office_chair(k) if k.chance(0.7) else wooden_chair(k)
        parts += place(c, Frame.yaw(w / 2 + k.u(-0.2, 0.2), d + k.u(0.15, 0.4), math.pi + k.u(-0.5, 0.5)))
    return parts


def _desk_lamp(k: Kit, x: float, y: float, h: float) -> list[Part]:
    stand = merge([cylinder([x, y, h], 0.07, 0.02, 8), cylinder([x, y, h + 0.02], 0.01, 0.35, 6, caps=False)])
    shade = cylinder([x, y, h + 0.3], 0.09, 0.12, 10, radius_top=0.05)
    return [Part(stand, "lamp_stand", k.pal.pick("lamp_stand")), Part(shade, "lamp", k.pal.pick("lamp", shared=False))]


def sofa(k: Kit, w: float, d: float) -> list[Part]:
    """A fabric sofa: base, back and arms."""
    fab = k.pal.pick("sofa", shared=False)
    m = merge([box([0, 0, 0.08], [w, d, 0.45]), box([0, 0, 0.45], [w, 0.22, 0.85]),
               box([0, 0.22, 0.45], [0.18, d, 0.65]), box([w - 0.18, 0.22, 0.45], [w, d, 0.65])])
    return [Part(m, "sofa", fab)]


def tv_stand(k: Kit, w: float) -> list[Part]:
    """A low wooden cabinet with a television: a dark glossy panel when off, a glowing screen when on."""
    parts = cabinet(k, w, 0.4, 0.5)
    tw = min(w - 0.1, k.u(0.9, 1.4))
    th = tw * 0.57
    x0 = (w - tw) / 2
    frame = merge([box([x0, 0.1, 0.55], [x0 + tw, 0.16, 0.55 + th]),
                   box([w / 2 - 0.15, 0.05, 0.5], [w / 2 + 0.15, 0.25, 0.55])])
    screen = panel([x0 + 0.02, 0.162, 0.57], [tw - 0.04, 0, 0], [0, 0, th - 0.04])
    screen.faces = screen.faces[:, ::-1].copy()
    on = k.chance(0.4)
    parts += [Part(frame, "monitor_body", k.pal.pick("monitor_body")),
              Part(screen, "monitor" if on else "glass", k.pal.pick("monitor" if on else "glass", shared=False))]
    return parts


def bench(k: Kit, w: float) -> list[Part]:
    """A wooden bench (corridors)."""
    m = merge([_wood_box(k, [0, 0, 0.42], [w, 0.4, 0.46], skip=()),
               box([0.05, 0.05, 0], [0.1, 0.35, 0.42]), box([w - 0.1, 0.05, 0], [w - 0.05, 0.35, 0.42])])
    return [Part(m, "bench", k.pal.pick("bench"))]


def boxes(k: Kit, w: float, d: float) -> list[Part]:
    """A stack of cardboard boxes."""
    m, z = [], 0.0
    for _ in range(int(k.rng.integers(1, 4))):
        bw, bd, bh = k.u(0.3, w), k.u(0.25, d), k.u(0.2, 0.45)
        x0 = k.u(0, w - bw)
        m.append(box([x0, 0.02, z], [x0 + bw, 0.02 + bd, z + bh]))
        z += bh
    return [Part(merge(m), "box", k.pal.pick("box", shared=False))]


# ------------------------------------------------------------------------------ wall mounted
def whiteboard(k: Kit, w: float, h: float, z0: float) -> list[Part]:
    """A glossy whiteboard with an aluminum frame and marker tray."""
    board = box([0, 0, z0], [w, 0.015, z0 + h], skip=("-y",))
    f = 0.025
    frame = merge([box([-f, 0, z0 - f], [w + f, 0.03, z0]), box([-f, 0, z0 + h], [w + f, 0.03, z0 + h + f]),
                   box([-f, 0, z0], [0, 0.03, z0 + h]), box([w, 0, z0], [w + f, 0.03, z0 + h]),
                   box([0.1 * w, 0.03, z0 - f], [0.9 * w, 0.09, z0 - f + 0.02])])
    return [Part(board, "whiteboard", k.pal.pick("whiteboard", shared=False)),
            Part(frame, "whiteboard_frame", k.pal.pick("whiteboard_frame"))]


def picture(k: Kit, w: float, h: float, z0: float) -> list[Part]:
    """A framed poster or painting (vertex-color texture)."""
    f = k.u(0.02, 0.05)
    canvas = panel([w - f, 0.022, z0 + f], [-(w - 2 * f), 0, 0], [0, 0, h - 2 * f], 0.3,
                   k.tex(poster(k.rng, w - 2 * f, h - 2 * f)))
    frame = merge([box([0, 0, z0], [w, 0.025, z0 + f]), box([0, 0, z0 + h - f], [w, 0.025, z0 + h]),
                   box([0, 0, z0], [f, 0.025, z0 + h]), box([w - f, 0, z0], [w, 0.025, z0 + h])])
    return [Part(canvas, "picture", k.pal.pick("picture", shared=False)),
            Part(frame, "picture_frame", k.pal.pick("picture_frame"))]


def mirror(k: Kit, w: float, h: float, z0: float) -> list[Part]:
    """A wall mirror or glass panel (nearly pure specular) with a thin frame."""
    glass = box([0, 0, z0], [w, 0.012, z0 + h], skip=("-y",))
    f = 0.02
    frame = merge([box([-f, 0, z0 - f], [w + f, 0.02, z0]), box([-f, 0, z0 + h], [w + f, 0.02, z0 + h + f])])
    return [Part(glass, "mirror", k.pal.pick("mirror", shared=False)),
            Part(frame, "picture_frame", k.pal.pick("picture_frame"))]


def radiator(k: Kit, w: float, h: float, z0: float = 0.12) -> list[Part]:
    """A finned panel radiator of white enamel (corrugated front)."""
    fins = max(4, int(w / 0.05))
    front = panel([0, 0.05, z0], [w, 0, 0], [0, 0, h], nu=2 * fins, nv=1)
    front.vertices[:, 1] = 0.05 + 0.025 * ((np.round(front.vertices[:, 0] / w * 2 * fins)) % 2)
    sides = merge([box([0, 0.02, z0], [w, 0.05, z0 + h], skip=("-y", "+y")),
                   box([0.05, 0, z0 - 0.12], [0.08, 0.06, z0]), box([w - 0.08, 0, z0 - 0.12], [w - 0.05, 0.06, z0])])
    return [Part(merge([front, sides]), "radiator", k.pal.pick("radiator"))]


def window(k: Kit, w: float, h: float, z0: float) -> list[Part]:
    """A window seen at night or with dark glass: a dark glossy pane, a frame with a mullion, a sill."""
    pane = panel([0, 0.01, z0], [w, 0, 0], [0, 0, h])
    pane.faces = pane.faces[:, ::-1].copy()
    f = 0.06
    fr = [box([-f, 0, z0 - f], [w + f, 0.06, z0]), box([-f, 0, z0 + h], [w + f, 0.06, z0 + h + f]),
          box([-f, 0, z0], [0, 0.06, z0 + h]), box([w, 0, z0], [w + f, 0.06, z0 + h])]
    if w > 0.9:
        fr.append(box([w / 2 - 0.03, 0.0, z0], [w / 2 + 0.03, 0.05, z0 + h]))
    if k.chance(0.5):
        fr.append(box([0, 0.0, z0 + 0.7 * h - 0.025], [w, 0.05, z0 + 0.7 * h + 0.025]))
    sill = box([-f - 0.03, 0, z0 - f - 0.03], [w + f + 0.03, 0.2, z0 - f])
    return [Part(pane, "window", k.pal.pick("window", shared=False)),
            Part(merge(fr), "window_frame", k.pal.pick("window_frame")),
            Part(sill, "sill", k.pal.pick("sill"))]


def door(k: Kit, w: float, h: float) -> list[Part]:
    """A closed door on a wall: leaf (wood grain or paint), casing and a handle."""
    leaf = box([0, 0, 0.01], [w, 0.03, h], math.inf, k.tex(wood_grain(k.rng, vertical=False)), skip=("-y",),
               tex_faces=("+y",))
    c = 0.07
    casing = merge([box([-c, 0, 0], [0, 0.04, h + c]), box([w, 0, 0], [w + c, 0.04, h + c]),
                    box([-c, 0, h], [w + c, 0.04, h + c])])
    hx = w - 0.08
    handle = merge([box([hx - 0.1, 0.03, 1.03], [hx + 0.02, 0.09, 1.06]),
                    box([hx - 0.02, 0.03, 0.95], [hx + 0.02, 0.045, 1.12])])
    return [Part(leaf, "door", k.pal.pick("door", shared=False)), Part(casing, "door_frame", k.pal.pick("door_frame")),
            Part(handle, "handle", k.pal.pick("handle"))]


# ------------------------------------------------------------------------------ free standing
def office_chair(k: Kit) -> list[Part]:
    """An office chair facing +y: fabric seat and back, a black pole and star base."""
    fab = k.pal.pick("chair")
    sz = k.u(0.44, 0.52)
    seat = box([-0.24, -0.22, sz], [0.24, 0.24, sz + 0.08])
    back = box([-0.22, -0.3, sz + 0.12], [0.22, -0.24, sz + k.u(0.5, 0.7)])
    frame = [cylinder([0, 0, 0.08], 0.025, sz - 0.08, 6), box([-0.04, -0.27, sz], [0.04, -0.24, sz + 0.15])]
    for a in np.arange(5) * 2 * np.pi / 5:
        frame.append(transform(box([0, -0.02, 0.05], [0.3, 0.02, 0.09]), rot_z(a), [0, 0, 0]))
    return [Part(merge([seat, back]), "chair", fab), Part(merge(frame), "chair_frame", k.pal.pick("chair_frame"))]


def wooden_chair(k: Kit) -> list[Part]:
    """A wooden chair facing +y (legs, seat and back slats)."""
    wood = k.pal.pick("chair_frame")
    s = 0.44
    legs = [box([x - 0.02, y - 0.02, 0], [x + 0.02, y + 0.02, s]) for x in (-0.19, 0.19) for y in (-0.19, 0.19)]
    backs = [box([x - 0.02, -0.21, s], [x + 0.02, -0.17, s + 0.45]) for x in (-0.19, 0.19)]
    slats = [box([-0.19, -0.21, s + z], [0.19, -0.18, s + z + 0.06]) for z in (0.22, 0.37)]
    seat = box([-0.22, -0.22, s], [0.22, 0.22, s + 0.04])
    return [Part(merge([seat, *legs, *backs, *slats]), "chair_frame", wood)]


def plant(k: Kit, size: float | None = None) -> list[Part]:
    """A potted plant: a terracotta or ceramic pot and lumpy foliage."""
    size = size or k.u(0.5, 1.6)
    r = k.u(0.12, 0.22) * max(1.0, size / 1.0)
    ph = k.u(0.25, 0.45)
    pot = cylinder([0, 0, 0], r * 0.75, ph, 10, radius_top=r)
    leaves = [blob([k.u(-0.05, 0.05), k.u(-0.05, 0.05), ph + 0.6 * (size - ph)],
                   [r * 1.6, r * 1.6, 0.5 * (size - ph) + 0.1], 1, k.rng, 0.25)]
    if size > 1.0:
        leaves.append(blob([k.u(-0.1, 0.1), k.u(-0.1, 0.1), ph + 0.3 * (size - ph)],
                           [r * 1.3, r * 1.3, 0.3 * (size - ph)], 1, k.rng, 0.3))
    return [Part(pot, "pot", k.pal.pick("pot")), Part(merge(leaves), "plant", k.pal.pick("plant"))]


def floor_lamp(k: Kit) -> list[Part]:
    """A floor lamp with a glowing shade."""
    h = k.u(1.4, 1.8)
    stand = merge([cylinder([0, 0, 0], 0.15, 0.03, 10), cylinder([0, 0, 0.03], 0.015, h - 0.25, 6, caps=False)])
    shade = cylinder([0, 0, h - 0.3], k.u(0.18, 0.25), 0.3, 12, radius_top=k.u(0.1, 0.16))
    return [Part(stand, "lamp_stand", k.pal.pick("lamp_stand")), Part(shade, "lamp", k.pal.pick("lamp", shared=False))]


def pillar(k: Kit, ceiling: float, round_: bool | None = None) -> list[Part]:
    """A structural column, square or round, floor to ceiling."""
    round_ = k.chance(0.4) if round_ is None else round_
    s = k.u(0.3, 0.5)
    if round_:
        m = cylinder([0, 0, 0], s / 2, ceiling, 12, caps=False, tex=k.tex(mottle(k.rng, 0.06, 0.3)))
    else:
        m = box([-s / 2, -s / 2, 0], [s / 2, s / 2, ceiling], 0.5, k.tex(mottle(k.rng, 0.06, 0.5)), skip=("-z", "+z"))
    return [Part(m, "pillar", k.pal.pick("pillar"))]


def coat_rack(k: Kit) -> list[Part]:
    """A coat stand with a couple of coats hanging from it."""
    h = k.u(1.7, 1.85)
    stand = merge([cylinder([0, 0, 0], 0.22, 0.03, 8), cylinder([0, 0, 0.03], 0.02, h, 6),
                   transform(box([-0.15, -0.01, h - 0.1], [0.15, 0.01, h - 0.08]), rot_z(k.u(0, 3)), [0, 0, 0])])
    coats = []
    for i in range(int(k.rng.integers(1, 4))):
        a = k.u(0, 2 * np.pi)
        length = k.u(0.8, 1.1)
        c = box([-0.2, -0.06, h - 0.12 - length], [0.2, 0.08, h - 0.1])
        coats.append(transform(c, rot_z(a), [0.1 * np.cos(a), 0.1 * np.sin(a), 0]))
    return [Part(stand, "coat_rack", k.pal.pick("coat_rack")),
            Part(merge(coats), "coat", k.pal.pick("coat", shared=False))]


def waste_bin(k: Kit) -> list[Part]:
    return [Part(cylinder([0, 0, 0], 0.14, 0.35, 10, radius_top=0.16), "bin", k.pal.pick("bin"))]


def table(k: Kit, w: float, d: float, chairs: int = 2) -> list[Part]:
    """A wooden table centered on the origin, with chairs around it."""
    h = 0.75
    top = box([-w / 2, -d / 2, h - 0.04], [w / 2, d / 2, h], math.inf, k.tex(wood_grain(k.rng)), tex_faces=("+z",))
    legs = [box([x - 0.03, y - 0.03, 0], [x + 0.03, y + 0.03, h - 0.04]) for x in (-w / 2 + 0.06, w / 2 - 0.06)
            for y in (-d / 2 + 0.06, d / 2 - 0.06)]
    parts = [Part(merge([top, *legs]), "table", k.pal.pick("table"))]
    for i in range(chairs):
        side = 1 if i % 2 == 0 else -1
        yaw = np.pi if side > 0 else 0.0  # facing the table
        parts += place(wooden_chair(k), Frame.yaw(k.u(-w / 4, w / 4), side * (d / 2 + 0.15), yaw))
    return parts


def ceiling_light(k: Kit, w: float, d: float, ceiling: float) -> list[Part]:
    """A flush ceiling panel (a diffuser; lights are off during captures)."""
    return [Part(box([-w / 2, -d / 2, ceiling - 0.04], [w / 2, d / 2, ceiling - 0.001], skip=("+z",)), "ceiling_light",
                 k.pal.pick("ceiling_light"))]


FREE_STANDING = {"office_chair": office_chair, "wooden_chair": wooden_chair, "plant": plant, "floor_lamp": floor_lamp,
                 "coat_rack": coat_rack, "bin": waste_bin}
"""Free-standing pieces used as occluders between camera and wall (plus pillars)."""
