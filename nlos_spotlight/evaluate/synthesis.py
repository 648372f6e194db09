"""Posture and place by analysis by synthesis: render bodies in the room's scan, keep the nearest.

A network must learn a room's light transport from examples; the renderer already holds it. For
a photograph's person light d (the photograph minus the empty-room photograph), this fits the
renderer's body light L(theta) in the room's scan, under the same spot, to d by weighted least
squares (weights 1 / noise variance, clipped pixels at 0), per posture, over the nuisances theta
= (floor x, y, facing, height) and the clothing albedo a, and answers the posture of least chi^2:

    chi^2_q = min_{theta, a} sum_p w_p (d_p - L_q(theta, a)_p)^2,   posture = argmin_q chi^2_q.

The albedo is fitted exactly: the renderer's person light is affine in a per channel,
L(a) = a N + (1 - a) Q, with N the projector's light on a white body and Q the body's light at
albedo 0 (the ambient light it hides; ``train.imaging.albedo_factors``, DESIGN section 5), so one
render gives both and a is a clipped linear fit per channel. The rest is searched: a coarse bank
of renders over the floor (:class:`Bank`) finds the place, a scan over facings per posture the
direction, and bounded Levenberg-Marquardt (:func:`refine`) all four. The body is a mean build;
what that costs is measured in ``experiments/unseen-room-fit/synthesis_posture.py`` against the person's own body.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import torch

from ..render.person import Person
from ..render.transport import Renderer, RenderSettings
from ..scene.format import Scene, TriMesh
from .crb import PERSON

BANK_POSTURES = ("standing", "sitting", "crouching")
"""The coarse bank's postures: one per height group (the arm postures stand)."""
STEP = np.array([0.01, 0.01, 2.0, 0.01])
"""Forward-difference steps of the refined (x m, y m, facing deg, height m)."""
MEAN_HEIGHT_M = 1.7
"""Height the search starts from (``world.body.HEIGHT_RANGE_M``'s middle)."""


@dataclasses.dataclass
class Reading:
    """What :func:`read_photograph` says of one photograph."""

    posture: str
    """The posture of least chi^2."""
    xy: np.ndarray
    """(2,) its floor point, world frame, m."""
    facing_deg: float
    """Its facing, degrees."""
    height_m: float
    """Its height, m."""
    chi2: dict[str, float]
    """chi^2 of every posture at its own best fit (the full-quality body)."""


