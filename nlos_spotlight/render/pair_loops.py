"""The per-person pair sums as compiled loops over the pairs that carry light (numba, CPU).

A person's light is two sums over point pairs (DESIGN section 5): spot samples -> body samples
(``radiosity``) and body samples -> camera sub-samples (``gather_weights``), each with a shadow
ray per pair. The torch kernels (``render/fused.py``) evaluate them densely, pass by pass, and
build the rays of the pairs that need one with gathers over ``nonzero``: profiled at the demo
settings (239 candidates x 16 rays, 2,137 body samples, one thread), 70% of a person's time was
that elementwise torch and 30% the Embree rays. Here each sum is two loops over the (a, b)
pairs: the first writes the shadow rays of the pairs that can carry light (``pair_need``),
compacted, and the second adds up the light of those whose ray was not blocked. Nothing of
size (Na, Nb, 3) is stored, and pairs that carry no light cost a sign test.

These serve calls that need no gradient (dataset generation, evaluation, ``nlos render``); the
torch kernels stay the differentiable path and the reference these are tested against
(``tests/render/test_pair_loops.py``).

The order of operations follows ``render/rays.pair_rays`` and ``render/kernels.pair_geometry``
so that both build the same rays; sums run in float64 and are returned in the caller's dtype.

The loops run on numba's ``workqueue`` threading layer unless ``NUMBA_THREADING_LAYER`` says
otherwise: its idle threads sleep. Under the ``omp`` layer (numba's first choice) the idle OpenMP
threads spin between the hundred-odd loop calls of a person: two rendering processes on two cores
(``nlos fit``'s workers) rendered 2.49 people/s together against 3.23 for one alone
(``benchmarks/render_throughput.py``, its reference path).
"""

from __future__ import annotations

import math
import os
import types

import numba
import numpy as np
from numba import njit, prange

if "NUMBA_THREADING_LAYER" not in os.environ:  # before the first parallel loop runs (module docstring)
    numba.config.THREADING_LAYER = "workqueue"

from .brdf import COS_EPS
from .rays import EPS


@njit(cache=True, inline="always")
def _bs(akey, stride, a, n):
    """The b that a pairs with, as range bounds: all, or with footprint sampling (``stride`` > 0,
    ``akey[a]`` >= 0) every ``stride``-th from ``akey[a]``: the body samples shared out to a's slot."""
    if stride <= 0 or akey[a] < 0:
        return 0, n, 1
    return akey[a], n, stride


@njit(cache=True, inline="always")
def _needs(pa, na, front, o, nb, closed, a, b) -> bool:
    """The pair (a, b) can carry light: a faces b on its ``front`` side, and b's open side faces a."""
    dx, dy, dz = o[b, 0] - pa[a, 0], o[b, 1] - pa[a, 1], o[b, 2] - pa[a, 2]
    if (dx * na[a, 0] + dy * na[a, 1] + dz * na[a, 2]) * front[a] <= 0:
        return False
    return (not closed) or (dx * nb[b, 0] + dy * nb[b, 1] + dz * nb[b, 2]) < 0


@njit(cache=True, parallel=True)
def need_counts(pa, na, front, o, nb, closed, akey, stride):
    """(Na,) int64: how many body samples each point a exchanges light with (of those :func:`_bs` gives)."""
    out = np.zeros(pa.shape[0], np.int64)
    for a in prange(pa.shape[0]):
        c = 0
        lo, hi, step = _bs(akey, stride, a, o.shape[0])
        for b in range(lo, hi, step):
            if _needs(pa, na, front, o, nb, closed, a, b):
                c += 1
        out[a] = c
    return out


