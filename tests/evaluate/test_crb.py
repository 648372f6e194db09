"""Cramer-Rao bound: finite differences against autograd through the renderer, and the closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from nlos_spotlight.evaluate.crb import PERSON, fisher_crb, image_jacobian
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.sensor import SensorConfig
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.examples import SPOT_TARGET


def test_finite_differences_match_autograd(small_corner):
    scene = small_corner
    r = Renderer(scene, RenderSettings(pixel_samples=1, transport_pixel_samples=1, spot_samples=16,
                                       person_samples=128, dtype="float64", device="cpu"),
                 aim_points=SPOT_TARGET[None])
    person = Person.from_mesh(scene.human.mesh, scene.human.albedo, 128)
    y = r.spot_vector(0)
    t0 = np.zeros(3)
    fd = image_jacobian(r, y, person, t0, h=1e-4)

    def image(txy):
        return r.render(y, person, translation=torch.cat([txy, torch.zeros(1, dtype=txy.dtype)]),
                        components=PERSON).image

    ad = torch.autograd.functional.jacobian(image, torch.zeros(2, dtype=torch.float64))
    assert float(ad.abs().max()) > 0
    # visibility is held fixed under autograd; a 0.1 mm step flips almost no shadow ray
    rel = float((fd - ad).norm() / ad.norm())
    assert rel < 0.02, rel


def test_fisher_bound_matches_the_closed_form():
    """One informative pixel per axis: J = diag(g_x^2 / v, g_y^2 / v), CRB = sqrt(v / g_x^2 + v / g_y^2)."""
    cfg = SensorConfig(width=2, height=2, native_width=8, native_height=8)
    mean = torch.full((2, 2, 3), 1e-3, dtype=torch.float64)
    jac = torch.zeros(2, 2, 3, 2, dtype=torch.float64)
    jac[0, 0, 0, 0], jac[1, 1, 2, 1] = 2e-4, 5e-5
    exposure = 0.1
    k = exposure * cfg.electrons_per_radiance * cfg.gain
    mu = torch.tensor(1e-3 * k, dtype=torch.float64)
    from nlos_spotlight.render.sensor import noise_variance_dn

    v = float(noise_variance_dn(mu, cfg))
    want = math.sqrt(v / (2e-4 * k) ** 2 + v / (5e-5 * k) ** 2)
    assert fisher_crb(jac, mean, exposure, cfg) == pytest.approx(want, rel=1e-9)
    # a clipped pixel carries no information: clip the x pixel, the bound becomes infinite
    assert fisher_crb(jac, mean.index_put((torch.tensor(0), torch.tensor(0)), torch.tensor(1e9, dtype=torch.float64)),
                      exposure, cfg) == float("inf")
