"""The spot's light that the person blocks: the ``nlos_shadow`` component.

A photograph with the person minus one without holds, besides the light the body scatters
(``nlos``), the light it stops: spot light relayed by one static point h (the hidden floor, the
partition's back) toward a visible point x_p, blocked by the body on x_s -> h or on h -> x_p
(P -> x_s -> h -> x_p -> C). With V_S the static visibility and V_H the body's,

    L_p = - sum_h f_p(h -> x_p -> C) G(h, x_p) V_S(h, x_p) A_h rho_h / pi
              [E_blk(h) + (E(h) - E_blk(h)) (1 - V_H(h, x_p))],
    E(h)     = sum_s f_s(P -> x_s -> h) w_s G(x_s, h) V_S(x_s, h),
    E_blk(h) = sum_s f_s(P -> x_s -> h) w_s G(x_s, h) V_S(x_s, h) (1 - V_H(x_s, h)),

(1 - V_H V_H' = (1 - V_H) + V_H (1 - V_H')). Only a segment that crosses the body's bounding box
can be blocked, so body rays are cast only there, and only the points h with blocked light or
with a crossing segment toward the camera's points enter the sums. On a CPU the box test and the
second leg over diffuse camera points run as compiled loops: with the static visibility cached, over
every camera-point group in one call (``pair_loops.cross_groups``, ``pair_loops.shadow_legs``, on
:class:`FlatGroups`), else group by group (``pair_loops.segments_cross_box``, ``pair_loops.shadow_leg``);
the torch versions here stay the reference they are tested against.

Approximations, each small where this term matters: h is ``shadow_samples`` stratified area
samples of all static surfaces; h reflects as a Lambertian of albedo kd + ks (the hidden
surfaces of the reference scenes are diffuse, where this is exact); the body's shadow on direct
LOS-LOS paths (``interreflection``) is left out (zero on a planar relay wall). The term depends
on the person's position only through visibility, so it has no gradient with respect to it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import torch

from .brdf import brdf
from .fused import glossy_lobe
from .kernels import pair_geometry
from .person import Person, monte_carlo
from .rays import EPS

if TYPE_CHECKING:
    from .transport import Renderer


STATIC_CACHE_PAIRS = 1 << 26
"""Largest (camera sub-sample, h) visibility a renderer keeps (a byte a pair: 64 MB)."""


class FlatGroups(NamedTuple):
    """A relay set's camera-point groups flattened for the compiled legs (``pair_loops.relayed``,
    ``cross_groups``, ``shadow_legs``), float64 / int64 / bool numpy, P camera sub-samples, H
    relay points, G groups; fixed per renderer and relay set (:meth:`SpotShadow.flat_groups`)."""

    rp: np.ndarray
    """(P, 3) camera points."""
    rn: np.ndarray
    """(P, 3) their normals."""
    kd: np.ndarray
    """(P, 3) their diffuse albedo."""
    cos_c: np.ndarray
    """(P,) their cosine toward the camera."""
    rows: np.ndarray
    """The groups' camera points, group after group."""
    row_start: np.ndarray
    """(G + 1,) where each group's rows start."""
    hp: np.ndarray
    """(H, 3) relay points."""
    hn: np.ndarray
    """(H, 3) their normals."""
    area: np.ndarray
    """(H,) their area."""
    hs: np.ndarray
    """The groups' relay points, group after group."""
    hs_start: np.ndarray
    """(G + 1,) where each group's relay points start."""
    vis: np.ndarray
    """Each group's static visibility (its rows x its relay points, row-major), group after group."""
    vis_start: np.ndarray
    """(G + 1,) where each group's visibility starts."""


def segments_cross_box(a: torch.Tensor, b: torch.Tensor, lo: torch.Tensor, hi: torch.Tensor) -> torch.Tensor:
    """(Na, Nb) bool: the segment a_i -> b_j meets the axis-aligned box [lo, hi] (slab test)."""
    d = b.unsqueeze(0) - a.unsqueeze(1)
    d = torch.where(d.abs() < 1e-12, torch.full_like(d, 1e-12), d)
    t0, t1 = (lo - a.unsqueeze(1)) / d, (hi - a.unsqueeze(1)) / d
    near = torch.minimum(t0, t1).amax(-1).clamp(min=0)
    far = torch.maximum(t0, t1).amin(-1).clamp(max=1)
    return near <= far