@njit(cache=True, inline="always")
def _write_ray(pa, na, pb, nb, a, b, dx, dy, dz, sa, sb, org, dirs, length, k):
    """Ray k of the segment a -> b (unit direction d, sides sa, sb of the ends' surfaces facing the
    other end): both ends pushed off their surfaces as in ``rays.pair_rays``, the far one pulled in."""
    ox = pa[a, 0] + EPS * (sa * na[a, 0] + dx)
    oy = pa[a, 1] + EPS * (sa * na[a, 1] + dy)
    oz = pa[a, 2] + EPS * (sa * na[a, 2] + dz)
    ex = pb[b, 0] + EPS * (sb * nb[b, 0] - dx) - ox
    ey = pb[b, 1] + EPS * (sb * nb[b, 1] - dy) - oy
    ez = pb[b, 2] + EPS * (sb * nb[b, 2] - dz) - oz
    el = math.sqrt(ex * ex + ey * ey + ez * ez)
    org[k, 0], org[k, 1], org[k, 2] = ox, oy, oz
    dirs[k, 0], dirs[k, 1], dirs[k, 2] = ex / el, ey / el, ez / el
    length[k] = max(el - EPS, 0.0)


@njit(cache=True, parallel=True)
def shadow_rays(pa, na, front, o, nb, closed, akey, stride, start):
    """The shadow rays of the pairs that need one, a-major: float32 origins (M, 3), unit
    directions (M, 3), lengths (M,), and the body sample of each (M,) int32. ``start`` (Na + 1,):
    the exclusive prefix sum of :func:`need_counts`. Both ends are pushed off their surfaces as in
    ``rays.pair_rays``."""
    m = start[-1]
    org = np.empty((m, 3), np.float32)
    dirs = np.empty((m, 3), np.float32)
    length = np.empty(m, np.float32)
    idx = np.empty(m, np.int32)
    for a in prange(pa.shape[0]):
        k = start[a]
        lo, hi, step = _bs(akey, stride, a, o.shape[0])
        for b in range(lo, hi, step):
            if not _needs(pa, na, front, o, nb, closed, a, b):
                continue
            dx, dy, dz = o[b, 0] - pa[a, 0], o[b, 1] - pa[a, 1], o[b, 2] - pa[a, 2]
            r = math.sqrt(dx * dx + dy * dy + dz * dz)
            dx, dy, dz = dx / r, dy / r, dz / r
            sa = np.sign(dx * na[a, 0] + dy * na[a, 1] + dz * na[a, 2])
            sb = np.sign(-(dx * nb[b, 0] + dy * nb[b, 1] + dz * nb[b, 2]))
            _write_ray(pa, na, o, nb, a, b, dx, dy, dz, sa, sb, org, dirs, length, k)
            idx[k] = b
            k += 1
    return org, dirs, length, idx


@njit(cache=True, inline="always")
def _pair(pa, na, o, nb, a, b):
    """``kernels.pair_geometry`` of one pair: the unit direction a -> b, r^2, cos_a and cos_b."""
    dx, dy, dz = o[b, 0] - pa[a, 0], o[b, 1] - pa[a, 1], o[b, 2] - pa[a, 2]
    r2 = dx * dx + dy * dy + dz * dz
    r = math.sqrt(r2)
    dx, dy, dz = dx / r, dy / r, dz / r
    return dx, dy, dz, r2, dx * na[a, 0] + dy * na[a, 1] + dz * na[a, 2], -(dx * nb[b, 0] + dy * nb[b, 1] + dz * nb[b, 2])


@njit(cache=True, inline="always")
def _ggx_d(cos_h, alpha):
    a2 = alpha * alpha
    t = (a2 - 1) * cos_h * cos_h + 1
    return a2 / (math.pi * t * t)


@njit(cache=True, inline="always")
def _smith_g1(cos_v, alpha):
    c2 = max(cos_v * cos_v, COS_EPS)
    tan2 = max(1 - c2, 0.0) / c2
    return 2 / (1 + math.sqrt(1 + alpha * alpha * tan2))


