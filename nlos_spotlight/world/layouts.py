"""The five layout families: room shells at real scale, in a canonical frame.

Canonical frame (every family): meters, z up, floor at z = 0; the *main relay wall* is the plane
y = 0 facing +y; the camera stands at y in [1.5, 4] (1.5-4 m from it) and looks at it near the
hidden region, which lies behind an occluder the light passes around.
:func:`~nlos_spotlight.world.rooms.generate_room` turns and mirrors the finished room by a
multiple of 90 degrees, so the frame does not show in the data.

* ``partitioned_room``: one room (6.6-8 m x 5-7 m, ceiling 2.4-3 m) split by a partition
  (floor to ceiling, or a 2.15-2.35 m office partition) that stops 0.7-1.3 m short of the relay
  wall; the hidden side is 3.8-4.6 m wide. Light goes through the gap along the relay wall.
* ``cluttered_office``: the same plan; the divider is often a storage wall (a row of tall
  cabinets and bookshelves on a backer panel, 2.1-2.4 m); the camera side is crowded (desks with
  monitors and chairs, filing cabinets, shelves, free-standing desks and boxes, a pillar).
* ``doorway``: two rooms side by side (3.2-5 m and 3.9-5 m wide, 4.6-6.5 m deep); the shared wall
  (10-18 cm thick) has a door 0.9-1.7 m wide and 2.0-2.25 m high, 0.25-0.8 m from the relay
  wall, its leaf open into the hidden room.
* ``l_corner``: an L-shaped room; the camera's arm (2.6-4 m deep) runs along the relay wall, the
  hidden arm (3.8-4.6 m wide, 5.2-6.5 m long) turns away from the camera at the inner corner,
  often behind a short wall return; the camera looks at the corner and past it into the arm.
* ``corridor_junction``: a corridor (2.1-3 m wide) with a T junction: a hall (3.8-4.6 m wide,
  5.2-6.5 m long) opens off the relay wall; doors along the corridor, exit signs, radiators.

Each family returns a :class:`Layout`: the shell parts (walls as double-sided planes or slabs
with openings, floor, ceiling, baseboards, ceiling lights), the wall *slots* furniture may stand
against, where the camera may stand, where the hidden region may go, and keep-out zones for the
light path and door swings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .furniture import Kit, Part, ceiling_light, door, pillar, place, Frame
from .geometry import WallSpec, box, merge, panel, wall_mesh
from .materials import mottle, planks, tiles, wallpaper

Rect = tuple[float, float, float, float]
"""Axis-aligned floor rectangle (x0, y0, x1, y1), m."""


@dataclass
class Slot:
    """A stretch of wall furniture may stand against."""

    p0: tuple[float, float]
    """Start point on the wall's room-side surface (xy)."""
    tangent: tuple[float, float]
    """Unit direction along the wall."""
    normal: tuple[float, float]
    """Unit direction into the room."""
    length: float
    """Usable length, m."""
    side: str
    """'camera' or 'hidden'."""
    max_height: float = math.inf
    """Tallest piece allowed (low pieces only near the light path)."""
    max_depth: float = math.inf
    """Deepest piece allowed (corridors)."""
    windows: bool = False
    """An outer wall: windows may go here."""
    relay: bool = False
    """Part of the main relay wall (y = 0)."""

    def point(self, s: float, depth: float = 0.0) -> np.ndarray:
        return np.array(self.p0) + s * np.array(self.tangent) + depth * np.array(self.normal)