def cross_box(a: torch.Tensor, b: torch.Tensor, lo: torch.Tensor, hi: torch.Tensor) -> torch.Tensor:
    """:func:`segments_cross_box`, in the compiled loop on a CPU (``pair_loops.segments_cross_box``:
    the same slab test without the (Na, Nb, 3) temporaries; the shadow step's largest part)."""
    if a.device.type != "cpu":
        return segments_cross_box(a, b, lo, hi)
    from .pair_loops import segments_cross_box as loop

    return torch.from_numpy(loop(_f64(a), _f64(b), _f64(lo), _f64(hi)))


def _f64(x: torch.Tensor) -> np.ndarray:
    """A CPU tensor as the float64 array the compiled loops take."""
    return x.detach().double().numpy()


def two_sided(m: torch.Tensor, side: torch.Tensor, light: torch.Tensor) -> torch.Tensor:
    """(P, 3): weights m (P, K) on the radiance light (2, K, 3) of each h's front [0] and back [1] side."""
    return (m * side) @ light[0] + (m * (1 - side)) @ light[1]


def spot_key(y: torch.Tensor) -> tuple:
    """A spot vector as a cache key (its support and weights): what a renderer keeps per spot."""
    return tuple(torch.nonzero(y).flatten().tolist()), tuple(y[y != 0].tolist())