@njit(cache=True, inline="always")
def _ggx_lobe(n, a, wx, wy, wz, vx, vy, vz, cos_w, cos_v, alpha):
    """GGX factor D G1 G1 / (4 |cos_w| |cos_v|) at the point of normal ``n[a]`` between the unit
    directions w and v (``brdf.brdf``'s glossy lobe without ks)."""
    hx, hy, hz = wx + vx, wy + vy, wz + vz
    hn = max(math.sqrt(hx * hx + hy * hy + hz * hz), 1e-12)
    cos_h = abs((n[a, 0] * hx + n[a, 1] * hy + n[a, 2] * hz) / hn)
    spec = _ggx_d(cos_h, alpha) * _smith_g1(cos_w, alpha) * _smith_g1(cos_v, alpha)
    return spec / (4 * max(abs(cos_w), COS_EPS) * max(abs(cos_v), COS_EPS))


@njit(cache=True, parallel=True)
def radiosity(sp, sn, to_proj, kd, ks, alpha, glossy, w, runs, group, o, nb, start, idx, visible, groups):
    """Sum over spot samples s of f_s G(s, n) w_s for the unblocked pairs, per group and side of n.

    ``runs`` (R + 1,): boundaries of the runs of equal ``group`` in s (rows of one run write one
    group, so runs go in parallel); ``glossy``: add the GGX lobe of ``ks``, ``alpha``. Returns
    front and back, each (groups, N, 3) float64, as ``fused.radiosity``.
    """
    front = np.zeros((groups, o.shape[0], 3))
    back = np.zeros((groups, o.shape[0], 3))
    for r in prange(runs.shape[0] - 1):
        g = group[runs[r]]
        for s in range(runs[r], runs[r + 1]):
            cos_i = sn[s, 0] * to_proj[s, 0] + sn[s, 1] * to_proj[s, 1] + sn[s, 2] * to_proj[s, 2]
            for k in range(start[s], start[s + 1]):
                if not visible[k]:
                    continue
                b = idx[k]
                dx, dy, dz, r2, cos_a, cos_b = _pair(sp, sn, o, nb, s, b)
                if cos_i * cos_a <= 0:  # the BRDF's two sides
                    continue
                geo = abs(cos_a) * abs(cos_b) / r2
                spec = 0.0
                if glossy:
                    spec = _ggx_lobe(sn, s, to_proj[s, 0], to_proj[s, 1], to_proj[s, 2], dx, dy, dz, cos_i, cos_a,
                                     alpha[s])
                out = front if cos_b > 0 else back
                for c in range(3):
                    f = kd[s, c] / math.pi + (ks[s, c] * spec if glossy else 0.0)
                    out[g, b, c] += f * geo * w[s, c]
    return front, back


@njit(cache=True, parallel=True)
def gather_weights(rp, rn, to_cam, cos_c, alpha, gl_row, n_gl, o, nb, area, start, idx, visible):
    """The weights of ``fused.gather_weights`` and ``fused.glossy_lobe`` over the unblocked pairs.

    Returns wf, wb (P, N): G V a of body sample n's front and back side seen from sub-sample p
    (zero for pairs without light or with a blocked ray); sf, sb (n_gl, N): the same times the GGX
    factor, for the sub-samples with ``gl_row`` >= 0 (their row there); and whether any back-side
    weight is non-zero (never for a closed body).
    """
    wf = np.zeros((rp.shape[0], o.shape[0]), rp.dtype)
    wb = np.zeros((rp.shape[0], o.shape[0]), rp.dtype)
    sf = np.zeros((n_gl, o.shape[0]), rp.dtype)
    sb = np.zeros((n_gl, o.shape[0]), rp.dtype)
    backs = np.zeros(rp.shape[0], np.bool_)
    for p in prange(rp.shape[0]):
        g = gl_row[p]
        for k in range(start[p], start[p + 1]):
            if not visible[k]:
                continue
            b = idx[k]
            dx, dy, dz, r2, cos_a, cos_b = _pair(rp, rn, o, nb, p, b)
            v = abs(cos_a) * abs(cos_b) / r2 * area[b]
            if cos_b <= 0:
                backs[p] = True
            (wf if cos_b > 0 else wb)[p, b] = v
            if g >= 0:
                spec = _ggx_lobe(rn, p, dx, dy, dz, to_cam[p, 0], to_cam[p, 1], to_cam[p, 2], cos_a, cos_c[p], alpha[p])
                (sf if cos_b > 0 else sb)[g, b] = v * spec
    return wf, wb, sf, sb, backs.any()