@dataclass
class Layout:
    """A room shell and the rules for furnishing it and placing the camera."""

    family: str
    ceiling: float
    parts: list[Part] = field(default_factory=list)
    floors: list[Rect] = field(default_factory=list)
    """The walkable floor of every room."""
    camera_zone: Rect = (0, 0, 0, 0)
    """Where the tripod may stand."""
    camera_floor: list[Rect] = field(default_factory=list)
    """Floor of the camera's room(s): occluders stand here."""
    hidden_zone: Rect = (0, 0, 0, 0)
    """Where the hidden region may go (already 0.3 m off the walls)."""
    target: Callable[[np.random.Generator], np.ndarray] | None = None
    """Draws the camera's look-at point on the relay wall near the hidden region."""
    anchor: tuple[float, float] = (0.0, 0.0)
    """Where light enters the hidden zone; the hidden region is placed as close to it as it can."""
    keepout: list[Rect] = field(default_factory=list)
    """No floor furniture or occluders here (the light path, door swings)."""
    slots: list[Slot] = field(default_factory=list)
    theme: str = "office"
    """'home', 'office' or 'corridor': which furniture goes where."""
    footprints: list[tuple[Rect, float]] = field(default_factory=list)
    """Floor footprints (rect, top height) of everything placed so far."""
    doors: list[Rect] = field(default_factory=list)
    """Floor rectangles in front of closed doors (no wall fittings over them)."""

    def add(self, parts: list[Part]) -> None:
        self.parts.extend(parts)


# ------------------------------------------------------------------------------ shell parts
class Shell:
    """Builds walls, floors, ceilings and baseboards of one layout with per-room materials."""

    def __init__(self, k: Kit, lay: Layout):
        self.k, self.lay = k, lay
        self.cell = k.cell
        self.trim = k.pal.pick("baseboard")
        self._accent_done = False

    def paint(self, room: str) -> str:
        return self.k.pal.shared("paint", room)

    def wall(self, p0, p1, room: str, openings=(), thickness: float = 0.0, caps=(False, False), z1: float | None = None,
             baseboard_normal=None, accent_ok: bool = True) -> None:
        z1 = self.lay.ceiling if z1 is None else z1
        tex = mottle(self.k.rng, 0.06, 0.6)
        if accent_ok and not self._accent_done and self.k.chance(0.25):
            tex, self._accent_done = wallpaper(self.k.rng), True
        spec = WallSpec(tuple(p0), tuple(p1), 0.0, z1, thickness, tuple(openings), caps)
        self.lay.add([Part(wall_mesh(spec, self.cell, self.k.tex(tex)), "wall", self.paint(room), "shell")])
        normals = [baseboard_normal] if baseboard_normal is not None else []
        if thickness > 0 and baseboard_normal is None:
            d = np.subtract(p1, p0) / np.linalg.norm(np.subtract(p1, p0))
            normals = [(-d[1], d[0]), (d[1], -d[0])]
        for n in normals:
            self.baseboard(p0, p1, n, thickness / 2, openings)

    def baseboard(self, p0, p1, normal, offset: float = 0.0, openings=()) -> None:
        p0, p1, n = np.asarray(p0, float), np.asarray(p1, float), np.asarray(normal, float)
        length = float(np.linalg.norm(p1 - p0))
        d = (p1 - p0) / length
        h, t = self.k.u(0.06, 0.11), 0.015
        cuts = sorted([(a, b) for a, b, z0, _ in openings if z0 < h])
        s, spans = 0.0, []
        for a, b in cuts:
            if a > s:
                spans.append((s, a))
            s = max(s, b)
        if s < length:
            spans.append((s, length))
        ms = []
        for a, b in spans:
            o = np.array([*(p0 + a * d + (offset + t) * n), 0.0])
            u = np.array([*((b - a) * d), 0.0])
            ms.append(panel(o, u, [0, 0, h]))
            ms.append(panel(o + [0, 0, h], u, [*(-t * n), 0.0]))
        if ms:
            self.lay.add([Part(merge(ms), "baseboard", self.trim, "shell")])

    def floor(self, rect: Rect, room: str, hidden: bool = False) -> None:
        mat = self.k.pal.pick("floor", tag=room)
        cls = mat.rsplit("_", 1)[0]
        if cls == "floor_wood":
            tex = planks(self.k.rng)
        elif cls == "tile":
            tex = tiles(self.k.rng)
        else:
            tex = mottle(self.k.rng, 0.12, 0.5)
        x0, y0, x1, y1 = rect
        cell = self.cell * (1.8 if hidden else 1.25)
        if hidden and cls != "carpet":
            tex = mottle(self.k.rng, 0.08, cell)
        m = panel([x0, y0, 0], [x1 - x0, 0, 0], [0, y1 - y0, 0], cell, self.k.tex(tex))
        self.lay.add([Part(m, "floor", mat, "shell")])
        self.lay.floors.append(rect)

    def ceiling(self, rect: Rect, room: str, lights: bool = True) -> None:
        x0, y0, x1, y1 = rect
        h = self.lay.ceiling
        m = panel([x0, y0, h], [0, y1 - y0, 0], [x1 - x0, 0, 0], self.cell * 1.8)
        self.lay.add([Part(m, "ceiling", self.k.pal.shared("ceiling"), "shell")])
        if lights and self.k.chance(0.7):
            w, d = (0.6, 0.6) if self.k.chance(0.5) else (1.2, 0.3)
            nx, ny = max(1, int((x1 - x0) / 2.4)), max(1, int((y1 - y0) / 2.4))
            for i in range(nx):
                for j in range(ny):
                    cx, cy = x0 + (i + 0.5) * (x1 - x0) / nx, y0 + (j + 0.5) * (y1 - y0) / ny
                    self.lay.add(place(ceiling_light(self.k, w, d, h), Frame.yaw(cx, cy, 0.0), "shell"))


