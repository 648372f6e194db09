"""The ideal observer against closed forms and a brute-force Monte Carlo in the full pixel space."""

import pytest
import torch
from scipy.stats import norm

from nlos_spotlight.evaluate.ideal_observer import ideal_observer


def two_classes(d_par: float, d_perp: float, p: int = 50) -> tuple[torch.Tensor, torch.Tensor]:
    """Means 0 and (d_par, d_perp, 0...) with one nuisance along the first axis for both classes."""
    means = torch.zeros(2, p, dtype=torch.float64)
    means[1, 0], means[1, 1] = d_par, d_perp
    jac = torch.zeros(2, p, 1, dtype=torch.float64)
    jac[:, 0, 0] = 1.0
    return means + 3.0, jac  # a common offset outside the span must not matter


@pytest.mark.parametrize("frames", [1.0, 4.0])
def test_two_classes_match_the_closed_form(frames):
    means, jac = two_classes(2.0, 1.5)
    acc = ideal_observer(means, jac, frames=frames, draws=200_000)
    known, fitted = acc.accuracy
    # Phi(d sqrt(F) / 2); the fitted observer keeps only the part of the difference off the nuisance
    assert known == pytest.approx(norm.cdf(2.5 * frames ** 0.5 / 2), abs=4e-3)
    assert fitted == pytest.approx(norm.cdf(1.5 * frames ** 0.5 / 2), abs=4e-3)


def brute_force(means, jac, draws, seed=1):
    """The same decisions with noise drawn in all P pixels and projections by least squares."""
    gen = torch.Generator().manual_seed(seed)
    k, p = means.shape
    known, fitted = torch.zeros(k, k), torch.zeros(k, k)
    for t in range(k):
        y = means[t] + torch.randn(draws, p, generator=gen, dtype=torch.float64)
        dk, df = [], []
        for c in range(k):
            r = y - means[c]
            coef = torch.linalg.lstsq(jac[c], r.T).solution
            dk.append((r ** 2).sum(1))
            df.append(((r - (jac[c] @ coef).T) ** 2).sum(1))
        known[t] = torch.bincount(torch.stack(dk, 1).argmin(1), minlength=k) / draws
        fitted[t] = torch.bincount(torch.stack(df, 1).argmin(1), minlength=k) / draws
    return known, fitted


def test_three_classes_match_a_full_space_monte_carlo():
    gen = torch.Generator().manual_seed(0)
    means = 2.0 * torch.randn(3, 40, generator=gen, dtype=torch.float64) / 40 ** 0.5
    jac = 0.3 * torch.randn(3, 40, 2, generator=gen, dtype=torch.float64)
    jac[:, :, 0] += means[1] - means[0]  # one nuisance mimics the first two classes' difference
    acc = ideal_observer(means, jac, draws=40_000)
    known, fitted = brute_force(means, jac, 40_000)
    assert torch.allclose(acc.known.float(), known.float(), atol=0.012)
    assert torch.allclose(acc.nuisance.float(), fitted.float(), atol=0.012)
    assert acc.accuracy[1] < acc.accuracy[0] - 0.05  # nuisances cost accuracy here
