"""The room's later bounces of the spot's light on the relay points: the light the body stops past
the first relay (``nlos_shadow`` at ``RenderSettings.shadow_depth`` over 4).

``nlos_shadow`` takes away the spot's light the body stops on its way to a static relay point h
(the first leg) or from h to a camera point x_p (the second): paths to Mitsuba's ``max_depth`` 4
(P -> x_s -> h -> x_p -> C). The h of a photograph hold more than that first relay: the room's own
interreflection of it, which the body stops on the second leg too. On M relay points (area A_i,
albedo rho_i = (kd + ks) / pi, two-sided: light leaves the side it came in), with L_1 the spot's
first relay (``bounce.spot_radiance``),

    I_{n+1}(j) = sum_i L_n(i) G(i, j) V_S(i, j) A_i,   L_{n+1} = rho I_{n+1},
    G = |cos_i cos_j| / max(d_ij^2, d_0^2),

and the light of the later relays up to depth D is L_tail = rho sum_{n=2}^{D-3} I_n. It is computed
once per room and spot on :data:`TAIL_POINTS` points and carried to any set of relay points by the
incoming light I of the nearest points facing the same way (interreflected light is smooth), times
their own albedo; the body stops it on the last leg, to the camera's points, as it does L_1.

The body also stops the room's light before its last leg, and what it stops there the room no
longer relays (:meth:`RoomLight.deficit`): on the transfer's points, the spot's first leg it
blocks (Delta L_1 = rho sum_s c_s B_s, with B 1 where the body meets the segment) and the light
between two points it blocks (Delta I(j) = sum_i L(i) G V_S A_i B_ij, L = L_1 + ... + L_{D-4}) are
relayed on by the room,

    Delta I_tot = sum_{m=0}^{D-6} (K)^m (K Delta L_1 + Delta I),    K: one relay (rho, then I),

carried to the relay points as above and taken from the camera's points with nothing more blocked
(``bounce.relayed_to_camera``). Left out: the body's own light on the relays (``nlos_bounce``'s)
and the body stopping a deficit again.

In the reference scenes and the scanned copy room the shadow past the first relay is not a fixed
multiple of it (Mitsuba: 0.12 of it in the diffuse corner, 0.46 in the copy room), nor the room's
power ratio (0.31 and 0.38 by this transfer): it depends on where the spot's and the room's light
come from, so it is rendered (experiments/bounce-tail).

Shapes:
    pos, normal: (M, 3); area: (M,); rho: (M, 3); light: (2, M, 3) (front, back side)
"""

from __future__ import annotations

import torch

from .kernels import pair_geometry
from .rays import pair_rays

TAIL_POINTS = 1024
"""Relay points of the room's transfer (every fourth of the shadow's 4,096; its rays are M^2): the copy room's
shadow past the first relay is 0.44 of it at 1,024 and 2,048 points, 0.46 at 512 (Mitsuba: 0.46)."""
ROWS = 256
"""Source points per block while the transfer is built (bounds the (rows, M) pair arrays)."""
NEIGHBOURS = 8
"""Transfer points an h's incoming light is interpolated from (those facing its way)."""
FACING = 0.9
"""|cos| between normals above which a transfer point faces an h's way."""