def _target(x0: float, x1: float, z=(0.6, 1.3)) -> Callable[[np.random.Generator], np.ndarray]:
    return lambda rng: np.array([rng.uniform(x0, x1), 0.0, rng.uniform(*z)])


def _slot(p0, p1, normal, side, **kw) -> Slot | None:
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    length = float(np.linalg.norm(p1 - p0))
    if length < 0.4:
        return None
    t = (p1 - p0) / length
    return Slot(tuple(p0), tuple(t), tuple(normal), length, side, **kw)


def _add_slots(lay: Layout, *slots) -> None:
    lay.slots.extend(s for s in slots if s is not None)


# ------------------------------------------------------------------------------ families
def partitioned_room(k: Kit, cluttered: bool = False) -> Layout:
    """One room split by a partition that stops short of the relay wall."""
    H = k.u(2.4, 3.0)
    lay = Layout("cluttered_office" if cluttered else "partitioned_room", H, theme="office")
    W, D = k.u(6.6, 8.0), k.u(5.0, 7.0)
    wh = k.u(3.8, min(4.6, W - 2.7))
    t = k.u(0.08, 0.14)
    xp = W - wh - t / 2
    g = k.u(0.7, 1.3)
    sh = Shell(k, lay)
    sh.wall((0, 0), (W, 0), "a", baseboard_normal=(0, 1))
    sh.wall((0, D), (0, 0), "a", baseboard_normal=(1, 0))
    sh.wall((W, 0), (W, D), "a", baseboard_normal=(-1, 0))
    back_door = (0.6, 1.5) if k.chance(0.5) else None
    sh.wall((W, D), (0, D), "a", baseboard_normal=(0, -1))
    shelves = cluttered and k.chance(0.6)
    top = H if (shelves or k.chance(0.75)) else k.u(2.15, min(2.35, H))
    if shelves:  # a storage wall: a row of tall cabinets and shelves on a thin backer panel
        from .furniture import bookshelf, cabinet

        top = min(H, k.u(2.1, 2.4))
        sh.wall((xp, g), (xp, D), "a", thickness=0.03, caps=(True, True), z1=top, accent_ok=False,
                baseboard_normal=(1, 0))
        y, depth = g, k.u(0.4, 0.55)
        while y < D - 0.45:
            w = min(k.u(0.8, 1.2), D - y)
            if k.chance(0.55):
                piece = bookshelf(k, w, depth, top - 0.02)
            else:
                piece = cabinet(k, w, depth, top - 0.02, glass=k.chance(0.3))
            lay.add(place(piece, Frame.at(xp - 0.015, y + w, (0, -1), (-1, 0))))
            y += w
        lay.footprints.append(((xp - depth - 0.015, g, xp, D), top))
    else:
        sh.wall((xp, g), (xp, D), "a", thickness=t, caps=(True, False), z1=top, accent_ok=False)
    for r in [(0, 0, W, D)]:
        sh.floor(r, "a")
        sh.ceiling(r, "a")
    xc = xp - (0.015 if shelves else t / 2)
    xh = xp + (0.015 if shelves else t / 2)
    lay.hidden_zone = (xh + 0.3, 0.3, W - 0.3, D - 0.3)
    lay.camera_zone = (0.5, 1.5, xc - 0.6 - (0.5 if shelves else 0.0), min(4.0, D - 0.5))
    lay.camera_floor = [(0, 0, xc, D)]
    lay.target = _target(xc - (2.4 if cluttered else 1.8), xc - 0.15)
    lay.anchor = (xh + 0.3, g / 2)
    lay.keepout = [(xc - 1.2, 0, xh + 1.5, g + 0.9)]
    if cluttered:  # low pieces (desks, sideboards) may stand right up to the light path
        lay.keepout = [(xc - 1.2, 0.8, xh + 1.5, g + 0.9), (xc - 0.3, 0, xh + 1.5, 0.8)]
        _add_slots(lay, _slot((xc - 1.2, 0), (xc - 0.3, 0), (0, 1), "camera", relay=True, max_height=1.3,
                              max_depth=0.8))
    if back_door:
        _wall_door(k, lay, (W, D), (-1, 0), (0, -1), W - xh - 0.5 - 1.0)
    _add_slots(lay,
               _slot((0, 0), (xc - 1.2, 0), (0, 1), "camera", relay=True),
               _slot((0, D), (0, 0), (1, 0), "camera", windows=True),
               _slot((xc, D), (0, D), (0, -1), "camera", windows=True),
               None if shelves else _slot((xc, g + 0.9), (xc, D), (-1, 0), "camera"),
               _slot((W, 0.3), (W, D), (-1, 0), "hidden", windows=True),
               _slot((xh, D), (W, D), (0, -1), "hidden"),
               _slot((xh, D), (xh, g + 0.9), (1, 0), "hidden"),
               _slot((xh + 1.5, 0), (W, 0), (0, 1), "hidden"))
    if cluttered and k.chance(0.5):  # a structural column in the open office
        x, y = k.u(0.8, xc - 1.5), k.u(D * 0.55, D - 0.6)
        lay.add(place(pillar(k, H), Frame.yaw(x, y, 0.0)))
        lay.footprints.append(((x - 0.3, y - 0.3, x + 0.3, y + 0.3), H))
    return lay


