"""The per-person pair kernels, as plain torch and optionally fused by ``torch.compile``.

A person's light is two sums over point pairs (DESIGN section 5): spot samples x_s -> body
samples (``radiosity``: B E) and body samples -> camera sub-samples (``gather_weights``: A).
Profiled at the dataset settings (209 candidates x 16 rays, 4,000 body samples), about 85% of a
person's time was elementwise torch over the (S, N) pairs: the geometry, the GGX BRDF and the
masks, each a separate pass over memory, while the Embree rays took about 10%. ``torch.compile``
fuses each kernel into one pass (about 4x on this machine's CPU); the eager functions are the
reference the fused ones are tested against.

Each kernel recomputes the pair geometry instead of storing it: the (S, N, 3) directions are the
largest temporaries, and recomputing them inside a fused loop is cheaper than reading them back.
"""

from __future__ import annotations

import warnings

import torch

from .brdf import COS_EPS, brdf, ggx_d, smith_g1
from .kernels import pair_geometry


def pair_need(pa, na, front, o, nb, closed: bool) -> torch.Tensor:
    """(Na, N) bool: surface point a faces body sample n on its ``front`` side and light can pass n's side.

    ``front`` (Na, 1): n_a . (direction to the projector) for spot samples, n_a . (direction to the
    camera) for camera sub-samples; a closed body exchanges light only through its outside.
    """
    d = o.unsqueeze(0) - pa.unsqueeze(1)  # signs only: no normalization needed
    return ((d * na.unsqueeze(1)).sum(-1) * front > 0) & (((d * nb.unsqueeze(0)).sum(-1) < 0) | (not closed))


def radiosity(sp, sn, to_proj, kd, ks, alpha, o, nb, vis, w, group, groups: int):
    """Irradiance-weighted radiance leaving spot samples toward each body sample, summed per group.

    Returns (front, back), each (groups, N, 3): sum over s in the group of f_s G(s, n) V(s, n) w_s,
    split by the side of body sample n that faces s. ``ks`` and ``alpha`` None: Lambertian samples.
    """
    geo = pair_geometry(sp, sn, o, nb)
    gloss = (ks.unsqueeze(1), alpha.unsqueeze(1)) if ks is not None else (None, None)
    f = brdf(sn.unsqueeze(1), to_proj.unsqueeze(1), geo.dir_ab, kd.unsqueeze(1), *gloss)
    e = f * (geo.g * vis).unsqueeze(-1) * w.unsqueeze(1)
    side = (geo.cos_b > 0).to(e.dtype).unsqueeze(-1)
    zero = torch.zeros(groups, o.shape[0], 3, device=o.device, dtype=e.dtype)
    return zero.index_add(0, group, e * side), zero.index_add(0, group, e * (1 - side))


def gather_weights(rp, rn, o, nb, vis, area):
    """(P, N) weights G V a of body sample n's front (first) and back side seen from sub-sample p.

    ``vis`` is 0 wherever ``pair_need`` is false (no ray was cast there), so it carries the mask.
    """
    geo = pair_geometry(rp, rn, o, nb)
    w = geo.g * vis * area
    side = (geo.cos_b > 0).to(vis.dtype)
    return w * side, w * (1 - side)


def glossy_lobe(rp, rn, to_cam, cos_c, alpha, o, nb) -> torch.Tensor:
    """(P, N) GGX factor D G1 G1 / (4 |cos_i| |cos_o|) of glossy sub-samples toward body sample n."""
    geo = pair_geometry(rp, rn, o, nb)
    n, wi, wo = rn.unsqueeze(1), geo.dir_ab, to_cam.unsqueeze(1)
    h = wi + wo
    h = h / h.norm(dim=-1, keepdim=True).clamp(min=1e-12)
    a = alpha.unsqueeze(1)
    cos_i = geo.cos_a
    spec = ggx_d((n * h).sum(-1).abs(), a) * smith_g1(cos_i, a) * smith_g1(cos_c, a)
    return spec / (4 * cos_i.abs().clamp(min=COS_EPS) * cos_c.abs().clamp(min=COS_EPS))


KERNELS = ("pair_need", "radiosity", "gather_weights", "glossy_lobe")


class PairKernels:
    """The kernels above, eager or compiled (``fuse``).

    Compiled kernels serve only calls that need no gradient (dataset generation, evaluation);
    a call with a tensor that requires grad takes the eager function, so the renderer stays
    differentiable without compiling a backward pass. If compiling fails (no C++ compiler, an
    unsupported device), a warning is given once and everything runs eagerly.
    """

    def __init__(self, fuse: bool = False):
        self.fuse = fuse
        g = globals()
        self._eager = {k: g[k] for k in KERNELS}
        self._fused = {k: torch.compile(g[k], dynamic=True) for k in KERNELS} if fuse else {}

    def __call__(self, name: str, *args, **kwargs):
        if self._fused and not (torch.is_grad_enabled() and any(
                isinstance(a, torch.Tensor) and a.requires_grad for a in args)):
            try:
                return self._fused[name](*args, **kwargs)
            except Exception as err:  # noqa: BLE001  (a compiler missing or failing: fall back, once)
                warnings.warn(f"render: fused kernels unavailable ({type(err).__name__}: {str(err)[:120]}); "
                              "running eagerly", RuntimeWarning, stacklevel=2)
                self._fused = {}
        return self._eager[name](*args, **kwargs)


_SHARED: dict[bool, PairKernels] = {}


def pair_kernels(fuse: bool) -> PairKernels:
    """One PairKernels per mode for the process (compiled code is cached by torch per function)."""
    if fuse not in _SHARED:
        _SHARED[fuse] = PairKernels(fuse)
    return _SHARED[fuse]


__all__ = ["KERNELS", "PairKernels", "pair_kernels", *KERNELS]