@njit(cache=True, parallel=True)
def gather_sparse(rp, rn, to_cam, cos_c, kd, ks, alpha, glossy, o, nb, area, start, idx, visible, front, back):
    """The radiance (P, C) each camera sub-sample p receives from the body over its unblocked pairs:
    ``kd_p / pi sum_n G V a_n L_n + ks_p sum_n G V a_n GGX L_n``, L_n the front or back radiance
    (N, C) of body sample n by the side facing p, channels c taking colour c % 3 of kd and ks.
    The same sums as :func:`gather_weights` followed by its matrix products, without the dense
    (P, N) weights: for footprint sampling, where each sub-sample pairs with 1 / n^2 of the body."""
    out = np.zeros((rp.shape[0], front.shape[1]))
    for p in prange(rp.shape[0]):
        for k in range(start[p], start[p + 1]):
            if not visible[k]:
                continue
            b = idx[k]
            dx, dy, dz, r2, cos_a, cos_b = _pair(rp, rn, o, nb, p, b)
            v = abs(cos_a) * abs(cos_b) / r2 * area[b]
            light = front if cos_b > 0 else back
            spec = 0.0
            if glossy[p]:
                spec = _ggx_lobe(rn, p, dx, dy, dz, to_cam[p, 0], to_cam[p, 1], to_cam[p, 2], cos_a, cos_c[p], alpha[p])
            for c in range(front.shape[1]):
                out[p, c] += (kd[p, c % 3] / math.pi + ks[p, c % 3] * spec) * v * light[b, c]
    return out


@njit(cache=True, parallel=True)
def relay_exchange(o, on, lf, lb, hp, hn, lr, start, idx, visible, r2_min, parts):
    """Both ways between body samples o (N) and relay points h (H) over the unblocked pairs, as
    ``render.bounce.body_relay``'s torch blocks: w = |cos_o| |cos_h| / max(r^2, r2_min);
    e[s_o, n] = sum_h w lr[s_h, h] (the irradiance on body sample n's side s_o from the side s_h of
    h that faces it; ``lr`` (2, H, 3) relay radiance times area) and out[s_h, h] = sum_n w lo_n
    (``lf`` / ``lb`` (N, 3): the body's front / back radiance times area, by the side facing h).
    Returns e (2, N, 3) and out (2, H, 3) in float64. Rows of o run in ``parts`` blocks, each
    adding to its own copy of ``out`` (no two threads write one h)."""
    n_o, n_h = o.shape[0], hp.shape[0]
    e = np.zeros((2, n_o, 3))
    out = np.zeros((parts, 2, n_h, 3))
    step = (n_o + parts - 1) // parts
    for p in prange(parts):
        for a in range(p * step, min(n_o, (p + 1) * step)):
            for k in range(start[a], start[a + 1]):
                if not visible[k]:
                    continue
                b = idx[k]
                dx, dy, dz, r2, cos_a, cos_b = _pair(o, on, hp, hn, a, b)
                w = abs(cos_a) * abs(cos_b) / max(r2, r2_min)
                so = 0 if cos_a > 0 else 1
                sh = 0 if cos_b > 0 else 1
                for c in range(3):
                    e[so, a, c] += w * lr[sh, b, c]
                    out[p, sh, b, c] += w * (lf[a, c] if so == 0 else lb[a, c])
    return e, out.sum(0)