class RelayTransfer:
    """The light transfer between two-sided relay points through the static scene.

    ``occluded(origins, dirs, lengths) -> (N,) bool`` is a ray engine's occlusion query.
    """

    def __init__(self, pos: torch.Tensor, normal: torch.Tensor, area: torch.Tensor, rho: torch.Tensor,
                 occluded, r2_min: float):
        m = len(pos)
        self.pos, self.normal, self.area, self.rho = pos, normal, area, rho
        # blocks[s_out][s_in]: (M, M) weight G V A_i from side s_out of source i to side s_in of j
        self.blocks = [[torch.zeros(m, m, dtype=torch.float32) for _ in range(2)] for _ in range(2)]
        for a in range(0, m, ROWS):
            sl = slice(a, a + ROWS)
            geo = pair_geometry(pos[sl], normal[sl], pos, normal, r2_min)
            need = (geo.cos_a != 0) & (geo.cos_b != 0)
            need[torch.arange(len(need)), torch.arange(a, a + len(need))] = False
            vis = torch.zeros_like(geo.g)
            if need.any():
                vis[need] = (~torch.as_tensor(occluded(*pair_rays(pos[sl], normal[sl], pos, normal, geo.dir_ab,
                                                                  geo.cos_a, geo.cos_b, need)))).to(vis.dtype)
            w = torch.where(vis > 0, geo.g.abs() * area[sl].unsqueeze(1), 0.0).float()  # i = j: 0/0
            fa, fb = geo.cos_a > 0, geo.cos_b > 0  # the source's front faces j; j's front faces the source
            for so, ms in ((0, fa), (1, ~fa)):
                for si, mi in ((0, fb), (1, ~fb)):
                    self.blocks[so][si][sl] = w * (ms & mi)

    def incoming(self, light: torch.Tensor) -> torch.Tensor:
        """(2, M, 3) light arriving on each side of each point from ``light`` (2, M, 3) leaving them."""
        src = light.float()
        out = torch.stack([sum(self.blocks[so][si].T @ src[so] for so in (0, 1)) for si in (0, 1)])
        return out.to(light.dtype)

    def step(self, light: torch.Tensor) -> torch.Tensor:
        """(2, M, 3) radiance after one more relay of ``light``."""
        return self.incoming(light) * self.rho.unsqueeze(0)

    def power(self, light: torch.Tensor) -> float:
        return float((light.sum((0, 2)) * self.area).sum())

    def ratios(self, start: torch.Tensor, orders: int) -> list[float]:
        """The power of each further relay over the one before, from ``start``: in a closed room of
        uniform albedo every one is that albedo (the form factors out of a point sum to one)."""
        out, light = [], start
        for _ in range(orders):
            nxt = self.step(light)
            p = self.power(light)
            out.append(self.power(nxt) / p if p > 0 else 0.0)
            light = nxt
        return out


class RoomLight:
    """The incoming light of the room's later relays on :data:`TAIL_POINTS` points, carried to any
    relay point by its nearest transfer points facing its way (inverse-distance weights)."""

    def __init__(self, pos: torch.Tensor, normal: torch.Tensor, incoming: torch.Tensor,
                 transfer: "RelayTransfer | None" = None, leaving: torch.Tensor | None = None,
                 first: torch.Tensor | None = None, first_need: torch.Tensor | None = None, depth: int = 10):
        """``incoming`` (2, M, 3) the later relays' light arriving at the points; for
        :meth:`deficit`: the ``transfer``, the light ``leaving`` the points (2, M, 3), the spot's
        first leg to them per source ``first`` (2, S, M, 3) and which of those legs carry light
        ``first_need`` (S, M)."""
        from scipy.spatial import cKDTree

        self.pos, self.normal, self.incoming = pos, normal, incoming
        self.transfer, self.leaving, self.first, self.first_need = transfer, leaving, first, first_need
        self.depth = depth
        self.tree = cKDTree(pos.numpy())

    def deficit(self, blocks, lo: torch.Tensor, hi: torch.Tensor, src_pos: torch.Tensor,
                src_normal: torch.Tensor) -> torch.Tensor:
        """(2, M, 3) incoming light the room no longer relays to its points because the body (``blocks(pa,
        na, pb, nb, sel) -> (Na, Nb)`` 1 where it meets a segment, box [lo, hi]) stops the spot's first
        leg or a leg between two of them (module docstring), relayed on to ``depth``."""
        from .shadow import cross_box

        tr, pos, normal = self.transfer, self.pos, self.normal
        sel = self.first_need & cross_box(src_pos, pos, lo, hi)
        lost1 = torch.zeros_like(self.leaving)
        if sel.any():
            b1 = blocks(src_pos, src_normal, pos, normal, sel).to(self.first.dtype)  # (S, M)
            lost1 = (self.first * b1.unsqueeze(0).unsqueeze(-1)).sum(1) * tr.rho.unsqueeze(0)
        inc = tr.incoming(lost1)
        cross = cross_box(pos, pos, lo, hi)
        cross.fill_diagonal_(False)
        if cross.any():
            i, j = torch.nonzero(blocks(pos, normal, pos, normal, cross) > 0, as_tuple=True)  # legs it stops
            for so in (0, 1):
                for si in (0, 1):
                    w = tr.blocks[so][si][i, j].to(inc.dtype).unsqueeze(-1)
                    inc[si].index_add_(0, j, w * self.leaving[so][i])
        total = inc.clone()
        for _ in range(self.depth - 6):
            inc = tr.incoming(inc * tr.rho.unsqueeze(0))
            total += inc
        return total

    def at(self, pos: torch.Tensor, normal: torch.Tensor, rho: torch.Tensor,
           incoming: torch.Tensor | None = None) -> torch.Tensor:
        """(2, N, 3) radiance the later relays (or ``incoming`` (2, M, 3) light on the transfer's
        points) leave on N points of albedo ``rho`` / pi."""
        dist, idx = self.tree.query(pos.detach().cpu().numpy(), min(NEIGHBOURS, self.tree.n))
        dist, idx = torch.as_tensor(dist, dtype=rho.dtype), torch.as_tensor(idx)
        cos = (normal.detach().cpu().unsqueeze(1) * self.normal[idx].to(rho.dtype)).sum(-1)  # (N, k)
        w = (cos.abs() > FACING).to(rho.dtype) / dist.clamp(min=1e-6)
        alone = w.sum(1) == 0  # nothing faces its way nearby: the nearest point alone
        w[alone, 0] = 1.0
        w = w / w.sum(1, keepdim=True)
        inc = (self.incoming if incoming is None else incoming).to(rho.dtype)[:, idx]  # (2, N, k, 3), its own sides
        same = (cos >= 0).unsqueeze(-1)  # a point facing the other way sees its sides swapped
        front = torch.where(same, inc[0], inc[1])
        back = torch.where(same, inc[1], inc[0])
        out = torch.stack([(front * w.unsqueeze(-1)).sum(1), (back * w.unsqueeze(-1)).sum(1)])
        return out.to(rho.device) * rho.unsqueeze(0)


