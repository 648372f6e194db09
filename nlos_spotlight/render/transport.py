"""The light-transport renderer (DESIGN section 5).

``image(y) = D y + A (B (E y)) + ambient + nlos_ambient``

* ``E``: per candidate spot t, K projector rays inside the cutoff cone land on
  LOS samples x_s carrying flux I f(theta) dOmega (see :mod:`.spot`).
* ``D``: direct image per candidate, from the exact spot irradiance at every
  camera sub-sample, with projector visibility.
* ``B``: LOS samples -> outgoing radiance of each person sample (two sides).
* ``A``: person samples -> camera sub-samples -> pixel means.

Everything after the ray casts is torch, so the images are exactly linear in
y and differentiable with respect to y and the person's translation (the
visibility masks are held fixed, as in any renderer without edge sampling).
Visibility is Embree: static geometry plus the posed body, so limbs occlude
too. The person is assumed outside the camera's and the projector's direct
view (the NLOS setting): it shapes the ``nlos`` and ``nlos_ambient`` terms only, and, on
request, ``nlos_shadow``: the spot light it blocks on one static bounce (:mod:`.shadow`), which a
photograph with the person minus one without also holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch

from ..errors import NlosError
from ..scene.format import Scene
from .brdf import brdf
from .fused import pair_kernels
from .camera import pixel_rays
from .kernels import pair_geometry
from . import pair_loops
from .person import Person, as_translation
from .rays import RayEngine, SceneRays, occlusion_engine, pair_rays
from .spot import cone_directions, spot_profile
from .settings import RENDER_PRESETS, RenderSettings  # noqa: F401  (re-exported beside the renderer)
from .surface import StaticSurfaces, SurfacePoints

RELAY_SETS_KEPT = 16
"""Sets of relay points (``nlos_shadow``, one per strata offset) a renderer keeps with their cached visibility."""
INTER_CACHE_SPOTS = 8
"""Largest support of y whose interreflection is read from the per-candidate images."""
INTER_CACHE_SIZE = 256
"""Candidates' interreflection images kept per renderer (48 kB each at 64 x 64)."""
FOOTPRINT_LOOP_CHUNK = 16384
"""Camera sub-samples per block of the footprint-sampled gather in the compiled loops (its memory
is a few rays a sub-sample, so blocks can be large: one ray call each)."""
COMPONENTS = ("direct", "interreflection", "ambient", "nlos", "nlos_ambient", "nlos_shadow", "nlos_bounce")
DEFAULT_COMPONENTS = ("direct", "ambient", "nlos", "nlos_ambient")


@dataclass
class RenderOutput:
    """Images per component, each (H, W, 3) or (B, H, W, 3) for a batch of people."""

    components: dict[str, torch.Tensor] = field(default_factory=dict)
    """Component name -> linear radiance, W sr^-1 m^-2."""

    @property
    def image(self) -> torch.Tensor:
        """Sum of the rendered components."""
        return sum(self.components.values())

    def __getitem__(self, name: str) -> torch.Tensor:
        return self.components[name]


@dataclass
class _Receivers:
    """Camera sub-sample hits as torch tensors."""

    pts: dict
    to_cam: torch.Tensor
    pixel: torch.Tensor
    n_sub: int
    glossy: torch.Tensor
    surf: SurfacePoints
    key: torch.Tensor | None = None
    """(P,) int64 slot of each sub-sample among its pixel's ``n_sub`` (footprint sampling), else None."""

    def share(self, n: int, device) -> torch.Tensor:
        """(n,) the slot each of n sources (body samples, static points) is shared out to: every
        ``n_sub``-th source to the same sub-sample of each pixel (a thinned copy of the sources)."""
        return torch.arange(n, device=device) % self.n_sub

    def scale(self, per_sample: torch.Tensor) -> torch.Tensor:
        """Footprint sampling: a sub-sample saw 1 / ``n_sub`` of the sources, so it counts ``n_sub`` times."""
        return per_sample * self.n_sub if self.key is not None else per_sample