@njit(cache=True, parallel=True)
def relayed(rp, rn, kd, cos_c, rows, row_start, hp, hn, area, hs, hs_start, vis, vis_start, light, lit, r2_min):
    """The radiance (P, 3) diffuse camera points receive from relay points of radiance ``light``
    (2, H, 3) (``lit`` (H,): the relay points whose light sums above zero; the others are skipped,
    as the shadow's legs skip them), by groups with nothing blocked: ``render.shadow.SpotShadow._second_leg`` with no body
    in the way, over every group in one call. Group g pairs the camera points ``rows[row_start[g]:
    row_start[g + 1]]`` with the relay points ``hs[hs_start[g]:hs_start[g + 1]]``; ``vis`` holds each
    group's static visibility row-major from ``vis_start[g]`` (``SpotShadow._static_visibility``)."""
    out = np.zeros((rp.shape[0], 3))
    for g in prange(row_start.shape[0] - 1):
        h0, nh = hs_start[g], hs_start[g + 1] - hs_start[g]
        for i in range(row_start[g], row_start[g + 1]):
            p = rows[i]
            v0 = vis_start[g] + (i - row_start[g]) * nh
            for j in range(nh):
                if not vis[v0 + j]:
                    continue
                b = hs[h0 + j]
                if not lit[b]:
                    continue
                dx, dy, dz, r2, cos_a, cos_b = _pair(rp, rn, hp, hn, p, b)
                if cos_a * cos_c[p] <= 0:
                    continue
                w = abs(cos_a) * abs(cos_b) / max(r2, r2_min) * area[b]
                side = 0 if cos_b > 0 else 1
                for c in range(3):
                    out[p, c] += kd[p, c] / math.pi * w * light[side, b, c]
    return out


@njit(cache=True, inline="always")
def _crosses(a, i, b, j, lo, hi) -> bool:
    """The segment a[i] -> b[j] meets the box [lo, hi] (:func:`segments_cross_box`'s slab test)."""
    near, far = 0.0, 1.0
    for k in range(3):
        d = b[j, k] - a[i, k]
        if abs(d) < 1e-12:
            d = 1e-12
        t0, t1 = (lo[k] - a[i, k]) / d, (hi[k] - a[i, k]) / d
        near = max(near, min(t0, t1))
        far = min(far, max(t0, t1))
    return near <= far


@njit(cache=True, parallel=True)
def cross_groups(rp, rows, row_start, hp, hs, hs_start, vis_start, lo, hi):
    """The box test of every group's (camera point, relay point) segments at once, laid out as the
    groups' static visibility (:func:`relayed`); and (H,) whether any camera point's segment to each
    relay point crosses (each relay point belongs to one group)."""
    cross = np.zeros(vis_start[-1], np.bool_)
    any_h = np.zeros(hp.shape[0], np.bool_)
    for g in prange(row_start.shape[0] - 1):
        h0, nh = hs_start[g], hs_start[g + 1] - hs_start[g]
        for i in range(row_start[g], row_start[g + 1]):
            v0 = vis_start[g] + (i - row_start[g]) * nh
            for j in range(nh):
                if _crosses(rp, rows[i], hp, hs[h0 + j], lo, hi):
                    cross[v0 + j] = True
                    any_h[hs[h0 + j]] = True
    return cross, any_h


@njit(cache=True, inline="always")
def _leg_pair(rp, rn, cos_c, hp, hn, p, b, r2_min):
    """(carries light, w without area, side of h facing p, direction, cos) of camera point p and relay point b."""
    dx, dy, dz, r2, cos_a, cos_b = _pair(rp, rn, hp, hn, p, b)
    if cos_a * cos_c[p] <= 0:
        return False, 0.0, 0, dx, dy, dz, cos_a, cos_b
    return True, abs(cos_a) * abs(cos_b) / max(r2, r2_min), 0 if cos_b > 0 else 1, dx, dy, dz, cos_a, cos_b