class SpotShadow:
    """Static sample points h of a renderer's scene (``shadow_samples`` strata of the static area,
    shifted by ``offset``) and the blocked light through them. One fixed set for every person makes
    its sampling error a fixed pattern of the room that a network can learn (the robustness
    benchmark's ``relay-offsets``), so a dataset draws the offset per person (``fit/shadow.py``)."""

    def __init__(self, r: "Renderer", offset: float = 0.5):
        self.r, self.offset = r, offset
        face, bary, area = monte_carlo(r.static.mesh.face_areas(), r.settings.shadow_samples, offset)
        self.h = r.static.shade(face, bary).torch(r.device, r.dtype)
        self.area = r._t(area)
        self.rho = (self.h["kd"] + self.h["ks"]) / math.pi
        self._vis: dict[int, torch.Tensor] = {}  # group -> static visibility (``_static_visibility``)
        self._group_cache: list | None = None  # ``_groups``: the renderer's sub-samples do not change
        self._spot_light: dict = {}  # spot vector -> the radiance it leaves on each h (``bounce.spot_radiance``)
        self._tail: dict = {}  # spot vector -> the radiance the room's later relays leave on each h (``tail_light``)
        self._flat: tuple | bool | None = None  # ``flat_groups``: False where it does not apply

    def bounce(self, y: torch.Tensor, person: Person, t: torch.Tensor) -> torch.Tensor:
        """(H, W, 3) ``nlos_bounce`` through these relay points (``render/bounce.py``)."""
        from .bounce import bounce_image

        return bounce_image(self, y, person, t)

    def tail_light(self, y: torch.Tensor) -> torch.Tensor | None:
        """(2, H, 3) radiance the room's later relays of ``y``'s light leave on each h, up to the
        renderer's ``shadow_depth`` (``render/tail.py``, :meth:`room`); None at depth 4 (the first
        relay alone)."""
        if self.r.settings.shadow_depth <= 4:
            return None
        key = spot_key(y)
        if key not in self._tail:
            self._tail[key] = self.room(y).at(self.h["pos"], self.h["normal"], self.rho)
        return self._tail[key]

    def room(self, y: torch.Tensor):
        """The renderer's ``tail.RoomLight`` of spot vector ``y`` (built once, on the relay set of
        offset 0.5, so that every set, person and worker sees the same room light)."""
        from .tail import room_light

        key = spot_key(y)
        rooms = self.r._room_light
        if key not in rooms:
            ref = self if self.offset == 0.5 else SpotShadow(self.r, 0.5)
            rooms[key] = room_light(ref, y, self.r.settings.shadow_depth)
        return rooms[key]

    def later_deficit(self, y: torch.Tensor, body, lo: torch.Tensor, hi: torch.Tensor, src: dict) -> torch.Tensor:
        """(H, W, 3) (positive) the room's later relays that the body's blocking before their last
        leg takes from the camera's points (``tail.RoomLight.deficit``); ``src``: the spot's sources."""
        from .bounce import relayed_to_camera

        room = self.room(y)
        cpu = lambda t: t.detach().cpu()
        blocks = lambda pa, na, pb, nb, sel: cpu(self._body_blocks(body, *(t.to(self.r.device, self.r.dtype)
                                                                            for t in (pa, na, pb, nb)), sel.to(self.r.device)))
        inc = room.deficit(blocks, cpu(lo), cpu(hi), cpu(src["pos"]), cpu(src["normal"]))
        light = room.at(self.h["pos"], self.h["normal"], self.rho, inc)
        return relayed_to_camera(self, body, light.to(self.r.device, self.r.dtype))

    def spot_sources(self, y: torch.Tensor) -> tuple[dict, torch.Tensor]:
        """The spot's sample points lit by ``y`` (``pos``, ``normal``, material, ``to_proj`` and
        ``flux``: (S, 3) their flux toward the scene under ``y``) and whether each faces the projector
        (S, 1): the sources of every relayed term (the shadow's and the bounce's first leg)."""
        r = self.r
        idx = r._active(y)
        src = {k: v[idx] for k, v in r.spot_pts.items()}
        src["to_proj"] = r.spot_to_proj[idx]
        src["flux"] = r.spot_flux[idx] * y[r.spot_owner[idx]].unsqueeze(-1)
        return src, (src["normal"] * src["to_proj"]).sum(-1, keepdim=True)

    @staticmethod
    def first_leg(src: dict, dir_ab: torch.Tensor, gv: torch.Tensor) -> torch.Tensor:
        """(S, K, 3) irradiance the spot's sources ``src`` send toward K points: BRDF x geometry x
        visibility ``gv`` (S, K) x flux, along the unit directions ``dir_ab`` (S, K, 3)."""
        f = brdf(src["normal"].unsqueeze(1), src["to_proj"].unsqueeze(1), dir_ab, src["kd"].unsqueeze(1),
                 src["ks"].unsqueeze(1), src["alpha"].unsqueeze(1))
        return f * gv.unsqueeze(-1) * src["flux"].unsqueeze(1)

    def image(self, y: torch.Tensor, person: Person, t: torch.Tensor) -> torch.Tensor:
        """(H, W, 3) ``nlos_shadow`` (negative) of spot vector ``y`` and the body moved by ``t``."""
        r, h = self.r, self.h
        t_np = t.detach().cpu().numpy().astype(np.float64)
        verts = person.mesh.vertices + t_np
        body = r.body_rays(verts, person.mesh.faces)
        lo, hi = r._t(verts.min(0) - 4 * EPS), r._t(verts.max(0) + 4 * EPS)
        src, lit = self.spot_sources(y)
        rec = r.recv_t
        groups = self._groups(rec)
        flat = self.flat_groups() if r._loops() else None  # every group in one compiled call
        # which h matter: a blocked first leg, or a second leg toward a camera point through the box
        geo1 = pair_geometry(src["pos"], src["normal"], h["pos"], h["normal"])
        need1 = geo1.cos_a * lit > 0
        cross1 = need1 & cross_box(src["pos"], h["pos"], lo, hi)
        if flat is not None:
            from . import pair_loops as pl

            pl.set_threads(torch.get_num_threads())
            cross_flat, any_h = pl.loops()["cross_groups"](flat.rp, flat.rows, flat.row_start, flat.hp, flat.hs,
                                                           flat.hs_start, flat.vis_start, _f64(lo), _f64(hi))
            cross2 = torch.from_numpy(any_h)
        else:
            cross2 = torch.zeros(len(h["pos"]), dtype=torch.bool, device=r.device)
            crossing = []  # per group: (its sub-samples, its h) segments through the body's box
            for rows, hs in groups:
                c = torch.cat([cross_box(rec.pts["pos"][sl], h["pos"][hs], lo, hi) for sl in self._chunks(rows)])
                crossing.append(c)
                cross2[hs] |= c.any(0)
        keep = torch.nonzero(cross1.any(0) | cross2).flatten()
        if len(keep) == 0:
            return torch.zeros(*r.shape, 3, device=r.device, dtype=r.dtype)
        hk = {k: v[keep] for k, v in h.items()}
        # first leg: irradiance at the kept h, and its part the body blocks
        n1 = need1[:, keep]
        vs = r._visible(r.rays, src["pos"], src["normal"], hk["pos"], hk["normal"], n1)
        c = self.first_leg(src, geo1.dir_ab[:, keep], geo1.g[:, keep] * vs)  # (S, K, 3)
        blocked1 = self._body_blocks(body, src["pos"], src["normal"], hk["pos"], hk["normal"],
                                     cross1[:, keep] & (vs > 0))
        rho = self.rho[keep]
        front = (geo1.cos_b[:, keep] > 0).to(r.dtype).unsqueeze(-1)  # h is two-sided: light leaves the side it came in
        c_sides = torch.stack([c * front, c * (1 - front)])  # (2, S, K, 3)
        l_blk = rho * (c_sides * blocked1.unsqueeze(-1)).sum(1)  # (2, K, 3) radiance of h the body takes away
        l_rest = rho * c_sides.sum(1) - l_blk  # what still reaches h, which the body may block on the way out
        tail = self.tail_light(y)
        if tail is not None:  # the room's later relays reach h too
            l_rest = l_rest + tail[:, keep]
        if flat is not None:
            out = self._legs_flat(flat, body, keep, l_blk, l_rest, cross_flat)
        else:
            out = self._legs(groups, body, rec, keep, l_blk, l_rest, crossing)
        img = -r._pixels(rec.scale(out), rec)
        if tail is not None:
            img = img - self.later_deficit(y, body, lo, hi, src)
        return img

    def _legs_flat(self, flat: "FlatGroups", body, keep, l_blk, l_rest, cross_flat) -> torch.Tensor:
        """(P, 3) the second legs of every group in one compiled pass (``pair_loops.shadow_legs``) and
        the body rays of the crossing pairs."""
        from . import pair_loops as pl

        n = len(self.h["pos"])
        blk, rest = np.zeros((2, n, 3)), np.zeros((2, n, 3))
        kn = keep.cpu().numpy()
        blk[:, kn], rest[:, kn] = _f64(l_blk), _f64(l_rest)
        rad, org, dirs, length, row, lost = pl.loops()["shadow_legs"](*flat, cross_flat, blk, rest,
                                                                      blk.sum((0, 2)) > 0, 0.0)
        if len(row):
            hit = body.occluded_rays(org, dirs, length)
            np.add.at(rad, row[hit], lost[hit])
        return self.r._t(rad)

    def _legs(self, groups, body, rec, keep, l_blk, l_rest, crossing) -> torch.Tensor:
        """(P, 3) the second legs group by group (``crossing``: each group's box test), chunk by chunk:
        where the camera sees a glossy point or the static visibility is not cached."""
        r, h = self.r, self.h
        cos_c = (rec.pts["normal"] * rec.to_cam).sum(-1, keepdim=True)
        out = torch.zeros(len(rec.pixel), 3, device=r.device, dtype=r.dtype)
        ak = self.area[keep]
        hk = {k: v[keep] for k, v in h.items()}
        at = torch.full((len(h["pos"]),), -1, dtype=torch.long, device=r.device)
        at[keep] = torch.arange(len(keep), device=r.device)  # h index -> its place among the kept
        for g, (rows, hs) in enumerate(groups):
            sel = at[hs] >= 0
            if not sel.any():
                continue
            kk = at[hs][sel]  # the kept h this group's sub-samples see
            hg = {k: v[kk] for k, v in hk.items()}
            vis = self._static_visibility(g, rows, hs, cos_c)
            cross = crossing[g][:, sel]
            for a in range(0, len(rows), r.settings.chunk):
                b = slice(a, a + r.settings.chunk)
                leg = self._second_leg_loops if vis is not None and r.device.type == "cpu" \
                    and not rec.glossy[rows[b]].any() else self._second_leg  # the torch one: the reference
                out[rows[b]] = leg(body, rec, rows[b], cos_c[rows[b]], hg, ak[kk], l_blk[:, kk], l_rest[:, kk], cross[b],
                                   None if vis is None else vis[b][:, sel])
        return out

    def _static_visibility(self, g: int, rows: torch.Tensor, hs: torch.Tensor, cos_c) -> torch.Tensor | None:
        """(rows, hs) static visibility V_S(h, x_p) of group ``g`` where x_p faces h, cast once per
        renderer (it does not depend on the person); None where it would hold over
        :data:`STATIC_CACHE_PAIRS` pairs (then each person casts its own)."""
        mask = self._static_mask(g, rows, hs, cos_c)
        return None if mask is None else mask.to(self.r.dtype)

    def _static_mask(self, g: int, rows: torch.Tensor, hs: torch.Tensor, cos_c) -> torch.Tensor | None:
        """:meth:`_static_visibility` as the cached bool mask itself (no copy)."""
        r = self.r
        if g in self._vis:
            return self._vis[g]
        if len(rows) * len(hs) > STATIC_CACHE_PAIRS:
            return None
        hp, hn = self.h["pos"][hs], self.h["normal"][hs]
        parts = []
        for sl in self._chunks(rows):
            geo = pair_geometry(r.recv_t.pts["pos"][sl], r.recv_t.pts["normal"][sl], hp, hn)
            need = geo.cos_a * cos_c[sl] > 0
            parts.append(r._visible(r.rays, r.recv_t.pts["pos"][sl], r.recv_t.pts["normal"][sl], hp, hn,
                                    need, geo) > 0)
        self._vis[g] = torch.cat(parts)
        return self._vis[g]

    def flat_groups(self) -> "FlatGroups | None":
        """The person-independent inputs of ``pair_loops.relayed`` as numpy (the camera points'
        position, normal, kd and cosine toward the camera; each group's rows, relay points and
        static visibility flattened with their offsets; the relay points' position, normal and
        area), built once per relay set; None where the camera sees a glossy point or a group's
        static visibility is not cached (the per-group legs then run)."""
        if self._flat is None:
            self._flat = self._flatten() or False
        return self._flat or None

    def _flatten(self) -> "FlatGroups | None":
        r, rec = self.r, self.r.recv_t
        if r.device.type != "cpu" or bool(rec.glossy.any()):
            return None
        cos_c = (rec.pts["normal"] * rec.to_cam).sum(-1, keepdim=True)
        groups = self._groups(rec)
        vis = []
        for g, (rows, hs) in enumerate(groups):
            if len(hs) == 0 or len(rows) == 0:
                vis.append(np.zeros(0, np.bool_))
                continue
            mask = self._static_mask(g, rows, hs, cos_c)
            if mask is None:
                return None
            vis.append(mask.cpu().numpy().reshape(-1))
        offsets = lambda parts: np.concatenate([[0], np.cumsum([len(x) for x in parts])]).astype(np.int64)
        rows = [x.cpu().numpy().astype(np.int64) for x, _ in groups]
        hs = [x.cpu().numpy().astype(np.int64) for _, x in groups]
        cat = lambda parts, dt: np.concatenate(parts).astype(dt) if parts else np.zeros(0, dt)
        return FlatGroups(_f64(rec.pts["pos"]), _f64(rec.pts["normal"]), _f64(rec.pts["kd"]), _f64(cos_c.reshape(-1)),
                          cat(rows, np.int64), offsets(rows), _f64(self.h["pos"]), _f64(self.h["normal"]),
                          _f64(self.area), cat(hs, np.int64), offsets(hs), cat(vis, np.bool_), offsets(vis))

    def _groups(self, rec) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """(camera sub-samples, points h) that exchange light: all with all, or under footprint
        sampling each slot's sub-samples with the h shared out to that slot (``_Receivers.share``)."""
        if self._group_cache is not None:
            return self._group_cache
        dev = self.r.device
        if rec.key is None:
            self._group_cache = [(torch.arange(len(rec.pixel), device=dev), torch.arange(len(self.h["pos"]), device=dev))]
            return self._group_cache
        order = torch.argsort(rec.key, stable=True)  # rows by slot, one pass instead of one per slot
        bounds = torch.searchsorted(rec.key[order], torch.arange(rec.n_sub + 1, device=dev)).tolist()
        slot = rec.share(len(self.h["pos"]), dev)
        self._group_cache = [(order[bounds[k]:bounds[k + 1]], torch.nonzero(slot == k).flatten())
                             for k in range(rec.n_sub)]
        return self._group_cache

    def _chunks(self, rows: torch.Tensor):
        return torch.split(rows, self.r.settings.chunk)

    def _second_leg_loops(self, body, rec, sl, cos_c, hk, ak, l_blk, l_rest, cross, vs_static,
                          r2_min: float = 0.0) -> torch.Tensor:
        """:meth:`_second_leg` for diffuse camera points with the static visibility cached, as one
        compiled pass (``pair_loops.shadow_leg``) and the body rays of the crossing pairs only."""
        from .pair_loops import shadow_leg

        rad, org, dirs, length, row, lost = shadow_leg(
            _f64(rec.pts["pos"][sl]), _f64(rec.pts["normal"][sl]), _f64(rec.pts["kd"][sl]), _f64(cos_c.reshape(-1)),
            _f64(hk["pos"]), _f64(hk["normal"]), _f64(ak), _f64(l_blk), _f64(l_rest), (l_blk.sum((0, 2)) > 0).numpy(),
            cross.numpy(), _f64(vs_static), float(r2_min))
        if len(row):
            hit = body.occluded_rays(org, dirs, length)
            np.add.at(rad, row[hit], lost[hit])
        return self.r._t(rad)

    def _second_leg(self, body, rec, sl, cos_c, hk, ak, l_blk, l_rest, cross, vs_static,
                    r2_min: float = 0.0) -> torch.Tensor:
        """(P, 3) radiance toward the camera from camera points ``sl`` of the light the body stops;
        ``cross``: their segments to ``hk`` that cross the body's box; ``vs_static``: their static
        visibility if cached (:meth:`_static_visibility`), else None; ``r2_min``: the squared
        distance's floor (``kernels.pair_geometry``)."""
        r = self.r
        rp, rn = rec.pts["pos"][sl], rec.pts["normal"][sl]
        geo = pair_geometry(rp, rn, hk["pos"], hk["normal"], r2_min)
        need = geo.cos_a * cos_c > 0
        # rays only where some light is lost: h with blocked light, or a leg through the body's box
        cross = need & cross
        need = need & ((l_blk.sum((0, 2)) > 0).unsqueeze(0) | cross)
        vs = r._visible(r.rays, rp, rn, hk["pos"], hk["normal"], need, geo) if vs_static is None \
            else vs_static * need
        wgt = geo.g * vs * ak
        lost = wgt * self._body_blocks(body, rp, rn, hk["pos"], hk["normal"], cross & (vs > 0))
        side = (geo.cos_b > 0).to(r.dtype)  # the side of h that faces x_p
        rad = rec.pts["kd"][sl] / math.pi * (two_sided(wgt, side, l_blk) + two_sided(lost, side, l_rest))
        gl = rec.glossy[sl]
        if gl.any():
            spec = glossy_lobe(rp[gl], rn[gl], rec.to_cam[sl][gl], cos_c[gl], rec.pts["alpha"][sl][gl],
                               hk["pos"], hk["normal"])
            rad = rad.clone()
            rad[gl] = rad[gl] + rec.pts["ks"][sl][gl] * (two_sided(wgt[gl] * spec, side[gl], l_blk)
                                                         + two_sided(lost[gl] * spec, side[gl], l_rest))
        return rad

    def _body_blocks(self, body, pa, na, pb, nb, sel: torch.Tensor) -> torch.Tensor:
        """(Na, Nb) 1 where the body blocks the pair's segment (rays only for ``sel``), else 0."""
        return sel.to(self.r.dtype) - self.r._visible(body, pa, na, pb, nb, sel)
