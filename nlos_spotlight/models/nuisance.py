"""Nuisance projection: what changed in the room's light between the empty-room capture and the
person capture, estimated and removed from their difference before the network reads it.

With ``d = P - B`` (person capture minus empty-room capture, radiance) and ``B`` the empty-room
capture, the capture variations of ``render/variation.py`` change the room's light along, to first
order, the columns of

    M = [ B f,  B (1 - f),  B r_x,  B r_y,  B r_roll,  B r_pan,  B r_tilt ]

(projector gain with the exposure, ambient gain, camera shift x and y in output pixels, camera roll
in radians about the image centre, the spot's pan and tilt in radians). ``f`` (H, W, 3) is the
fraction of each pixel's light that comes from the projector and ``r`` (5, H, W, 3) the relative
derivatives of the pixel's light in each motion, ``(d L / d motion) / L``, all rendered from the
room's scan at sub-pixel resolution (``render.variation.StaticLayers``) and kept as buffers
(:meth:`NuisanceProjection.set_prior`); multiplying by the measured ``B`` carries them to the real
room's brightness (an albedo the scan got wrong scales a pixel's light and its derivatives alike).
Central differences of the 32 x 32 photograph were tried first: they misjudge the derivative of a
spot edge a pixel wide by 20-80% (``tests/models/test_nuisance.py`` keeps the textured case). The
weighted least-squares coefficients

    c = argmin_c || W^1/2 (d - M c) ||^2,   W = 1 / (B + 0.01 mean B) (shot noise), 0 where clipped,

are the drift estimates (relative gains, pixels, radians), and the network reads the residual
``d - M c``. The same projection runs in training and in ``nlos predict``, so the network learns on
exactly what survives it. It also removes the person's light along those seven directions (its
overall brightness relative to the room, mostly): the price of a reading that survives drift.

The drift that ``nlos predict`` reports (:meth:`NuisanceProjection.drift`) is a second fit of the
same difference with the person's light as extra columns: ``B q_k`` for the mean and leading
principal directions ``q`` of the training people's light over the room's rendered light
(:func:`person_light_basis`). Without them the person's light leaks into the coefficients (in the
copy room it shifts the room-light estimate by 0.23 of its tolerance, person to person), which
the residual's standard error does not see; with them the estimates are what the room did.

Shapes:
    diff (B, H, W, 3), background (B, H, W, 3), clipped (B, H, W) bool or None
    -> residual (B, H, W, 3), coefficients (B, 7) in the order of :data:`DIRECTIONS`, their
    standard errors (B, 7).
"""

from __future__ import annotations

import torch
from torch import nn

DIRECTIONS = ("projector", "ambient", "shift_x", "shift_y", "roll", "aim_pan", "aim_tilt")
"""What each coefficient measures: relative gains, output pixels (x right, y down), radians."""
NOISE_FLOOR = 0.01
"""The weights' floor, as a fraction of the mean background (dark pixels still have read noise)."""
PERSON_DIRECTIONS = 8
"""Person-light columns of the drift fit: the mean and 7 principal directions (99% of the training
people's light in the copy room; 1 -> 8 columns take the drift flag's false alarms at 2x ``tripod``
from 7.4% to 2.7%, 16 or 32 add nothing: ``drift_directions.py``, archived as the git tag
``archive/studies-2026-11-29``)."""


def nuisance_basis(background: torch.Tensor, fraction: torch.Tensor, relative: torch.Tensor) -> torch.Tensor:
    """(B, 7, H, W, 3): the columns of ``M`` (module docstring) for empty-room captures (B, H, W, 3),
    the room's ``fraction`` (H, W, 3) and ``relative`` derivatives (5, H, W, 3)."""
    b = background.unsqueeze(1)
    return torch.cat([b * fraction, b * (1 - fraction), b * relative], dim=1)


def noise_weights(background: torch.Tensor, clipped: torch.Tensor | None) -> torch.Tensor:
    """(B, H, W, 3) least-squares weights: inverse shot-noise variance, zero where clipped."""
    level = background.clamp(min=0)
    floor = NOISE_FLOOR * level.mean(dim=(1, 2, 3), keepdim=True).clamp(min=1e-30)
    w = 1.0 / (level + floor)
    return w if clipped is None else w.masked_fill(clipped.unsqueeze(-1), 0.0)