class Synthesizer:
    """The room's scan lit by one spot; renders a body's light split into N and Q (module doc).

    Args:
        scene: the room without a person (its ``hidden_region`` gives the floor height).
        aim_point: (3,) where the spot lands.
        settings: the renderer's settings (``person_samples``: samples on the body).
        body_faces: faces of the body mesh.
        quadrature: ``Person.from_mesh``'s quadrature.
        pose: ``(BodyParams, faces) -> TriMesh``, soles at the origin; ``world.body.posed_body``.
    """

    def __init__(self, scene: Scene, aim_point: np.ndarray, settings: RenderSettings, body_faces: int,
                 quadrature: str = "faces", pose: Callable[..., TriMesh] | None = None):
        if pose is None:
            from ..world.body import posed_body

            pose = posed_body
        self.scene, self.settings, self.faces, self.quadrature, self.pose = scene, settings, body_faces, quadrature, pose
        self.r = Renderer(scene, settings, aim_points=np.asarray(aim_point, float).reshape(1, 3))
        self.floor_z = scene.hidden_region.floor_z
        self.renders = 0

    def light(self, params, xy) -> tuple[torch.Tensor, torch.Tensor]:
        """(N, Q), (H, W, 3) float64 each, of body ``params`` (its albedo ignored) standing at ``xy``."""
        n, q = self.lights(params, np.asarray(xy, float)[None])
        return n[0], q[0]

    def lights(self, params, xys: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
        """(N, Q), (K, H, W, 3) float64 each, of body ``params`` standing at each of ``xys`` (K, 2):
        the body posed once (posing costs as much as a coarse render)."""
        half = dataclasses.replace(params, albedo=np.full(3, 0.5))
        body = self.pose(half, self.faces)
        person = Person.from_mesh(body, half.albedo, self.settings.person_samples, self.quadrature)
        xys = np.asarray(xys, float).reshape(-1, 2)
        at = np.concatenate([xys, np.full((len(xys), 1), self.floor_z)], 1)
        out = self.r.render(self.r.spot_vector(0), person, translation=at, components=PERSON).components
        self.renders += len(xys)
        # at albedo 1/2: nlos = N / 2, nlos_ambient = (1 - 1/2) Q
        return 2 * out["nlos"].double(), 2 * out["nlos_ambient"].double()


def albedo_residual(d: torch.Tensor, w: torch.Tensor, n: torch.Tensor, q: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(residual d - a N - (1 - a) Q, albedo a (..., 3)) at the weighted least-squares a in [0, 1]
    per channel; n, q (..., H, W, 3), d and w (H, W, 3).

    chi^2 is a sum of one parabola per channel, so the per-channel optimum clipped to [0, 1] is the
    constrained optimum."""
    g, e = n - q, d - q
    a = ((w * g * e).sum((-3, -2)) / (w * g * g).sum((-3, -2)).clamp(min=1e-300)).clamp(0, 1)
    return e - a[..., None, None, :] * g, a


def albedo_fit(d: torch.Tensor, w: torch.Tensor, n: torch.Tensor, q: torch.Tensor) -> tuple[float, np.ndarray]:
    """chi^2 and albedo (3,) of d ~ a N + (1 - a) Q with weights w, all (H, W, 3) (:func:`albedo_residual`)."""
    r, a = albedo_residual(d, w, n, q)
    return float((w * r ** 2).sum()), a.numpy()


def albedo_fit_many(d: torch.Tensor, w: torch.Tensor, n: torch.Tensor, q: torch.Tensor) -> torch.Tensor:
    """(K,) chi^2 of :func:`albedo_fit` for K renders n, q (K, H, W, 3) against one d, w (H, W, 3)."""
    return (w * albedo_residual(d, w, n, q)[0] ** 2).sum((1, 2, 3))


def floor_cells(scene: Scene, spacing: float, floor: bool = True) -> np.ndarray:
    """(M, 2) centres of a ``spacing`` grid over the hidden region where a person may stand (the
    dataset's placement rules, ``world.placement``: 0.6-2.4 m from the visible walls, free of
    furniture, with ``floor`` on a floor)."""
    from ..world.rooms import scene_geometry

    reg = scene.hidden_region
    xs, ys = (np.arange(reg.min[j] + spacing / 2, reg.max[j], spacing) for j in (0, 1))
    xy = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
    return xy[scene_geometry(scene).valid_positions(xy, floor=floor)]


def mean_body(posture: str, facing_deg: float = 0.0, height_m: float = MEAN_HEIGHT_M):
    """The library's mean build in ``posture`` (pose variant 0)."""
    from ..world.body import BodyParams

    return BodyParams(posture=posture, height_m=float(height_m), facing_deg=float(facing_deg))


class Bank:
    """Coarse renders over the room's floor cells, shared by every photograph of the room: each
    posture of :data:`BANK_POSTURES` at ``facings`` directions, the mean body at 1.7 m.

    Shapes:
        n, q: (K, H, W, 3) with K = cells x 3 postures x facings.
    """

    def __init__(self, syn: Synthesizer, cells: np.ndarray, facings: int):
        self.cells, n, q = cells, [], []
        for posture in BANK_POSTURES:
            for k in range(facings):
                light = syn.lights(mean_body(posture, 360.0 * k / facings), cells)  # one body at every cell
                n.append(light[0].float())
                q.append(light[1].float())
        self.n, self.q = torch.cat(n), torch.cat(q)
        self.keys = list(range(len(cells))) * (len(BANK_POSTURES) * facings)

    def best(self, d: torch.Tensor, w: torch.Tensor) -> np.ndarray:
        """The floor cell of the bank's render nearest the photograph's light d (weights w)."""
        return self.cells[self.keys[int(albedo_fit_many(d, w, self.n.double(), self.q.double()).argmin())]]


def refine(syn: Synthesizer, d: torch.Tensor, w: torch.Tensor, posture: str, xy: np.ndarray, facing: float,
           evaluations: int, height_range: tuple[float, float] | None = None,
           free: tuple[int, ...] = (0, 1, 2, 3)) -> tuple[np.ndarray, float]:
    """(x, y, facing, height) of ``posture`` fitted to d from (xy, facing, 1.7 m) by bounded
    least squares (scipy's trust-region reflective; forward differences of :data:`STEP`; the albedo
    refitted exactly at every point), and its chi^2; at most ``evaluations`` steps. Only the
    entries ``free`` move (e.g. (2, 3): facing and height at a known place)."""
    from scipy.optimize import least_squares

    if height_range is None:
        from ..world.body import HEIGHT_RANGE_M as height_range
    reg = syn.scene.hidden_region
    lo = np.array([*reg.min, -np.inf, height_range[0]])
    hi = np.array([*reg.max, np.inf, height_range[1]])
    x0 = np.clip(np.array([*np.asarray(xy, float), facing, MEAN_HEIGHT_M]), lo, hi)
    free = list(free)
    sw = w.sqrt()
    memo: dict[tuple, np.ndarray] = {}

    def full(sub: np.ndarray) -> np.ndarray:
        theta = x0.copy()
        theta[free] = sub
        return theta

    def residual(sub: np.ndarray) -> np.ndarray:
        theta = full(sub)
        key = tuple(np.round(theta, 9))
        if key not in memo:
            r, _ = albedo_residual(d, w, *syn.light(mean_body(posture, theta[2], theta[3]), theta[:2]))
            memo[key] = (sw * r).reshape(-1).numpy()
        return memo[key]

    def jac(sub: np.ndarray) -> np.ndarray:
        base, cols = residual(sub), []
        for i, j in enumerate(free):
            step = STEP[j] if sub[i] + STEP[j] <= hi[j] else -STEP[j]
            t = sub.copy()
            t[i] += step
            cols.append((residual(t) - base) / step)
        return np.stack(cols, 1)

    res = least_squares(residual, x0[free], jac=jac, bounds=(lo[free], hi[free]),
                        x_scale=np.array([0.05, 0.05, 10.0, 0.05])[free], max_nfev=evaluations)
    return full(res.x), float(2 * res.cost)


def read_photograph(fast: Synthesizer, full: Synthesizer, bank: Bank | None, d: torch.Tensor, w: torch.Tensor,
                    postures, facings: int = 6, evaluations: int = 6, xy: np.ndarray | None = None,
                    start: np.ndarray | None = None, variants: int = 1) -> Reading:
    """Posture and place of a photograph's person light d (H, W, 3; weights w) with nothing known:
    the bank's nearest floor cell, then per posture the best of ``facings`` directions there,
    refined (:func:`refine`) with ``fast`` (a coarser body) and scored with ``full``. Given ``xy``
    (a known floor point) the bank is skipped and only facing and height are fitted; given
    ``start`` (a floor point from elsewhere, e.g. a network's answer) the search starts there
    instead of at the bank's cell and fits all four. With ``variants`` > 1 each posture is scored
    by the best of that many pose variants (``pose_seed``) at its fitted place: the body model's
    pose jitter, and for "unknown" its gesture, are nuisances too."""
    chi2, fits = {}, {}
    free = (0, 1, 2, 3) if xy is None else (2, 3)
    if xy is not None:
        xy = np.asarray(xy, float)
    elif start is not None:
        xy = np.asarray(start, float)
    elif bank is not None:
        xy = bank.best(d, w)
    else:
        raise ValueError("read_photograph: give a bank, a start or the floor point xy")
    for posture in postures:
        turns = [360.0 * k / facings for k in range(facings)]
        scan = [albedo_fit(d, w, *fast.light(mean_body(posture, f), xy))[0] for f in turns]
        theta, _ = refine(fast, d, w, posture, xy, turns[int(np.argmin(scan))], evaluations, free=free)
        body = mean_body(posture, theta[2], theta[3])
        chi2[posture] = min(albedo_fit(d, w, *full.light(dataclasses.replace(body, pose_seed=v), theta[:2]))[0]
                            for v in range(variants))
        fits[posture] = theta
    best = min(chi2, key=chi2.get)
    t = fits[best]
    return Reading(best, t[:2].copy(), float(t[2] % 360.0), float(t[3]), chi2)


def fused_log_posterior(chi2: np.ndarray, prob: np.ndarray, temperature: float) -> np.ndarray:
    """(N, Q) log posterior over postures from a network's probabilities ``prob`` (N, Q) and the
    synthesis fits' chi^2 (N, Q), up to a constant per row:

        log p(q | d) = log p_net(q | d) - (chi^2_q - min_q chi^2_q) / (2 T).

    T = 1 is the Gaussian likelihood of a model that is exact up to the noise; the mean body's
    misfit makes chi^2 differences overconfident, so T > 1 tempers them (T -> infinity: the
    network alone, T -> 0: the synthesis alone)."""
    chi2 = np.asarray(chi2, float)
    return np.log(np.clip(prob, 1e-12, None)) - (chi2 - chi2.min(1, keepdims=True)) / (2.0 * temperature)