def room_light(shadow, y: torch.Tensor, depth: int, points: int = TAIL_POINTS) -> RoomLight:
    """The later relays (depth 5 to ``depth``) of spot vector ``y``'s light, on ``points`` of a
    ``SpotShadow``'s relay points (every k-th: still stratified over the static area)."""
    from .bounce import NEAR_FIELD, spot_radiance

    n = len(shadow.h["pos"])
    k = max(1, n // points)
    idx = torch.arange(0, n, k, device=shadow.area.device)
    area = (shadow.area[idx] * k).cpu()  # each kept point stands for k strata
    pos, normal = shadow.h["pos"][idx].cpu(), shadow.h["normal"][idx].cpu()
    tr = RelayTransfer(pos, normal, area, shadow.rho[idx].cpu(), shadow.r.rays.occluded_rays,
                       NEAR_FIELD ** 2 * float(area.mean()))
    light = spot_radiance(shadow, y)[:, idx].cpu()
    total, leaving = torch.zeros_like(light), torch.zeros_like(light)
    for _ in range(depth - 4):  # I_2 ... I_{depth-3}; L_1 ... L_{depth-4} leave the points
        leaving += light
        inc = tr.incoming(light)
        total += inc
        light = inc * tr.rho.unsqueeze(0)
    src, lit = shadow.spot_sources(y)  # the spot's first leg to each point, per source, both sides
    geo = pair_geometry(src["pos"], src["normal"], shadow.h["pos"][idx], shadow.h["normal"][idx])
    need = geo.cos_a * lit > 0
    vs = shadow.r._visible(shadow.r.rays, src["pos"], src["normal"], shadow.h["pos"][idx], shadow.h["normal"][idx],
                           need, geo)
    c = shadow.first_leg(src, geo.dir_ab, geo.g * vs)  # (S, M, 3)
    front = (geo.cos_b > 0).to(c.dtype).unsqueeze(-1)
    first = torch.stack([c * front, c * (1 - front)]).cpu()  # (2, S, M, 3)
    return RoomLight(pos, normal, total, tr, leaving, first, need.cpu(), depth)


__all__ = ["RelayTransfer", "RoomLight", "TAIL_POINTS", "room_light"]
