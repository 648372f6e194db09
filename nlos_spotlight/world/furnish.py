"""Furnishing a layout: pieces along the wall slots, then wall-mounted fittings above them.

Each theme ('home', 'office', 'corridor') has a catalog of floor pieces with weights and sizes.
Pieces are packed along each slot with random gaps (``density`` scales how full walls get), never
into keep-out zones (the light path, door swings), never overlapping each other; the hidden side
gets fewer and shallower pieces so the hidden region stays mostly free floor. Then fittings go on
the walls where the floor pieces leave room: windows (outer walls, a radiator below), pictures,
whiteboards (offices), mirrors (homes). One *feature* piece (a refrigerator, a glass-front
cabinet, a bookshelf, a whiteboard or a mirror) goes first on the relay wall next to the light
path, so that the surfaces the camera sees near the hidden region vary in shape and material.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from . import furniture as F
from .furniture import Frame, Kit, Part, footprint, place
from .layouts import Layout, Rect, Slot


def _overlaps(a: Rect, b: Rect, pad: float = 0.0) -> bool:
    return a[0] < b[2] + pad and b[0] < a[2] + pad and a[1] < b[3] + pad and b[1] < a[3] + pad


# catalog entries: name -> (weight per theme, width range, depth range, height range, builder(k, w, d, h, H))
Builder = Callable[[Kit, float, float, float, float], list[Part]]

CATALOG: dict[str, tuple[dict[str, float], tuple[float, float], tuple[float, float], tuple[float, float], Builder]] = {
    "cabinet": ({"home": 2, "office": 2, "corridor": 1}, (0.6, 1.6), (0.4, 0.6), (0.7, 1.0),
                lambda k, w, d, h, H: F.cabinet(k, w, d, h)),
    "tall_cabinet": ({"home": 1, "office": 1.5, "corridor": 0.5}, (0.6, 1.2), (0.4, 0.6), (1.6, 2.1),
                     lambda k, w, d, h, H: F.cabinet(k, w, d, min(h, H - 0.2), glass=k.chance(0.4))),
    "bookshelf": ({"home": 2, "office": 2, "corridor": 0.7}, (0.6, 1.2), (0.28, 0.4), (1.0, 2.2),
                  lambda k, w, d, h, H: F.bookshelf(k, w, d, min(h, H - 0.2))),
    "fridge": ({"home": 1.2, "office": 0.8}, (0.6, 0.9), (0.62, 0.75), (1.7, 1.9),
               lambda k, w, d, h, H: F.fridge(k, w, d, min(h, H - 0.15))),
    "kitchen": ({"home": 1.2, "office": 0.4}, (1.2, 2.4), (0.62, 0.62), (0.9, 2.2),
                lambda k, w, d, h, H: F.kitchen_counter(k, w, H)),
    "desk": ({"home": 0.8, "office": 3.5}, (1.1, 1.8), (0.6, 0.8), (0.76, 1.3),
             lambda k, w, d, h, H: F.desk(k, w, d, monitor=k.chance(0.8), lamp=k.chance(0.3))),
    "filing": ({"office": 1.5}, (0.45, 0.9), (0.5, 0.62), (0.7, 1.4),
               lambda k, w, d, h, H: F.filing_cabinet(k, w, d, h)),
    "sofa": ({"home": 1.5}, (1.5, 2.2), (0.8, 0.95), (0.85, 0.85), lambda k, w, d, h, H: F.sofa(k, w, d)),
    "tv": ({"home": 1.0}, (1.0, 1.8), (0.4, 0.4), (1.4, 1.4), lambda k, w, d, h, H: F.tv_stand(k, w)),
    "bench": ({"corridor": 1.5}, (1.0, 1.8), (0.4, 0.4), (0.46, 0.46), lambda k, w, d, h, H: F.bench(k, w)),
    "boxes": ({"home": 0.3, "office": 0.6, "corridor": 0.3}, (0.5, 0.9), (0.4, 0.6), (0.2, 1.3),
              lambda k, w, d, h, H: F.boxes(k, w, d)),
    "plant": ({"home": 1.0, "office": 1.0, "corridor": 1.5}, (0.5, 0.6), (0.5, 0.6), (0.5, 1.6),
              lambda k, w, d, h, H: place(F.plant(k, h), Frame.yaw(w / 2, d / 2, 0.0))),
    "lamp": ({"home": 0.8, "office": 0.3}, (0.5, 0.5), (0.5, 0.5), (1.4, 1.8),
             lambda k, w, d, h, H: place(F.floor_lamp(k), Frame.yaw(w / 2, d / 2, 0.0))),
    "coat_rack": ({"home": 0.3, "office": 0.4, "corridor": 1.0}, (0.55, 0.55), (0.55, 0.55), (1.85, 1.85),
                  lambda k, w, d, h, H: place(F.coat_rack(k), Frame.yaw(w / 2, d / 2, 0.0))),
}
"""Floor pieces: per-theme weights, width, depth and height ranges (m), and the builder."""

FEATURES = {"home": ("fridge", "tall_cabinet", "bookshelf", "mirror", "kitchen"),
            "office": ("fridge", "tall_cabinet", "whiteboard", "bookshelf", "mirror"),
            "corridor": ("tall_cabinet", "mirror", "whiteboard", "bookshelf")}
"""Pieces that may stand on the relay wall next to the light path."""


class Furnisher:
    """Fills the slots of one layout."""

    def __init__(self, lay: Layout, k: Kit, density: float):
        self.lay, self.k, self.density = lay, k, density
        self.spans: dict[int, list[tuple[float, float, float]]] = {}  # slot -> (s0, s1, top) of floor pieces
        self.mounted: dict[int, list[tuple[float, float, float]]] = {}  # slot -> (s0, s1, bottom z) on the wall

    # ----------------------------------------------------------------- floor pieces
    def _fits(self, rect: Rect) -> bool:
        if any(_overlaps(rect, r) for r in self.lay.keepout):
            return False
        return not any(_overlaps(rect, r, 0.02) for r, _ in self.lay.footprints)

    def _put(self, slot_i: int, slot: Slot, s: float, w: float, parts: list[Part]) -> bool:
        # local x runs along the slot; a left-handed frame (tangent, normal) is fine: winding is fixed
        fr = Frame.at(*slot.point(s), slot.tangent, slot.normal)
        placed = place(parts, fr)
        x0, y0, x1, y1, top = footprint(placed)
        rect = (x0, y0, x1, y1)
        if not self._fits(rect):
            return False
        if any(a < s + w and b > s and top > z - 0.03 for a, b, z in self.mounted.get(slot_i, [])):
            return False
        self.lay.add(placed)
        self.lay.footprints.append((rect, top))
        self.spans.setdefault(slot_i, []).append((s, s + w, top))
        return True

    def _choose(self, theme: str, slot: Slot) -> str | None:
        names, weights = [], []
        for name, (w, _, (d0, _d1), (h0, _h1), _) in CATALOG.items():
            if w.get(theme, 0) <= 0 or d0 > slot.max_depth or h0 > slot.max_height:
                continue
            if slot.side == "hidden" and (d0 > 0.7 or name in ("desk", "kitchen")):
                continue
            names.append(name)
            weights.append(w[theme])
        if not names:
            return None
        p = np.asarray(weights) / np.sum(weights)
        return names[int(self.k.rng.choice(len(names), p=p))]

    def floor_pieces(self) -> None:
        k = self.k
        crowded = 1.6 if self.lay.family == "cluttered_office" else 1.0
        for i, slot in enumerate(self.lay.slots):
            fill = self.density * (0.45 if slot.side == "hidden" else crowded)
            if slot.relay and slot.side == "camera" and math.isfinite(slot.max_height) and crowded > 1:
                fill = 3.0  # the low stretch next to the light path: (almost) always a desk or sideboard
            s = k.u(0.0, 0.6)
            while s < slot.length - 0.4:
                if k.rng.uniform() > min(0.95, 0.55 * fill + 0.1):
                    s += k.u(0.4, 1.2)
                    continue
                name = self._choose(self.lay.theme, slot)
                if name is None:
                    break
                self._try_piece(i, slot, name, s)
                s = max(s + 0.3, self._end(i, s)) + k.u(0.05, 0.6) / max(fill, 0.2)

    def _end(self, i: int, s: float) -> float:
        ends = [b for a, b, _ in self.spans.get(i, []) if a >= s - 1e-9]
        return max(ends) if ends else s

    def _try_piece(self, i: int, slot: Slot, name: str, s: float) -> bool:
        k = self.k
        _, (w0, w1), (d0, d1), (h0, h1), build = CATALOG[name]
        w = k.u(w0, w1)
        if s + w > slot.length:
            w = slot.length - s
            if w < w0:
                return False
        d = min(k.u(d0, d1), slot.max_depth)
        h = min(k.u(h0, h1), slot.max_height)
        if d < d0 or h < h0:
            return False
        parts = build(k, w, d, h, self.lay.ceiling)
        if footprint(parts)[4] > slot.max_height + 1e-6:
            return False
        return self._put(i, slot, s, w, parts)

    def feature(self) -> None:
        """One interesting piece on the relay wall right next to the light path."""
        k = self.k
        relay = [(i, s) for i, s in enumerate(self.lay.slots) if s.relay and s.side == "camera"
                 and math.isinf(s.max_height) and s.length > 1.0 and s.p0[0] < self.lay.camera_zone[2]]
        if not relay:
            return
        i, slot = max(relay, key=lambda t: t[1].p0[0] + t[1].length)  # ends nearest the light path
        name = FEATURES[self.lay.theme][int(k.rng.integers(len(FEATURES[self.lay.theme])))]
        if name in ("whiteboard", "mirror"):
            self._feature_wall(i, slot, name)
            return
        _, (w0, w1), _, _, _ = CATALOG[name]
        w = k.u(w0, w1)
        end = slot.length if slot.tangent[0] > 0 else 0.0
        s = max(0.0, end - w - k.u(0.0, 0.3)) if slot.tangent[0] > 0 else k.u(0.0, 0.3)
        self._try_piece(i, slot, name, s)

    def _feature_wall(self, i: int, slot: Slot, name: str) -> None:
        k = self.k
        w = k.u(1.2, 2.2) if name == "whiteboard" else k.u(0.6, 1.4)
        w = min(w, slot.length - 0.1)
        h = k.u(0.9, 1.2) if name == "whiteboard" else k.u(0.8, 1.4)
        z0 = k.u(0.8, 1.0)
        h = min(h, self.lay.ceiling - z0 - 0.2)
        s = slot.length - w - k.u(0.05, 0.3)
        parts = F.whiteboard(k, w, h, z0) if name == "whiteboard" else F.mirror(k, w, h, z0)
        self.lay.add(place(parts, Frame.at(*slot.point(s), slot.tangent, slot.normal)))
        self.spans.setdefault(i, []).append((s, s + w, -1.0))  # wall-mounted: no floor footprint
        self.mounted.setdefault(i, []).append((s, s + w, z0 - 0.03))

    # ----------------------------------------------------------------- wall fittings
    def fittings(self) -> None:
        k = self.k
        H = self.lay.ceiling
        for i, slot in enumerate(self.lay.slots):
            pieces = sorted(self.spans.get(i, []))
            s = k.u(0.1, 0.8)
            while s < slot.length - 0.5:
                w = k.u(0.5, 1.6)
                if s + w > slot.length - 0.1:
                    break
                under = [top for a, b, top in pieces if a < s + w and b > s]
                mounted = any(top < 0 for top in under)
                top = max([t for t in under if t >= 0], default=0.0)
                r = k.rng.uniform()
                parts = None
                if mounted:
                    pass
                elif slot.windows and top < 0.75 and r < 0.35:
                    z0 = k.u(0.85, 1.0)
                    wh = min(k.u(1.1, 1.6), H - z0 - 0.3)
                    parts = F.window(k, w, wh, z0)
                    if top <= 0 and k.chance(0.7):
                        parts += F.radiator(k, w * k.u(0.7, 0.95), min(0.6, z0 - 0.35), 0.12)
                elif self.lay.theme == "office" and top < 0.8 and r < 0.55 and w > 0.9:
                    parts = F.whiteboard(k, w, min(k.u(0.8, 1.2), H - 1.2), k.u(0.85, 1.0))
                elif r < 0.75 * min(1.0, self.density):
                    z0 = max(top + 0.2, k.u(1.1, 1.5))
                    ph = min(k.u(0.35, 0.9), H - z0 - 0.2)
                    pw = min(w, k.u(0.3, 1.0))
                    if ph > 0.25:
                        parts = F.mirror(k, pw, ph, z0) if (self.lay.theme == "home" and k.chance(0.15)) \
                            else F.picture(k, pw, ph, z0)
                elif top <= 0 and self.lay.theme == "corridor" and r < 0.9:
                    parts = F.radiator(k, w, k.u(0.4, 0.6), 0.15)
                if parts:
                    placed = place(parts, Frame.at(*slot.point(s), slot.tangent, slot.normal))
                    x0, y0, x1, y1, _ = footprint(placed)
                    if any(_overlaps((x0, y0, x1, y1), d, 0.05) for d in self.lay.doors):
                        parts = None
                if parts:
                    self.lay.add(placed)
                    pieces.append((s, s + w, -1.0))
                s += w + k.u(0.3, 1.5)


def furnish(lay: Layout, k: Kit, density: float) -> None:
    """Feature piece, floor pieces along the walls, then wall fittings."""
    f = Furnisher(lay, k, density)
    if density > 0:
        f.feature()
        f.floor_pieces()
        f.fittings()