class Renderer:
    """Per-scene precompute and per-person rendering.

    Args:
        scene: the scene.
        settings: sampling settings.
        aim_points: (T, 3) candidate spot targets; default the static faces' centroids.
    """

    def __init__(self, scene: Scene, settings: RenderSettings | None = None, aim_points: np.ndarray | None = None):
        self.scene = scene
        self.settings = s = settings or RenderSettings()
        self.device = torch.device("cuda" if s.device == "auto" and torch.cuda.is_available()
                                   else ("cpu" if s.device == "auto" else s.device))
        self.dtype = getattr(torch, s.dtype)
        self.kernels = pair_kernels(s.fuse)
        self.static = StaticSurfaces(scene)
        self.rays = occlusion_engine(self.static.engine, s.rays, self.device.type)  # per-person visibility
        self.aim_points = self.static.mesh.centroids() if aim_points is None else np.atleast_2d(aim_points)
        self.num_spots = len(self.aim_points)
        cam = scene.camera
        self.shape = (cam.height, cam.width)
        self.recv = self._receivers(s.pixel_samples)
        self._draw = None  # the footprint draw of ``recv_t`` (``use_footprint``)
        if s.pixel_footprint > 0:
            self.recv_t = self._receivers(s.pixel_footprint, footprint=True)
            self._footprints = {None: self.recv_t}
        else:
            self.recv_t = self.recv if s.transport_pixel_samples == s.pixel_samples \
                else self._receivers(s.transport_pixel_samples)
        self._spot_samples()
        self.D = self._direct_matrix()
        self.ambient_image = self._ambient()
        self._inter_cache: dict[int, torch.Tensor] = {}  # candidate -> its interreflection image
        self._spot_shadows: dict = {}  # (relay offset, footprint draw) -> its ``SpotShadow`` (relay points, cached visibility)
        self._room_light: dict = {}  # spot vector -> the room's later relays of its light (``render/tail.py``)

    # ---------------------------------------------------------------- precompute
    def _t(self, x) -> torch.Tensor:
        return torch.as_tensor(x, device=self.device, dtype=self.dtype)

    def _receivers(self, n: int, footprint: bool = False, draw: int | None = None) -> _Receivers:
        """Camera sub-samples, n x n a pixel; ``footprint``: with the slots of footprint sampling,
        each pixel's turned by a random offset so that neighbouring pixels pair their sub-samples
        with different thinned sources, and (``footprint_jitter``) the sub-samples jittered in their
        cells; both drawn from ``footprint_seed`` and ``draw`` (None: the renderer's fixed set)."""
        jitter, turn = None, None
        if footprint:
            s, cells = self.settings, self.shape[0] * self.shape[1]
            rng = np.random.default_rng(s.footprint_seed if draw is None else [s.footprint_seed, draw])
            turn = rng.integers(n * n, size=cells)
            if s.footprint_jitter:
                jitter = rng.random((*self.shape, n, n, 2))
        dirs, origin = pixel_rays(self.scene.camera, n, jitter)
        flat = dirs.reshape(-1, 3)
        hit, surf = self.static.trace(np.broadcast_to(origin, flat.shape), flat)
        if not hit.any():
            raise NlosError("camera: sees no geometry (check position, look_at and fov_deg)")
        index = np.flatnonzero(hit)
        pixel = index // (n * n)
        to_cam = -flat[hit]
        key = None
        if footprint:
            key = torch.as_tensor((index % (n * n) + turn[pixel]) % (n * n), device=self.device)
        return _Receivers(surf.torch(self.device, self.dtype), self._t(to_cam),
                          torch.as_tensor(pixel, device=self.device), n * n, torch.as_tensor(surf.glossy, device=self.device),
                          surf, key)

    def use_footprint(self, draw: int | None) -> None:
        """Make footprint draw ``draw`` the person terms' camera sub-samples (None: the fixed set of
        ``footprint_seed``); each draw's sub-samples are traced once and kept (a few at a time).
        Without footprint sampling there is one set and ``draw`` changes nothing."""
        if self.settings.pixel_footprint <= 0 or draw == self._draw:
            return
        if draw not in self._footprints:
            if len(self._footprints) >= RELAY_SETS_KEPT + 1:
                self._footprints.pop(next(k for k in self._footprints if k is not None))  # the oldest draw
            self._footprints[draw] = self._receivers(self.settings.pixel_footprint, footprint=True, draw=draw)
        self.recv_t, self._draw = self._footprints[draw], draw

    def _spot_samples(self) -> None:
        """LOS samples x_s of every candidate: where the projector's rays land, and their flux."""
        pr = self.scene.projector
        k = self.settings.spot_samples
        dirs, owner, flux = [], [], []
        for t, aim in enumerate(self.aim_points):
            d, theta, domega = cone_directions(aim - pr.position, pr.cutoff_deg, k)
            prof = spot_profile(theta, pr.beam_width_deg, pr.cutoff_deg)
            keep = prof > 0
            dirs.append(d[keep])
            owner.append(np.full(keep.sum(), t))
            flux.append(pr.intensity[None, :] * (prof[keep] * domega)[:, None])
        dirs, owner, flux = np.concatenate(dirs), np.concatenate(owner), np.concatenate(flux)
        hit, surf = self.static.trace(np.broadcast_to(pr.position, dirs.shape), dirs)
        self.spot_surf = surf
        self.spot_pts = surf.torch(self.device, self.dtype)
        self.spot_owner = torch.as_tensor(owner[hit], device=self.device)
        self.spot_flux = self._t(flux[hit])
        to_p = pr.position - surf.pos
        self.spot_to_proj = self._t(to_p / np.linalg.norm(to_p, axis=1, keepdims=True))
        self.spot_glossy = torch.as_tensor(surf.glossy, device=self.device)
        self.spot_landed = np.bincount(owner[hit], minlength=self.num_spots) > 0
        if not self.spot_landed.any():
            raise NlosError("projector: aimed at nothing (no projector ray reaches a surface)")

    def _direct_matrix(self) -> torch.Tensor:
        """D: (H*W, T, 3) direct image per unit of each candidate spot."""
        pr, r = self.scene.projector, self.recv
        p = r.surf.pos
        vis = ~self.static.engine.occluded(np.broadcast_to(pr.position, p.shape).copy(), p, None, r.surf.normal)
        d = pr.position - p
        dist2 = (d * d).sum(1)
        wi = self._t(d / np.sqrt(dist2)[:, None])
        f = brdf(r.pts["normal"], wi, r.to_cam, r.pts["kd"], r.pts["ks"], r.pts["alpha"])
        cos = (r.pts["normal"] * wi).sum(-1).abs()
        g = f * (cos * self._t(vis / dist2)).unsqueeze(-1) * self._t(pr.intensity)
        axes = self.aim_points - pr.position
        axes = self._t(axes / np.linalg.norm(axes, axis=1, keepdims=True))
        D = torch.zeros(self.shape[0] * self.shape[1], self.num_spots, 3, device=self.device, dtype=self.dtype)
        for s in range(0, self.num_spots, 64):
            cos_t = ((-wi) @ axes[s:s + 64].T).clamp(-1, 1)
            prof = spot_profile(torch.arccos(cos_t), pr.beam_width_deg, pr.cutoff_deg)
            D[:, s:s + 64].index_add_(0, r.pixel, g.unsqueeze(1) * prof.unsqueeze(-1) / r.n_sub)
        return D

    def _ambient(self) -> torch.Tensor:
        r, amb = self.recv, self.scene.ambient
        rad = self._t(amb.radiance if amb is not None else np.zeros(3))
        per = (r.pts["kd"] + r.pts["ks"]) * rad + r.pts["emission"]
        return self._pixels(per, r)

    def _pixels(self, per_sample: torch.Tensor, r: _Receivers) -> torch.Tensor:
        out = torch.zeros(self.shape[0] * self.shape[1], per_sample.shape[-1], device=self.device, dtype=self.dtype)
        out.index_add_(0, r.pixel, per_sample / r.n_sub)
        return out.reshape(*self.shape, -1)

    # ---------------------------------------------------------------- rendering
    def spot_vector(self, index: int) -> torch.Tensor:
        """One-hot y for candidate ``index``."""
        y = torch.zeros(self.num_spots, device=self.device, dtype=self.dtype)
        y[index] = 1
        return y

    def render(self, y: torch.Tensor, person: Person | None = None, translation=None,
               components=DEFAULT_COMPONENTS, relay_offset: float | None = None,
               footprint_draw: int | None = None) -> RenderOutput:
        """Render the requested components.

        Args:
            y: (T,) spot vector (one-hot or a distribution over candidates).
            person: the sampled body, or None for the empty scene.
            translation: None, (2|3,) or (B, 2|3) offsets of the body (floor x, y [, z]); a batch
                dimension B makes every image (B, H, W, 3).
            components: names from :data:`COMPONENTS`.
            relay_offset: the strata offset of ``nlos_shadow``'s relay points for this call
                (``RenderSettings.relay_offset`` if None).
            footprint_draw: the person terms' footprint sub-samples for this call and later ones
                (:meth:`use_footprint`; None: the fixed set).
        """
        unknown = set(components) - set(COMPONENTS)
        if unknown:
            raise ValueError(f"unknown component(s): {', '.join(sorted(unknown))}")
        y = torch.as_tensor(y, device=self.device, dtype=self.dtype)
        if y.shape != (self.num_spots,):
            raise ValueError(f"spot vector: expected shape ({self.num_spots},), got {tuple(y.shape)}")
        batched = translation is not None and torch.as_tensor(translation).dim() == 2
        self.use_footprint(footprint_draw)
        out = RenderOutput()
        if "direct" in components:
            out.components["direct"] = self._direct(y)
        if "interreflection" in components:
            out.components["interreflection"] = self._interreflection(y)
        if "ambient" in components:
            out.components["ambient"] = self.ambient_image
        if "nlos_shadow" in components:
            out.components["nlos_shadow"] = self._relayed(y, person, translation, relay_offset, "image")
        if "nlos_bounce" in components:
            out.components["nlos_bounce"] = self._relayed(y, person, translation, relay_offset, "bounce")
        want = [c for c in ("nlos", "nlos_ambient") if c in components]
        if want:
            per = self._person_terms(y, person, translation, want)
            out.components.update(per)
        if batched:
            b = torch.as_tensor(translation).shape[0]
            for k, v in out.components.items():
                if v.dim() == 3:
                    out.components[k] = v.unsqueeze(0).expand(b, -1, -1, -1)
        return out

    def _translations(self, translation) -> tuple[torch.Tensor, bool]:
        """(B, 3) body offsets (B = 1 unless ``translation`` is a (B, 2|3) batch) and whether it is one."""
        batched = translation is not None and torch.as_tensor(translation).dim() == 2
        b = torch.as_tensor(translation).shape[0] if batched else 1
        return as_translation(translation, b, self.device, self.dtype), batched

    def _direct(self, y: torch.Tensor) -> torch.Tensor:
        """D y as (H, W, 3); without a gradient, over y's support only (a one-hot y reads one column)."""
        if y.requires_grad:
            return torch.einsum("ptc,t->pc", self.D, y).reshape(*self.shape, 3)
        sup = torch.nonzero(y).flatten()
        return torch.einsum("ptc,t->pc", self.D[:, sup], y[sup]).reshape(*self.shape, 3)

    def _relayed(self, y: torch.Tensor, person: Person | None, translation, offset: float | None,
                 term: str) -> torch.Tensor:
        """A term through the static relay points of strata ``offset`` (one ``SpotShadow`` a set,
        kept): ``image``, ``nlos_shadow``, the spot light the body blocks (``render/shadow.py``), or
        ``bounce``, ``nlos_bounce``, the person's light over one more static bounce
        (``render/bounce.py``)."""
        if person is None:
            return torch.zeros(*self.shape, 3, device=self.device, dtype=self.dtype)
        from .shadow import SpotShadow

        offset = float(self.settings.relay_offset if offset is None else offset)
        if not 0 <= offset < 1:
            raise ValueError(f"relay_offset: expected a number in [0, 1), got {offset}")
        cache, key = self._spot_shadows, (offset, self._draw)  # its camera points are the footprint draw's
        if key not in cache:
            if len(cache) >= RELAY_SETS_KEPT:
                cache.pop(next(iter(cache)))  # the oldest set
            cache[key] = SpotShadow(self, offset)
        t, batched = self._translations(translation)
        imgs = [getattr(cache[key], term)(y, person, tb) for tb in t]
        return torch.stack(imgs) if batched else imgs[0]

    def _active(self, y: torch.Tensor) -> torch.Tensor:
        """Indices of spot samples whose candidate matters: all if y needs a gradient, else y's support."""
        if y.requires_grad:
            return torch.arange(len(self.spot_owner), device=self.device)
        return torch.nonzero(y[self.spot_owner] != 0).flatten()

    def _interreflection(self, y: torch.Tensor) -> torch.Tensor:
        """One LOS-LOS bounce: P -> x_s -> x_p -> C, as sum_t y_t I_t over y's support.

        The image I_t of each candidate is computed on its first use and kept (a static term, like
        the columns of D, but too costly to compute for every candidate up front: tens of ms a
        spot), since a spot stays fixed while people move. A y with a gradient or with more than
        :data:`INTER_CACHE_SPOTS` candidates is summed directly instead.
        """
        sup = torch.nonzero(y).flatten()
        if y.requires_grad or len(sup) > INTER_CACHE_SPOTS:
            return self._interreflection_sum(y)
        cache = self._inter_cache
        for t in sup.tolist():
            if t not in cache:
                if len(cache) >= INTER_CACHE_SIZE:
                    cache.pop(next(iter(cache)))  # the oldest
                cache[t] = self._interreflection_sum(self.spot_vector(t))
        out = torch.zeros(*self.shape, 3, device=self.device, dtype=self.dtype)
        for t in sup.tolist():
            out = out + y[t] * cache[t]
        return out

    def _interreflection_sum(self, y: torch.Tensor) -> torch.Tensor:
        """:meth:`_interreflection` summed over y's active spot samples (differentiable in y)."""
        idx = self._active(y)
        r = self.recv_t  # a per-spot pair sum like the person terms: same sub-sample budget
        src = {k: v[idx] for k, v in self.spot_pts.items()}
        w = self.spot_flux[idx] * y[self.spot_owner[idx]].unsqueeze(-1)
        out = torch.zeros(len(r.pixel), 3, device=self.device, dtype=self.dtype)
        for a in range(0, len(r.pixel), self.settings.chunk):
            sl = slice(a, a + self.settings.chunk)
            geo = pair_geometry(src["pos"], src["normal"], r.pts["pos"][sl], r.pts["normal"][sl])
            lit = (src["normal"] * self.spot_to_proj[idx]).sum(-1, keepdim=True)
            seen = (r.pts["normal"][sl] * r.to_cam[sl]).sum(-1)
            need = (geo.cos_a * lit > 0) & (geo.cos_b * seen > 0)
            vis = self._visible(self.rays, src["pos"], src["normal"], r.pts["pos"][sl],
                                r.pts["normal"][sl], need, geo)
            f_src = brdf(src["normal"].unsqueeze(1), self.spot_to_proj[idx].unsqueeze(1), geo.dir_ab,
                         src["kd"].unsqueeze(1), src["ks"].unsqueeze(1), src["alpha"].unsqueeze(1))
            f_rec = brdf(r.pts["normal"][sl].unsqueeze(0), -geo.dir_ab, r.to_cam[sl].unsqueeze(0),
                         r.pts["kd"][sl].unsqueeze(0), r.pts["ks"][sl].unsqueeze(0), r.pts["alpha"][sl].unsqueeze(0))
            out[sl] = (f_src * f_rec * (geo.g * vis).unsqueeze(-1) * w.unsqueeze(1)).sum(0)
        return self._pixels(out, r)

    def _visible(self, rays, pa, na, pb, nb, need: torch.Tensor, geo=None) -> torch.Tensor:
        """(Na, Nb) 0/1 mutual visibility (held fixed under autograd); rays only for ``need`` pairs.

        Pairs whose transport weight is zero anyway (light on the wrong side of a surface, or the
        inside of a closed body) are left at 0 without casting a ray. ``geo``: the pairs' geometry
        if already computed (else the rays are built from the points).
        """
        vis = torch.zeros(need.shape, device=self.device, dtype=self.dtype)
        if need.any():
            dirs = (geo.dir_ab, geo.cos_a, geo.cos_b) if geo is not None else (None, None, None)
            occ = rays.occluded_rays(*pair_rays(pa, na, pb, nb, *dirs, need))
            vis[need] = self._t(~occ)
        return vis

    def body_rays(self, vertices: np.ndarray, faces: np.ndarray):
        """An occlusion engine over a body alone for small batches of rays (``nlos_shadow``'s body
        tests): embreex on a CPU, where Dr.Jit's cost per call outweighs its speed per ray on such small
        batches; the renderer's engine on a GPU."""
        if self.rays is self.static.engine or self.device.type == "cpu":
            return RayEngine(vertices, faces)
        from .rays_drjit import DrJitRays

        return DrJitRays(vertices, faces, self.rays.device, self.rays.threads)

    def _loops(self, *tensors) -> bool:
        """Sum pairs in compiled loops: CPU, enabled, and no gradient asked of these tensors."""
        return self.settings.pair_loops and self.device.type == "cpu" and not (
            torch.is_grad_enabled() and any(t.requires_grad for t in tensors))

    def _loop_pairs(self, pa, na, front, o, nb, closed: bool, rays: SceneRays, keys=None):
        """(start, body index, visible) of the pairs that carry light, a-major (``pair_loops``);
        ``keys`` (a's slots, n): a pairs only with the b shared out to its slot (footprint sampling)."""
        pair_loops.set_threads(torch.get_num_threads())
        keys = pair_loops.no_keys(len(pa), len(o)) if keys is None else (keys[0].cpu().numpy(), int(keys[1]))
        args = [x.detach().numpy() for x in (pa, na, front.reshape(-1), o, nb)] + [bool(closed), *keys]
        start = pair_loops.pair_start(pair_loops.loops()["need_counts"](*args))
        org, dirs, length, idx = pair_loops.loops()["shadow_rays"](*args, start)
        return start, idx, ~rays.occluded_rays(org, dirs, length)

    def _radiosity_loops(self, src, to_proj, lit, glossy: bool, w, group, groups, o, pts, person, rays):
        """``fused.radiosity`` of the spot samples ``src`` over the unblocked pairs only."""
        start, idx, vis = self._loop_pairs(src["pos"], src["normal"], lit, o, pts["normal"], person.closed, rays)
        g = group.numpy()
        np_ = {k: src[k].detach().numpy() for k in ("pos", "normal", "kd", "ks", "alpha")}
        f, b = pair_loops.loops()["radiosity"](np_["pos"], np_["normal"], to_proj.numpy(), np_["kd"], np_["ks"], np_["alpha"],
                                    glossy, w.detach().numpy(), pair_loops.group_runs(g), g, o.detach().numpy(),
                                    pts["normal"].numpy(), start, idx, vis, groups)
        return self._t(f), self._t(b)

    def _gather_loops(self, sl, cos_c, o, pts, person, rays, front, back) -> torch.Tensor:
        """One block of sub-samples of :meth:`_gather` over the unblocked pairs only: (P, C) radiance."""
        r = self.recv_t
        rp, rn = r.pts["pos"][sl], r.pts["normal"][sl]
        keys = None if r.key is None else (r.key[sl], r.n_sub)  # b shared to slot k: k, k + n_sub, ... (``share``)
        start, idx, vis = self._loop_pairs(rp, rn, cos_c, o, pts["normal"], person.closed, rays, keys)
        if keys is not None:  # footprint sampling: few pairs a sub-sample, summed without dense weights
            np_ = lambda x: x.detach().numpy()
            rad = pair_loops.loops()["gather_sparse"](np_(rp), np_(rn), np_(r.to_cam[sl]), np_(cos_c.reshape(-1)),
                                           np_(r.pts["kd"][sl]), np_(r.pts["ks"][sl]), np_(r.pts["alpha"][sl]),
                                           np_(r.glossy[sl]), np_(o), np_(pts["normal"]), np_(pts["area"]), start, idx,
                                           vis, np_(front), np_(back))
            return self._t(rad)
        gl = r.glossy[sl].numpy()
        gl_row = np.where(gl, np.cumsum(gl) - 1, -1)
        wf, wb, sf, sb, backs = pair_loops.loops()["gather_weights"](
            rp.numpy(), rn.numpy(), r.to_cam[sl].numpy(), cos_c.reshape(-1).numpy(), r.pts["alpha"][sl].numpy(),
            gl_row, int(gl.sum()), o.detach().numpy(), pts["normal"].numpy(), pts["area"].numpy(), start, idx, vis)
        wf, sf = torch.from_numpy(wf), torch.from_numpy(sf)
        rad = wf @ front + torch.from_numpy(wb) @ back if backs else wf @ front  # a closed body: no back light
        rad = r.pts["kd"][sl].repeat(1, front.shape[1] // 3) / math.pi * rad
        if len(sf):
            spec = sf @ front + torch.from_numpy(sb) @ back if backs else sf @ front
            rad[torch.from_numpy(gl)] += r.pts["ks"][sl][torch.from_numpy(gl)].repeat(1, front.shape[1] // 3) * spec
        return rad

    def _person_terms(self, y, person, translation, want) -> dict[str, torch.Tensor]:
        if person is None:
            zero = torch.zeros(*self.shape, 3, device=self.device, dtype=self.dtype)
            return {c: zero for c in want}
        t, batched = self._translations(translation)
        amb = self.scene.ambient
        hidden = self._t(amb.hidden_radiance if amb is not None else np.zeros(3))
        pts = {k: self._t(getattr(person, k)) for k in ("pos", "normal", "area", "albedo")}
        res = {c: [] for c in want}
        for b in range(len(t)):
            img = self._one_person(y, person, pts, t[b], hidden, want)
            for c in want:
                res[c].append(img[c])
        return {c: torch.stack(v) if batched else v[0] for c, v in res.items()}

    def _one_person(self, y, person: Person, pts, t, hidden, want) -> dict[str, torch.Tensor]:
        t_np = t.detach().cpu().numpy().astype(np.float64)
        rays = SceneRays(self.rays, person.translated_mesh(t_np))
        o = pts["pos"] + t
        radiance = []
        if "nlos" in want:
            lf, lb = self._person_radiosity(y, person, pts, o, rays)
            radiance.append((lf, lb))
        if "nlos_ambient" in want:
            own = (pts["albedo"] - 1) * hidden
            radiance.append((own, own))
        front = torch.cat([r[0] for r in radiance], dim=1)
        back = torch.cat([r[1] for r in radiance], dim=1)
        img = self._gather(person, pts, o, rays, front, back)
        return {c: img[..., 3 * i:3 * i + 3] for i, c in enumerate(want)}

    def _person_radiosity(self, y, person: Person, pts, o, rays: SceneRays, per_spot: bool = False,
                          spots: torch.Tensor | None = None):
        """B (E y): outgoing radiance of each body sample on its front and back side.

        Returns two (N, 3) tensors, or with ``per_spot`` two (N, 3 K) tensors holding one RGB triple
        per candidate (the columns of B E, y ignored): all T candidates, or only the K candidates
        ``spots`` (in that order), whose spot samples alone are then traced.
        """
        if per_spot and spots is not None:
            slot = torch.full((self.num_spots,), -1, dtype=torch.long, device=self.device)
            slot[spots] = torch.arange(len(spots), device=self.device)
            owner = slot[self.spot_owner]  # (S,) the spot sample's column, -1 for candidates not asked for
            idx = torch.nonzero(owner >= 0).flatten()
            groups = len(spots)
        else:
            owner = self.spot_owner
            idx = torch.arange(len(self.spot_owner), device=self.device) if per_spot else self._active(y)
            groups = self.num_spots if per_spot else 1
        lf = torch.zeros(groups, len(o), 3, device=self.device, dtype=self.dtype)
        lb = torch.zeros_like(lf)
        glossy = self.spot_glossy[idx]
        # diffuse spot samples skip the GGX lobe: exact (ks = 0) and most of the pair work
        for ii in (c for part in (idx[~glossy], idx[glossy]) if len(part)
                   for c in torch.split(part, self.settings.chunk)):
            gl = bool(self.spot_glossy[ii[0]])
            src = {k: v[ii] for k, v in self.spot_pts.items()}
            w = self.spot_flux[ii] if per_spot else self.spot_flux[ii] * y[self.spot_owner[ii]].unsqueeze(-1)
            lit = (src["normal"] * self.spot_to_proj[ii]).sum(-1, keepdim=True)
            group = owner[ii] if per_spot else torch.zeros_like(ii)
            if self._loops(w, o):
                f, b = self._radiosity_loops(src, self.spot_to_proj[ii], lit, gl, w, group, groups, o, pts, person, rays)
                lf, lb = lf + f, lb + b
                continue
            need = self.kernels("pair_need", src["pos"], src["normal"], lit, o, pts["normal"], person.closed)
            vis = self._visible(rays, src["pos"], src["normal"], o, pts["normal"], need)
            f, b = self.kernels("radiosity", src["pos"], src["normal"], self.spot_to_proj[ii], src["kd"],
                                src["ks"] if gl else None, src["alpha"] if gl else None, o, pts["normal"], vis, w,
                                group, groups)
            lf, lb = lf + f, lb + b
        scale = (pts["albedo"] / math.pi).unsqueeze(1)  # (N, 1, 3)
        lf, lb = lf.transpose(0, 1) * scale, lb.transpose(0, 1) * scale  # (N, groups, 3)
        return lf.reshape(len(o), -1), lb.reshape(len(o), -1)

    def transport_images(self, person: Person, translation=None, spots=None, also: tuple = (),
                         nlos_ambient: bool = False, footprint_draw: int | None = None) -> torch.Tensor:
        """The ``nlos`` image of every candidate spot for one body placement, (T, H, W, 3).

        These are the columns of the light transport matrix F (paper Eq. (1)): for any spot vector
        y, ``nlos(y) = einsum('thwc,t->hwc', F, y)``. The person -> pixel transport A is shared by
        all candidates, so all T images cost little more than one. ``spots`` (K,) candidate
        indices: only those columns, (K, H, W, 3), tracing only their projector rays.

        ``also``: renderers of the same geometry and camera under other emitters (e.g. the flash),
        whose every candidate's column follows this renderer's; ``nlos_ambient``: the
        ``nlos_ambient`` image last. All of them share the one person -> pixel pass (the costly
        visibility): (K + sum of their T [+ 1], H, W, 3). ``footprint_draw``: as in :meth:`render`,
        for this renderer and ``also``.
        """
        for r in (self, *also):
            r.use_footprint(footprint_draw)
        for other in also:
            if other.shape != self.shape or not torch.equal(other.recv_t.pts["pos"], self.recv_t.pts["pos"]):
                raise ValueError("transport_images: 'also' renderers must share this one's camera receivers")
        if spots is not None:
            spots = torch.as_tensor(np.asarray(spots, np.int64), device=self.device)
            if spots.dim() != 1 or len(spots) == 0 or int(spots.min()) < 0 or int(spots.max()) >= self.num_spots \
                    or len(torch.unique(spots)) != len(spots):
                raise ValueError(f"spots: expected distinct candidate indices in 0..{self.num_spots - 1}")
        t = as_translation(translation, 1, self.device, self.dtype)[0]
        pts = {k: self._t(getattr(person, k)) for k in ("pos", "normal", "area", "albedo")}
        rays = SceneRays(self.rays, person.translated_mesh(t.detach().cpu().numpy()))
        o = pts["pos"] + t
        lf, lb = self._person_radiosity(None, person, pts, o, rays, per_spot=True, spots=spots)
        fronts, backs = [lf], [lb]
        for other in also:
            f, b = other._person_radiosity(None, person, pts, o, rays, per_spot=True)
            fronts.append(f)
            backs.append(b)
        if nlos_ambient:
            amb = self.scene.ambient
            own = (pts["albedo"] - 1) * self._t(amb.hidden_radiance if amb is not None else np.zeros(3))
            fronts.append(own)
            backs.append(own)
        lf, lb = torch.cat(fronts, dim=1), torch.cat(backs, dim=1)
        img = self._gather(person, pts, o, rays, lf, lb)  # (H, W, 3 C)
        return img.reshape(*self.shape, lf.shape[1] // 3, 3).permute(2, 0, 1, 3)

    def _gather(self, person: Person, pts, o, rays: SceneRays, front, back) -> torch.Tensor:
        """A: radiance (N, C) leaving body samples (by side) -> pixel means (H, W, C)."""
        r = self.recv_t
        out = torch.zeros(len(r.pixel), front.shape[1], device=self.device, dtype=self.dtype)
        wa = pts["area"]
        loops = self._loops(o, wa, front, back)
        # footprint sampling in the loops keeps nothing of size (rows, N): larger blocks, fewer ray calls
        step = FOOTPRINT_LOOP_CHUNK if loops and r.key is not None else self.settings.chunk
        for a in range(0, len(r.pixel), step):
            sl = slice(a, a + step)
            rp, rn = r.pts["pos"][sl], r.pts["normal"][sl]
            cos_c = (rn * r.to_cam[sl]).sum(-1, keepdim=True)
            if loops:
                out[sl] = self._gather_loops(sl, cos_c, o, pts, person, rays, front, back)
                continue
            need = self.kernels("pair_need", rp, rn, cos_c, o, pts["normal"], person.closed)
            if r.key is not None:
                need = need & (r.key[sl].unsqueeze(1) == r.share(len(o), self.device).unsqueeze(0))
            vis = self._visible(rays, rp, rn, o, pts["normal"], need)
            wf, wb = self.kernels("gather_weights", rp, rn, o, pts["normal"], vis, wa)
            rad = r.pts["kd"][sl].repeat(1, front.shape[1] // 3) / math.pi * (wf @ front + wb @ back)
            gl = r.glossy[sl]
            if gl.any():
                spec = self.kernels("glossy_lobe", rp[gl], rn[gl], r.to_cam[sl][gl], cos_c[gl], r.pts["alpha"][sl][gl],
                                    o, pts["normal"])
                ks = r.pts["ks"][sl][gl].repeat(1, front.shape[1] // 3)
                rad = rad.clone()
                rad[gl] = rad[gl] + ks * ((wf[gl] * spec) @ front + (wb[gl] * spec) @ back)
            out[sl] = rad
        return self._pixels(r.scale(out), r)