def cluttered_office(k: Kit) -> Layout:
    """An open office divided by a storage wall or partition, crowded on the camera side."""
    return partitioned_room(k, cluttered=True)


def doorway(k: Kit) -> Layout:
    """Two rooms joined by a door in the shared wall near the relay wall."""
    H = k.u(2.4, 3.0)
    lay = Layout("doorway", H, theme="home" if k.chance(0.6) else "office")
    Wa, Wb, t, D = k.u(3.2, 5.0), k.u(3.9, 5.0), k.u(0.1, 0.18), k.u(4.6, 6.5)
    xa, xb = Wa, Wa + t
    W = xb + Wb
    yd, wd = k.u(0.25, 0.8), k.u(0.9, 1.7)
    hd = k.u(2.0, min(2.25, H - 0.15))
    sh = Shell(k, lay)
    sh.wall((0, 0), (xa, 0), "a", baseboard_normal=(0, 1))
    sh.wall((xb, 0), (W, 0), "b", baseboard_normal=(0, 1))
    sh.wall((0, D), (0, 0), "a", baseboard_normal=(1, 0))
    sh.wall((W, 0), (W, D), "b", baseboard_normal=(-1, 0))
    sh.wall((xa, D), (0, D), "a", baseboard_normal=(0, -1))
    sh.wall((W, D), (xb, D), "b", baseboard_normal=(0, -1))
    xw = (xa + xb) / 2
    sh.wall((xw, 0), (xw, D), "a", openings=[(yd, yd + wd, 0.0, hd)], thickness=t, accent_ok=False)
    # the open door leaf, hinged at the far jamb, swung into the hidden room
    theta = math.radians(k.u(100, 170))
    hinge = np.array([xb, yd + wd])
    dirn = np.array([math.sin(theta), -math.cos(theta)])
    leaf_parts = door(k, wd - 0.02, hd - 0.02)[:1]  # the leaf only; casing below
    lay.add(place(leaf_parts, _leaf_frame(hinge, dirn)))
    _casing(k, lay, xa, xb, yd, wd, hd)
    for r, room in (((0, 0, xa, D), "a"), ((xb, 0, W, D), "b")):
        sh.floor(r, room, hidden=room == "b")
        sh.ceiling(r, room, lights=room == "a")
    lay.hidden_zone = (xb + 0.3, 0.3, W - 0.3, D - 0.3)
    lay.camera_zone = (0.5, 1.5, xa - 0.6, min(4.0, D - 0.5))
    lay.camera_floor = [(0, 0, xa, D)]
    lay.target = _target(xa - 1.5, xa - 0.15)
    lay.anchor = (xb + 0.3, yd + wd / 2)
    lay.keepout = [(xa - 1.2, 0, xa, yd + wd + 0.5), (xb, 0, xb + 1.4, yd + wd + 1.0)]
    _add_slots(lay,
               _slot((0, 0), (xa - 1.2, 0), (0, 1), "camera", relay=True),
               _slot((0, D), (0, 0), (1, 0), "camera", windows=True),
               _slot((xa, D), (0, D), (0, -1), "camera", windows=True),
               _slot((xa, yd + wd + 0.5), (xa, D), (-1, 0), "camera"),
               _slot((W, 0.2), (W, D), (-1, 0), "hidden", windows=True),
               _slot((W, D), (xb, D), (0, -1), "hidden"),
               _slot((xb, D), (xb, yd + wd + 1.0), (1, 0), "hidden"),
               _slot((xb + 1.4, 0), (W, 0), (0, 1), "hidden"))
    return lay


