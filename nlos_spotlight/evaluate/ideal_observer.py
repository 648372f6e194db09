"""An ideal observer's posture accuracy: the most any network could read from one photograph.

For one person, ``means`` (K, P) holds the person's light in each of K postures with everything
else the same, and ``jacobians`` (K, P, J) its derivatives with respect to J nuisances (place,
facing, height, albedo), all whitened by the camera's noise (divided by its standard deviation per
pixel). The photograph of posture t is ``y = means[t] + n``, ``n ~ N(0, I / frames)``. Two
observers classify it:

* ``known``: everything but the posture known, the nearest mean, ``argmin_k ||y - mu_k||``;
* ``nuisance``: the nuisances unknown, fitted to first order (a generalized likelihood ratio test),
  ``argmin_k ||(I - P_k)(y - mu_k)||`` with ``P_k`` the projection on ``jacobians[k]``'s columns.

Both are upper bounds on a network that must also learn the room: they know the room, the body's
build and pose variant, and (``nuisance``) move the nuisances only along their tangent. Accuracy is
estimated by Monte Carlo in the subspace that the decision depends on (the mean differences and
the Jacobians' columns): only the noise's projection there changes a decision, so that projection
is drawn exactly, ``(m,)`` standard normals with ``m <= K - 1 + K J``, not ``(P,)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass
class ObserverAccuracy:
    """Monte Carlo confusion matrices of the two observers (rows: true class, columns: answer).

    Shapes:
        known: (K, K) fraction of draws of class t answered k.
        nuisance: (K, K) the same with the nuisances fitted.
    """

    known: torch.Tensor
    nuisance: torch.Tensor

    @property
    def accuracy(self) -> tuple[float, float]:
        """(known, nuisance) accuracy with equal priors."""
        return float(self.known.diagonal().mean()), float(self.nuisance.diagonal().mean())


def _orthonormal(cols: torch.Tensor, rtol: float = 1e-10) -> torch.Tensor:
    """(P, r) orthonormal basis of the span of ``cols`` (P, c), numerically dependent columns dropped."""
    u, s, _ = torch.linalg.svd(cols, full_matrices=False)
    return u[:, s > rtol * s.max()] if s.numel() and s.max() > 0 else cols[:, :0]


def ideal_observer(means: torch.Tensor, jacobians: torch.Tensor | None = None, frames: float = 1.0,
                   draws: int = 4000, seed: int = 0) -> ObserverAccuracy:
    """Confusion matrices of the known-nuisance and fitted-nuisance observers.

    Args:
        means: (K, P) whitened class means.
        jacobians: (K, P, J) whitened nuisance derivatives per class, or None (no nuisances).
        frames: frames averaged (the noise's variance is divided by it).
        draws: Monte Carlo draws per true class.
        seed: random seed of the draws.
    """
    means = means.double()
    k, _ = means.shape
    jac = jacobians.double() if jacobians is not None else means.new_zeros(k, means.shape[1], 0)
    cols = torch.cat([(means[1:] - means[0]).T, jac.permute(1, 0, 2).reshape(means.shape[1], -1)], 1)
    basis = _orthonormal(cols)                                    # (P, m)
    mu = means @ basis                                            # (K, m): the means in the subspace
    q = [_orthonormal(jac[c]).T @ basis for c in range(k)]        # (r_c, m): each class's nuisance span
    gen = torch.Generator().manual_seed(seed)
    known, fitted = torch.zeros(k, k, dtype=torch.float64), torch.zeros(k, k, dtype=torch.float64)
    for t in range(k):
        y = mu[t] + torch.randn(draws, basis.shape[1], generator=gen, dtype=torch.float64) / frames ** 0.5
        r = y[:, None, :] - mu[None]                              # (D, K, m) residual to each mean
        d_known = (r ** 2).sum(-1)
        d_fit = d_known - torch.stack([((r[:, c] @ q[c].T) ** 2).sum(-1) for c in range(k)], 1)
        known[t] = torch.bincount(d_known.argmin(1), minlength=k).double() / draws
        fitted[t] = torch.bincount(d_fit.argmin(1), minlength=k).double() / draws
    return ObserverAccuracy(known, fitted)


__all__ = ["ObserverAccuracy", "ideal_observer"]
