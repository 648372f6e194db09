"""The person's light over one more static bounce: the ``nlos_bounce`` component.

``nlos`` follows three bounces (P -> x_s -> body -> x_p -> C). A photograph holds every bounce;
the next order has two paths through a static point h, both ways around the body:

    in:   P -> x_s -> h -> body -> x_p -> C   (the spot's light relayed onto the body by the room)
    out:  P -> x_s -> body -> h -> x_p -> C   (the body's light relayed to the camera's points)

With L_s(h) the radiance the spot leaves on h (its first leg, as ``nlos_shadow``'s E(h) times
rho_h), L_o the body's outgoing radiance (``nlos``'s), V the visibility with the body in place and
V_S the static one,

    in:   L_o' = albedo_o / pi  sum_h L_s(h) G(h, o) V(h, o) A_h,   gathered to x_p as ``nlos`` is;
    out:  L_p  = sum_h f_p(h -> x_p -> C) G(h, x_p) V_S(h, x_p) A_h rho_h  sum_o L_o G(o, h) V(o, h) A_o.

In the diffuse corner scene Mitsuba's particle tracer finds the fifth bounce 20% of the person's
scattered light and the sixth 9% more (``max_depth`` 5 and 6 against 4), the extra light's pattern
correlated 0.78 with ``nlos``'s: not a gain alone.

Approximations: h are the ``nlos_shadow`` relay points (``shadow_samples`` strata of the static
area, Lambertian of albedo kd + ks); the body does not block h -> x_p on the way out, nor the spot's
first leg on the way in (the shadow's own terms); light from the body to itself is left out. No
gradient (the body's visibility is held fixed).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import torch

from .kernels import pair_geometry

if TYPE_CHECKING:
    from .shadow import SpotShadow

H_CHUNK = 1024
"""Relay points per block of the body <-> h pairs (bounds memory: N x 1024 pairs a block)."""
NEAR_FIELD = 1.0
"""The relayed legs' distance floor in relay spacings (sqrt of the static area per relay point):
a relay point nearer a spot sample, body point or camera point than this exchanges light with it
as if this far (instant radiosity's clamp, Keller 1997). Unbounded, relay points next to a camera
point lit single pixels 10 to 10,000 times the person's light there (5 of 100 people in the copy
room)."""
BOUNCE_TAIL = 1.9
"""Everything past the fourth bounce (to depth 10) over ``nlos_bounce``, by Mitsuba 3's particle
tracer in the three reference scenes: 1.83-2.07, its 4 x 4 blocks correlated 0.98 with
``nlos_bounce`` (1.81-1.99 before the distance floor; ``benchmarks/bounce_mitsuba.py --spp 32768
--res 16 --tail 10``, docs/results/bounce-mitsuba.txt); 1.87 (1.84-1.97) in the scanned copy room
(experiments/bounce-tail). ``nlos_bounce`` times this stands in for all later bounces of the light
off the body; the light the body stops over the later bounces is ``nlos_shadow``'s
(``RenderSettings.shadow_depth``, ``render/tail.py``)."""


def near_r2(sh: "SpotShadow") -> float:
    """The squared distance floor of the relayed legs (:data:`NEAR_FIELD` relay spacings)."""
    return NEAR_FIELD ** 2 * float(sh.area.mean())


def spot_radiance(sh: "SpotShadow", y: torch.Tensor) -> torch.Tensor:
    """(2, H, 3) radiance the spot leaves on each relay point's front [0] and back [1] side, through
    static visibility only; kept per spot vector (it does not depend on the person)."""
    r, h = sh.r, sh.h
    from .shadow import spot_key

    key = spot_key(y)
    cache = sh._spot_light
    if key in cache:
        return cache[key]
    src, lit = sh.spot_sources(y)
    out = torch.zeros(2, len(h["pos"]), 3, device=r.device, dtype=r.dtype)
    for a in range(0, len(h["pos"]), H_CHUNK):
        sl = slice(a, a + H_CHUNK)
        geo = pair_geometry(src["pos"], src["normal"], h["pos"][sl], h["normal"][sl], near_r2(sh))
        need = geo.cos_a * lit > 0
        vs = r._visible(r.rays, src["pos"], src["normal"], h["pos"][sl], h["normal"][sl], need, geo)
        c = sh.first_leg(src, geo.dir_ab, geo.g * vs)  # (S, h, 3) irradiance parts
        front = (geo.cos_b > 0).to(r.dtype).unsqueeze(-1)  # h is two-sided: light leaves the side it came in
        out[0, sl] = (c * front).sum(0)
        out[1, sl] = (c * (1 - front)).sum(0)
    cache[key] = out * sh.rho
    return cache[key]


def body_relay(sh: "SpotShadow", rays, o: torch.Tensor, normal: torch.Tensor, l_front: torch.Tensor,
               l_back: torch.Tensor, area: torch.Tensor, albedo: torch.Tensor, l_relay: torch.Tensor,
               closed: bool = True):
    """Both ways between the body's samples o (N) and the relay points h (H), one visibility:
    returns the extra outgoing radiance of the body's front and back (N, 3) lit by ``l_relay``
    (2, H, 3), and the radiance (2, H, 3) each h's sides leave with the body's light ``l_front`` /
    ``l_back`` (N, 3). A ``closed`` body exchanges light through its front only. On a CPU without
    gradients a closed body runs as compiled loops (:func:`_body_relay_loops`); these torch blocks
    stay the reference they are tested against."""
    r, h = sh.r, sh.h
    if closed and LOOP_PAIRS > 0 and r._loops(o, normal, l_front, l_back, area, albedo, l_relay):
        return _body_relay_loops(sh, rays, o, normal, l_front, l_back, area, albedo, l_relay)
    e_front = torch.zeros(len(o), 3, device=r.device, dtype=r.dtype)
    e_back = torch.zeros_like(e_front)
    out = torch.zeros(2, len(h["pos"]), 3, device=r.device, dtype=r.dtype)
    for a in range(0, len(h["pos"]), H_CHUNK):
        sl = slice(a, a + H_CHUNK)
        geo = pair_geometry(o, normal, h["pos"][sl], h["normal"][sl], near_r2(sh))
        need = ((geo.cos_a > 0) if closed else (geo.cos_a != 0)) & (geo.cos_b != 0)
        w = geo.g * r._visible(rays, o, normal, h["pos"][sl], h["normal"][sl], need, geo)  # (N, h)
        o_front = (geo.cos_a > 0).to(r.dtype)  # h lies before the body sample's front
        h_front = (geo.cos_b > 0).to(r.dtype)  # the body sample lies before h's front
        ah = sh.area[sl]
        lr = l_relay[:, sl] * ah.unsqueeze(-1)  # (2, h, 3) radiance times area
        e_front += (w * o_front * h_front) @ lr[0] + (w * o_front * (1 - h_front)) @ lr[1]
        e_back += (w * (1 - o_front) * h_front) @ lr[0] + (w * (1 - o_front) * (1 - h_front)) @ lr[1]
        lo = (l_front * area.unsqueeze(-1), l_back * area.unsqueeze(-1))
        for side, hs in ((0, h_front), (1, 1 - h_front)):
            m = w * hs
            out[side, sl] = (m * o_front).T @ lo[0] + (m * (1 - o_front)).T @ lo[1]
    scale = albedo / math.pi
    return e_front * scale, e_back * scale, out * sh.rho[None]


LOOP_PAIRS = 1 << 22
"""Body sample x relay point pairs per block of :func:`_body_relay_loops` (bounds its rays: about
64 MB a block); 0: the torch blocks instead (the reference path of ``benchmarks/render_throughput.py --shadow``)."""


def _body_relay_loops(sh: "SpotShadow", rays, o, normal, l_front, l_back, area, albedo, l_relay):
    """:func:`body_relay` for a closed body as compiled loops (``pair_loops.relay_exchange``): the
    rays of the pairs where the body sample faces h built in one pass, the two sums over the
    unblocked ones in another, without the (N, H) geometry, masks and weights of the torch blocks.
    Profiled in the copy room at the fit's settings (1,024 body samples, 4,096 relay points, two
    threads), those blocks took about two thirds of the bounce's body <-> relay time, the rays the rest."""
    from . import pair_loops as pl
    from .shadow import _f64 as f64

    r, h = sh.r, sh.h
    pl.set_threads(torch.get_num_threads())
    hp, hn = f64(h["pos"]), f64(h["normal"])
    on, oo = f64(normal), f64(o)
    lo_f, lo_b = f64(l_front * area.unsqueeze(-1)), f64(l_back * area.unsqueeze(-1))
    lr = f64(l_relay * sh.area.unsqueeze(-1))
    r2 = near_r2(sh)
    e = np.zeros((2, len(oo), 3))
    out = np.zeros((2, len(hp), 3))
    step = max(1, LOOP_PAIRS // max(1, len(hp)))
    for a in range(0, len(oo), step):
        sl = slice(a, a + step)
        front = np.ones(len(oo[sl]))
        args = (oo[sl], on[sl], front, hp, hn, False, *pl.no_keys(len(oo[sl]), len(hp)))
        start = pl.pair_start(pl.loops()["need_counts"](*args))
        org, dirs, length, idx = pl.loops()["shadow_rays"](*args, start)
        vis = ~rays.occluded_rays(org, dirs, length)
        parts = 1 if pl.loops() is pl.SERIAL else pl.numba.get_num_threads()
        ea, oa = pl.loops()["relay_exchange"](oo[sl], on[sl], lo_f[sl], lo_b[sl], hp, hn, lr, start, idx, vis, r2, parts)
        e[:, sl] = ea
        out += oa
    scale = albedo / math.pi
    e_t, out_t = r._t(e), r._t(out)
    return e_t[0] * scale, e_t[1] * scale, out_t * sh.rho[None]


def relayed_to_camera(sh: "SpotShadow", body, l_relay: torch.Tensor) -> torch.Tensor:
    """(H, W, 3) the camera's points lit by the relay points' radiance (2, H, 3): the shadow's
    second leg with nothing blocked (``SpotShadow._second_leg`` and its compiled twin)."""
    r = sh.r
    rec = r.recv_t
    flat = sh.flat_groups() if r._loops(l_relay) else None
    if flat is not None:  # every group in one compiled call
        from . import pair_loops as pl

        pl.set_threads(torch.get_num_threads())
        light = l_relay.detach().double().cpu().numpy()
        rad = pl.loops()["relayed"](*flat, light, light.sum((0, 2)) > 0, near_r2(sh))
        return r._pixels(rec.scale(r._t(rad)), rec)
    cos_c = (rec.pts["normal"] * rec.to_cam).sum(-1, keepdim=True)
    out = torch.zeros(len(rec.pixel), 3, device=r.device, dtype=r.dtype)
    zero = torch.zeros_like(l_relay)
    for g, (rows, hs) in enumerate(sh._groups(rec)):
        if len(hs) == 0:
            continue
        hg = {k: v[hs] for k, v in sh.h.items()}
        vis = sh._static_visibility(g, rows, hs, cos_c)
        for a in range(0, len(rows), r.settings.chunk):
            b = rows[a:a + r.settings.chunk]
            cross = torch.zeros(len(b), len(hs), dtype=torch.bool, device=r.device)
            leg = sh._second_leg_loops if vis is not None and r.device.type == "cpu" \
                and not rec.glossy[b].any() else sh._second_leg
            out[b] = leg(body, rec, b, cos_c[b], hg, sh.area[hs], l_relay[:, hs], zero[:, hs], cross,
                         None if vis is None else vis[a:a + r.settings.chunk], near_r2(sh))
    return r._pixels(rec.scale(out), rec)


def bounce_image(sh: "SpotShadow", y: torch.Tensor, person, t: torch.Tensor) -> torch.Tensor:
    """(H, W, 3) ``nlos_bounce`` of spot vector ``y`` and the body moved by ``t`` (module docstring)."""
    from .rays import SceneRays

    r = sh.r
    n = r.settings.bounce_body_samples
    if 0 < n < len(person):  # a coarser stratified body quadrature for this smooth term
        person = person.resampled(n, sh.offset)
    with torch.no_grad():
        t_np = t.detach().cpu().numpy().astype("float64")
        rays = SceneRays(r.rays, person.translated_mesh(t_np))
        body = r.body_rays(person.mesh.vertices + t_np, person.mesh.faces)
        pts = {k: r._t(getattr(person, k)) for k in ("pos", "normal", "area", "albedo")}
        o = pts["pos"] + t
        lf, lb = r._person_radiosity(y, person, pts, o, rays)  # the body's light from the spot
        ef, eb, l_out = body_relay(sh, rays, o, pts["normal"], lf, lb, pts["area"], pts["albedo"],
                                   spot_radiance(sh, y), person.closed)
        return r._gather(person, pts, o, rays, ef, eb) + relayed_to_camera(sh, body, l_out)


__all__ = ["BOUNCE_TAIL", "NEAR_FIELD", "bounce_image", "body_relay", "near_r2", "relayed_to_camera", "spot_radiance"]