def _leaf_frame(hinge: np.ndarray, dirn: np.ndarray) -> Frame:
    # the leaf is built along local +x from its hinge edge, 3 cm thick along local +y
    return Frame.at(hinge[0], hinge[1], dirn, (-dirn[1], dirn[0]))


def _casing(k: Kit, lay: Layout, xa: float, xb: float, yd: float, wd: float, hd: float) -> None:
    c = 0.07
    mat = k.pal.pick("door_frame")
    m = []
    for x0, x1 in ((xa - 0.02, xa), (xb, xb + 0.02)):
        m += [box([x0, yd - c, 0], [x1, yd, hd + c]), box([x0, yd + wd, 0], [x1, yd + wd + c, hd + c]),
              box([x0, yd - c, hd], [x1, yd + wd + c, hd + c])]
    lay.add([Part(merge(m), "door_frame", mat, "shell")])


def _wall_door(k: Kit, lay: Layout, p0, tangent, normal, s: float) -> None:
    """A closed door on a wall at distance s from p0 along ``tangent``."""
    if s < 0.3:
        return
    w = k.u(0.82, 0.95)
    x, y = np.asarray(p0) + s * np.asarray(tangent)
    x1, y1 = np.asarray(p0) + (s + w) * np.asarray(tangent)
    nx, ny = normal
    r = (min(x, x1, x + 0.9 * nx), min(y, y1, y + 0.9 * ny), max(x, x1, x + 0.9 * nx), max(y, y1, y + 0.9 * ny))
    if any(_overlap(r, d) for d in lay.doors):
        return
    lay.add(place(door(k, w, k.u(2.0, min(2.15, lay.ceiling - 0.1))), Frame.at(x, y, tangent, normal)))
    lay.keepout.append(r)
    lay.doors.append(r)
    if lay.theme == "corridor" and k.chance(0.5):  # an exit sign above the door
        sign = box([w / 2 - 0.17, 0.0, 2.25], [w / 2 + 0.17, 0.06, 2.4])
        if lay.ceiling > 2.45:
            lay.add(place([Part(sign, "sign", k.pal.pick("sign", shared=False))], Frame.at(x, y, tangent, normal)))