@njit(cache=True, parallel=True)
def shadow_legs(rp, rn, kd, cos_c, rows, row_start, hp, hn, area, hs, hs_start, vis, vis_start, cross, l_blk,
                l_rest, blk_any, r2_min):
    """:func:`shadow_leg` over every group in one call (the layout of :func:`relayed`; ``cross`` from
    :func:`cross_groups`; ``l_blk``, ``l_rest`` (2, H, 3) and ``blk_any`` (H,) over all relay points,
    zero where nothing is blocked). Returns the same: the radiance (P, 3) of the light blocked on
    the first leg, and the body rays of the crossing pairs with their camera point and radiance."""
    n_g = row_start.shape[0] - 1
    counts = np.zeros(n_g, np.int64)
    for g in prange(n_g):
        h0, nh = hs_start[g], hs_start[g + 1] - hs_start[g]
        for i in range(row_start[g], row_start[g + 1]):
            v0 = vis_start[g] + (i - row_start[g]) * nh
            for j in range(nh):
                if cross[v0 + j] and vis[v0 + j]:
                    if _leg_pair(rp, rn, cos_c, hp, hn, rows[i], hs[h0 + j], r2_min)[0]:
                        counts[g] += 1
    first = np.zeros(n_g + 1, np.int64)
    for g in range(n_g):
        first[g + 1] = first[g] + counts[g]
    m = first[-1]
    rad = np.zeros((rp.shape[0], 3))
    org = np.empty((m, 3), np.float32)
    dirs = np.empty((m, 3), np.float32)
    length = np.empty(m, np.float32)
    row = np.empty(m, np.int32)
    lost = np.empty((m, 3))
    for g in prange(n_g):
        h0, nh = hs_start[g], hs_start[g + 1] - hs_start[g]
        k = first[g]
        for i in range(row_start[g], row_start[g + 1]):
            p = rows[i]
            v0 = vis_start[g] + (i - row_start[g]) * nh
            for j in range(nh):
                b = hs[h0 + j]
                if not (blk_any[b] or cross[v0 + j]) or not vis[v0 + j]:
                    continue
                ok, w, side, dx, dy, dz, cos_a, cos_b = _leg_pair(rp, rn, cos_c, hp, hn, p, b, r2_min)
                if not ok:
                    continue
                w *= area[b]
                for ch in range(3):
                    rad[p, ch] += kd[p, ch] / math.pi * w * l_blk[side, b, ch]
                if not cross[v0 + j]:
                    continue
                _write_ray(rp, rn, hp, hn, p, b, dx, dy, dz, np.sign(cos_a), np.sign(cos_b), org, dirs, length, k)
                row[k] = p
                for ch in range(3):
                    lost[k, ch] = kd[p, ch] / math.pi * w * l_rest[side, b, ch]
                k += 1
    return rad, org, dirs, length, row, lost


def no_keys(na: int, nb: int) -> tuple[np.ndarray, int]:
    """(akey, stride) under which every a pairs with every b (:func:`_bs`)."""
    return np.full(na, -1, np.int64), 0


@njit(cache=True)
def segments_cross_box(a, b, lo, hi):
    """(Na, Nb) bool: the segment a_i -> b_j meets the box [lo, hi]: ``render.shadow.segments_cross_box``
    (the torch reference) as one loop, the same slab test in float64 without its (Na, Nb, 3) temporaries."""
    out = np.zeros((a.shape[0], b.shape[0]), np.bool_)
    for i in range(a.shape[0]):
        for j in range(b.shape[0]):
            out[i, j] = _crosses(a, i, b, j, lo, hi)
    return out