def project_out(diff: torch.Tensor, basis: torch.Tensor, weights: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Weighted least squares of ``diff`` (B, H, W, 3) on ``basis`` (B, K, H, W, 3): the residual,
    the coefficients (B, K) and their standard errors (B, K) (from the residual's weighted
    variance: what noise and the person's light leave uncertain). Solved in float64 with the
    columns scaled to unit weighted norm and a tiny ridge, so a column that is zero or collinear
    costs nothing."""
    bsz, k = basis.shape[:2]
    m = basis.reshape(bsz, k, -1).double()
    d = diff.reshape(bsz, -1).double()
    w = weights.reshape(bsz, -1).double()
    norm = (m.pow(2) * w[:, None]).sum(-1).sqrt().clamp(min=1e-300)
    mn = m / norm[..., None]
    gram = torch.einsum("bkn,bjn->bkj", mn * w[:, None], mn)
    gram = gram + 1e-9 * torch.eye(k, dtype=gram.dtype, device=gram.device)
    rhs = torch.einsum("bkn,bn->bk", mn * w[:, None], d)
    cn = torch.linalg.solve(gram, rhs)
    resid = d - torch.einsum("bk,bkn->bn", cn, mn)
    dof = ((w > 0).sum(-1) - k).clamp(min=1).double()
    scale = (w * resid.pow(2)).sum(-1) / dof
    se = (torch.linalg.inv(gram).diagonal(dim1=-2, dim2=-1) * scale[:, None]).clamp(min=0).sqrt() / norm
    return resid.reshape(diff.shape).to(diff.dtype), (cn / norm).to(diff.dtype), se.to(diff.dtype)


def person_light_basis(light: torch.Tensor, total: torch.Tensor, k: int = PERSON_DIRECTIONS) -> torch.Tensor:
    """(k, H, W, 3): the mean and the k - 1 leading principal directions of the people's light
    ``light`` (N, H, W, 3) over the room's rendered light ``total`` (H, W, 3), each of unit norm (the
    drift fit scales its columns anyway)."""
    total = total.double()
    rel = torch.where(total > 0, light.double() / total.clamp(min=1e-30), 0.0).reshape(len(light), -1)  # unlit: no say
    mean = rel.mean(0)
    k = max(1, min(k, len(light)))
    vh = leading_directions(rel - mean, k - 1) if k > 1 else rel[:0]
    q = torch.cat([(mean / mean.norm().clamp(min=1e-300))[None], vh])
    return q.reshape(len(q), *total.shape).float()


EXACT_SVD_ENTRIES = 1 << 24
"""Largest (people x pixels) matrix whose principal directions take a full SVD (3,000 people at
32 x 32 hold 9.2M entries); above it a randomized SVD (Halko et al. 2011) finds the few leading ones."""


def leading_directions(x: torch.Tensor, k: int, oversample: int = 10, power: int = 4) -> torch.Tensor:
    """(k, M) the leading right singular vectors of the centred rows ``x`` (N, M): by a full SVD up
    to :data:`EXACT_SVD_ENTRIES` entries, else by a randomized range finder (Halko et al. 2011,
    Alg. 4.4: ``oversample`` extra columns, ``power`` subspace iterations: the people's light has a
    fast-falling spectrum) drawn from its own seeded generator, so no caller's random stream moves."""
    if x.numel() <= EXACT_SVD_ENTRIES:
        return torch.linalg.svd(x, full_matrices=False)[2][:k]
    q = min(k + oversample, *x.shape)
    gen = torch.Generator(device=x.device).manual_seed(0)
    basis = torch.linalg.qr(x @ torch.randn(x.shape[1], q, generator=gen, device=x.device, dtype=x.dtype))[0]
    for _ in range(power):  # re-orthonormalized each pass (numerically stable subspace iteration)
        basis = torch.linalg.qr(x @ torch.linalg.qr(x.T @ basis)[0])[0]
    return torch.linalg.svd(basis.T @ x, full_matrices=False)[2][:k]


def project_out_reference(diff, basis, weights):
    """Slow, obviously correct twin of :func:`project_out`: numpy's lstsq on sqrt(W)-scaled rows,
    one image at a time (no ridge)."""
    import numpy as np

    res, coef = [], []
    for d, m, w in zip(diff.double().numpy(), basis.double().numpy(), weights.double().numpy()):
        a = (m.reshape(len(m), -1) * np.sqrt(w.reshape(-1))).T
        c = np.linalg.lstsq(a, d.reshape(-1) * np.sqrt(w.reshape(-1)), rcond=None)[0]
        coef.append(c)
        res.append(d - np.tensordot(c, m, axes=1))
    return torch.as_tensor(np.stack(res)), torch.as_tensor(np.stack(coef))


class NuisanceProjection(nn.Module):
    """The projection of the module docstring, with the room's rendered prior as buffers.

    Buffers: ``fraction`` (H, W, 3) the projector's share of each pixel's light, ``relative``
    (5, H, W, 3) the relative derivatives of the light in the camera's shift (x, y, per output
    pixel), roll and the spot's pan and tilt (per radian), ``person`` (K, H, W, 3) the training
    people's light directions of the drift fit (:func:`person_light_basis`; empty: none, as in room
    models fitted before it). They take their shapes from :meth:`set_prior` / :meth:`set_person`
    or from a checkpoint (``_load_from_state_dict``).
    """

    BUFFERS = ("fraction", "relative", "person")

    def __init__(self):
        super().__init__()
        for name in self.BUFFERS:
            self.register_buffer(name, torch.zeros(0))

    def reset_parameters(self) -> None:  # no parameters: the prior comes from the room
        pass

    def set_prior(self, fraction: torch.Tensor, relative: torch.Tensor) -> None:
        if fraction.dim() != 3 or fraction.shape[-1] != 3 or relative.shape != (5, *fraction.shape):
            raise ValueError(f"nuisance prior: expected (H, W, 3) and (5, H, W, 3), got {tuple(fraction.shape)} "
                             f"and {tuple(relative.shape)}")
        self.fraction = fraction.detach().to(self.fraction.device, torch.float32).clone()
        self.relative = relative.detach().to(self.fraction.device, torch.float32).clone()

    def set_person(self, basis: torch.Tensor) -> None:
        """The drift fit's person-light directions (K, H, W, 3), on the prior's grid."""
        if not self.ready or basis.dim() != 4 or tuple(basis.shape[1:]) != tuple(self.fraction.shape):
            raise ValueError(f"nuisance projection: person directions {tuple(basis.shape)} do not match the room "
                             f"prior {tuple(self.fraction.shape)}")
        self.person = basis.detach().to(self.fraction.device, torch.float32).clone()

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):
        # room models fitted before the drift fit had person directions: none (BatchNorm fills its
        # missing counter the same way)
        state_dict.setdefault(prefix + "person", torch.zeros(0))
        for name in self.BUFFERS:
            if prefix + name in state_dict:  # take the stored shape before the copy
                setattr(self, name, torch.empty_like(state_dict[prefix + name], device=getattr(self, name).device))
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)

    @property
    def ready(self) -> bool:
        return self.fraction.numel() > 0

    def _check(self, diff: torch.Tensor) -> None:
        if not self.ready:
            raise ValueError("nuisance projection: no room prior (set_prior) in this network")
        if tuple(self.fraction.shape) != tuple(diff.shape[1:]):
            raise ValueError(f"nuisance projection: the room prior is {tuple(self.fraction.shape)}, the photographs "
                             f"{tuple(diff.shape[1:])}")

    def _fit(self, diff: torch.Tensor, background: torch.Tensor, clipped: torch.Tensor | None,
             person: bool) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """:func:`project_out` on ``M`` (and with ``person`` the person directions ``B q_k`` after it)."""
        self._check(diff)
        background = background.expand_as(diff)
        basis = nuisance_basis(background, self.fraction.to(diff.dtype), self.relative.to(diff.dtype))
        if person:
            basis = torch.cat([basis, background.unsqueeze(1) * self.person.to(diff.dtype)], dim=1)
        return project_out(diff, basis, noise_weights(background, clipped))

    def forward(self, diff: torch.Tensor, background: torch.Tensor,
                clipped: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        return self._fit(diff, background, clipped, person=False)

    def drift(self, diff: torch.Tensor, background: torch.Tensor,
              clipped: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """The seven coefficients (B, 7) and their standard errors (B, 7) of a fit that also holds
        the person's light directions (module docstring): what ``nlos predict`` reports."""
        _, coef, se = self._fit(diff, background, clipped, person=self.person.numel() > 0)
        k = len(DIRECTIONS)
        return coef[:, :k], se[:, :k]


def room_prior(layers) -> tuple[torch.Tensor, torch.Tensor]:
    """The ``fraction`` (H, W, 3) and ``relative`` (5, H, W, 3) buffers of a room from its static
    layers (``render.variation.StaticLayers``): the rendered derivatives over the rendered light."""
    p, a = layers.nominal()
    total = (p + a).clamp(min=1e-30)
    derivs = torch.cat([layers.motion_derivatives(), layers.bin(layers.aim)])
    return (p / total).clamp(0, 1), derivs / total


__all__ = ["DIRECTIONS", "NuisanceProjection", "PERSON_DIRECTIONS", "noise_weights", "nuisance_basis",
           "leading_directions", "person_light_basis", "project_out", "project_out_reference", "room_prior"]