def _overlap(a: Rect, b: Rect) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def l_corner(k: Kit) -> Layout:
    """An L-shaped room: the camera's arm runs along the relay wall, the hidden arm turns away from
    the camera at its far end (the camera looks at the inner corner and past it into that arm);
    often a short wall return narrows the opening."""
    H = k.u(2.4, 3.0)
    lay = Layout("l_corner", H, theme="home" if k.chance(0.7) else "office")
    w1, w2, L2 = k.u(2.6, 4.0), k.u(3.8, 4.6), k.u(5.2, 6.5)
    xi = k.u(3.6, 4.6)  # the inner corner; the hidden arm spans x in [xi, L1], y in [-L2, 0]
    L1 = xi + w2
    stub = k.u(0.3, 0.9) if k.chance(0.6) else 0.0  # a wall return from the corner into the opening
    sh = Shell(k, lay)
    sh.wall((0, 0), (xi + stub, 0), "a", baseboard_normal=(0, 1))
    if stub:
        sh.baseboard((xi, 0), (xi + stub, 0), (0, -1))
    sh.wall((xi, 0), (xi, -L2), "b", baseboard_normal=(1, 0))
    sh.wall((xi, -L2), (L1, -L2), "b", baseboard_normal=(0, 1))
    sh.wall((L1, -L2), (L1, w1), "a", baseboard_normal=(-1, 0))
    sh.wall((L1, w1), (0, w1), "a", baseboard_normal=(0, -1))
    sh.wall((0, w1), (0, 0), "a", baseboard_normal=(1, 0))
    for r, room, hid in (((0, 0, L1, w1), "a", False), ((xi, -L2, L1, 0), "b", True)):
        sh.floor(r, room, hidden=hid)
        sh.ceiling(r, room, lights=not hid)
    if k.chance(0.5):  # a corner guard on the inner corner
        xg = xi + stub
        lay.add([Part(box([xg - 0.03, -0.004, 0], [xg + 0.004, 0.03, 1.4]), "door_frame", k.pal.pick("door_frame"),
                      "shell")])
    # the tripod stands 2.8+ m before the corner and 1.5-2.2 m from the relay wall, so the wedge it
    # sees past the corner into the hidden arm stays shallow
    lay.camera_zone = (0.5, 1.5, xi - 2.8, min(2.2, w1 - 0.4))
    lay.camera_floor = [(0, 0, L1, w1)]
    lay.hidden_zone = (xi + 0.3, -L2 + 0.3, L1 - 0.3, -0.3)
    lay.target = _target(xi - 1.2, xi + stub - 0.1)
    lay.anchor = (xi + 0.3, -0.3)
    lay.keepout = [(xi - 1.0, -1.2, L1 - 0.5, 0.9)]
    _add_slots(lay,
               _slot((0, 0), (xi - 1.0, 0), (0, 1), "camera", relay=True),
               _slot((0, w1), (0, 0), (1, 0), "camera", windows=True, max_depth=0.45),
               _slot((L1, w1), (xi - 2.0, w1), (0, -1), "camera", windows=True),
               _slot((L1, 0.9), (L1, w1), (-1, 0), "camera"),
               _slot((L1, -1.2), (L1, -L2), (-1, 0), "hidden", windows=True),
               _slot((L1, -L2), (xi, -L2), (0, 1), "hidden"),
               _slot((xi, -L2), (xi, -0.5), (1, 0), "hidden"))
    return lay