@njit(cache=True)
def shadow_leg(rp, rn, kd, cos_c, hp, hn, area, l_blk, l_rest, blk_any, cross, vs, r2_min):
    """The diffuse second leg of ``render.shadow.SpotShadow._second_leg`` in one pass over the pairs
    (camera point p, relay point h): returns the radiance (P, 3) of the light blocked on the first
    leg, and the body rays of the pairs whose segment crosses the body's box (float32 origins,
    directions, lengths as ``rays.pair_rays``) with each one's camera point and its radiance if the
    body blocks it (M, 3): the caller adds those the body blocks. ``cross`` (P, K) the box test,
    ``vs`` (P, K) the static visibility, ``blk_any`` (K,) h with light blocked on the first leg,
    ``r2_min`` the squared distance's floor (``kernels.pair_geometry``)."""
    n_p, n_h = rp.shape[0], hp.shape[0]
    rad = np.zeros((n_p, 3))
    m = 0
    for a in range(n_p):
        for b in range(n_h):
            if cross[a, b] and vs[a, b] > 0:
                m += 1
    org = np.empty((m, 3), np.float32)
    dirs = np.empty((m, 3), np.float32)
    length = np.empty(m, np.float32)
    row = np.empty(m, np.int64)
    lost = np.empty((m, 3))
    k = 0
    for a in range(n_p):
        c = kd[a] / math.pi
        for b in range(n_h):
            if not (blk_any[b] or cross[a, b]) or vs[a, b] <= 0:
                continue
            dx, dy, dz, r2, cos_a, cos_b = _pair(rp, rn, hp, hn, a, b)
            if cos_a * cos_c[a] <= 0:
                continue
            w = abs(cos_a) * abs(cos_b) / max(r2, r2_min) * vs[a, b] * area[b]
            side = 0 if cos_b > 0 else 1  # the side of h that faces p
            for ch in range(3):
                rad[a, ch] += c[ch] * w * l_blk[side, b, ch]
            if not cross[a, b]:
                continue
            _write_ray(rp, rn, hp, hn, a, b, dx, dy, dz, np.sign(cos_a), np.sign(cos_b), org, dirs, length, k)
            row[k] = a
            for ch in range(3):
                lost[k, ch] = c[ch] * w * l_rest[side, b, ch]
            k += 1
    return rad, org[:k], dirs[:k], length[:k], row[:k], lost[:k]


def _serial_twin(f):
    """``f`` compiled without ``parallel`` (its prange a plain loop), cached under its own name."""
    py = f.py_func
    twin = types.FunctionType(py.__code__, py.__globals__, py.__name__ + "_serial", py.__defaults__, py.__closure__)
    twin.__qualname__ = py.__qualname__ + "_serial"
    return njit(cache=True)(twin)


PARALLEL = {f.py_func.__name__: f for f in (need_counts, shadow_rays, radiosity, gather_weights, gather_sparse,
                                            relay_exchange, relayed, cross_groups,
                                            shadow_legs)}
"""The loops with ``prange`` over numba's threading layer."""
SERIAL = {name: _serial_twin(f) for name, f in PARALLEL.items()}
"""The same loops on the calling thread alone: what a process told to use one thread runs (the fit's
workers), with no threading layer between its hundred-odd calls a person."""
_loops = PARALLEL


def set_threads(n: int) -> None:
    """Loop threads as torch's (a process told to use one thread keeps to one, in :data:`SERIAL`)."""
    global _loops
    n = max(1, min(n, numba.config.NUMBA_NUM_THREADS))
    _loops = SERIAL if n == 1 else PARALLEL
    numba.set_num_threads(n)


def loops() -> dict:
    """name -> compiled loop for the thread count of the last :func:`set_threads`."""
    return _loops


def group_runs(group: np.ndarray) -> np.ndarray:
    """(R + 1,) boundaries of the runs of equal values in ``group`` (one run per spot, in order)."""
    cut = np.flatnonzero(np.diff(group)) + 1
    return np.concatenate([[0], cut, [len(group)]]).astype(np.int64)


def pair_start(counts: np.ndarray) -> np.ndarray:
    """(Na + 1,) exclusive prefix sum of per-row pair counts."""
    return np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)


__all__ = ["shadow_leg", "segments_cross_box", "gather_sparse", "gather_weights", "group_runs", "need_counts", "no_keys", "pair_start", "radiosity", "relay_exchange", "relayed", "cross_groups", "shadow_legs",
           "set_threads",
           "shadow_rays"]