def corridor_junction(k: Kit) -> Layout:
    """A corridor (T junction): a hall opens off the relay wall; the camera stands in the corridor
    before the junction and looks at the relay wall next to the opening."""
    H = k.u(2.4, 3.0)
    lay = Layout("corridor_junction", H, theme="corridor")
    wc, wh, Lh = k.u(2.1, 3.0), k.u(3.8, 4.6), k.u(5.2, 6.5)
    xh = k.u(3.6, 4.8)
    Lc = xh + wh + k.u(1.2, 3.0)
    sh = Shell(k, lay)
    sh.wall((0, 0), (xh, 0), "a", baseboard_normal=(0, 1))
    sh.wall((xh + wh, 0), (Lc, 0), "a", baseboard_normal=(0, 1))
    sh.wall((Lc, wc), (0, wc), "a", baseboard_normal=(0, -1))
    sh.wall((0, wc), (0, 0), "a", baseboard_normal=(1, 0))
    sh.wall((Lc, 0), (Lc, wc), "a", baseboard_normal=(-1, 0))
    sh.wall((xh, 0), (xh, -Lh), "b", baseboard_normal=(1, 0))
    sh.wall((xh + wh, -Lh), (xh + wh, 0), "b", baseboard_normal=(-1, 0))
    sh.wall((xh, -Lh), (xh + wh, -Lh), "b", baseboard_normal=(0, 1))
    for r, room, hid in (((0, 0, Lc, wc), "a", False), ((xh, -Lh, xh + wh, 0), "b", True)):
        sh.floor(r, room, hidden=hid)
        sh.ceiling(r, room, lights=True)
    lay.camera_zone = (0.5, 1.5, xh - 2.8, wc - 0.35)
    lay.camera_floor = [(0, 0, Lc, wc)]
    lay.hidden_zone = (xh + 0.3, -Lh + 0.3, xh + wh - 0.3, -0.3)
    lay.target = _target(xh - 1.2, xh - 0.1)
    lay.anchor = (xh + 0.3, -0.3)
    lay.keepout = [(xh - 1.0, -1.2, xh + wh + 0.5, wc)]
    _add_slots(lay,
               _slot((0, 0), (xh - 1.0, 0), (0, 1), "camera", relay=True, max_depth=0.45),
               _slot((xh + wh + 0.5, 0), (Lc, 0), (0, 1), "camera", relay=True, max_depth=0.45),
               _slot((Lc, wc), (xh - 2.0, wc), (0, -1), "camera", max_depth=0.45, windows=True),
               _slot((xh, -Lh), (xh, -0.6), (1, 0), "hidden"),
               _slot((xh + wh, -1.2), (xh + wh, -Lh), (-1, 0), "hidden", windows=True),
               _slot((xh + wh, -Lh), (xh, -Lh), (0, 1), "hidden"))
    for _ in range(int(k.rng.integers(0, 3))):  # office doors along the corridor's back wall
        _wall_door(k, lay, (Lc, wc), (-1, 0), (0, -1), k.u(0.3, Lc - xh + 1.0))
    if k.chance(0.6):  # a door in a corridor end wall
        _wall_door(k, lay, (0, wc), (0, -1), (1, 0), k.u(0.2, max(0.25, wc - 1.1)))
    return lay


def _minus(span, cuts):
    out = [span]
    for c0, c1 in cuts:
        nxt = []
        for a, b in out:
            if c1 <= a or c0 >= b:
                nxt.append((a, b))
                continue
            if c0 > a:
                nxt.append((a, c0))
            if c1 < b:
                nxt.append((c1, b))
        out = nxt
    return out


FAMILY_BUILDERS: dict[str, Callable[[Kit], Layout]] = {
    "l_corner": l_corner,
    "doorway": doorway,
    "corridor_junction": corridor_junction,
    "partitioned_room": partitioned_room,
    "cluttered_office": cluttered_office,
}
"""Layout family name -> shell builder."""
