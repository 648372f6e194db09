"""The room's ceiling (``fit/ceiling.py``): the position bound against closed forms and the
independent Fisher information of ``evaluate.crb``, and the nuisance steps."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.fit.ceiling import STEPS, crb_m, jacobian, jacobian_reference, perturbed
from nlos_spotlight.render.sensor import SensorConfig, noise_variance_dn
from nlos_spotlight.render.settings import ImageSampling
from nlos_spotlight.world.body import BodyParams


def test_bound_of_orthogonal_derivatives_is_the_closed_form():
    """Whitened derivatives along x with norm a and along y with norm b, a burst of f frames:
    J = f diag(a^2, b^2), so sqrt(trace(J^-1)) = sqrt(1 / (f a^2) + 1 / (f b^2))."""
    g = torch.zeros(50, 2, dtype=torch.float64)
    g[:20, 0] = 3.0 / np.sqrt(20)  # norm 3
    g[20:, 1] = 0.5 / np.sqrt(30)  # norm 0.5
    assert crb_m(g, 16) == pytest.approx(np.sqrt(1 / (16 * 9) + 1 / (16 * 0.25)), rel=1e-12)
    g[:, 1] = g[:, 0]  # x and y move the image alike: no bound
    assert crb_m(g, 16) == float("inf")


def test_bound_equals_the_fisher_information_of_the_sensor_model():
    """The ceiling's whitened form (noise of one frame, a burst of f) against ``evaluate.crb.fisher_crb``
    (the burst's noise, DN): the same bound for a random image and derivative."""
    from nlos_spotlight.evaluate.crb import fisher_crb

    gen = torch.Generator().manual_seed(0)
    h, w = 6, 5
    mean = torch.rand(h, w, 3, generator=gen, dtype=torch.float64) * 0.02
    jac = torch.randn(h, w, 3, 2, generator=gen, dtype=torch.float64) * 0.01
    exposure, frames = 0.05, 16
    burst = SensorConfig.at((h, w), {"burst_frames": frames})
    one = SensorConfig.at((h, w), {"burst_frames": 1})
    from nlos_spotlight.render.sensor import dn_per_radiance

    k = dn_per_radiance(exposure, one)
    assert float((mean * k).max()) < one.full_scale_dn  # nothing clips: fisher_crb keeps every pixel
    sigma = noise_variance_dn((mean * k).reshape(-1), one).sqrt() / k
    ours = crb_m(jac.reshape(-1, 2) / sigma[:, None], frames)
    assert ours == pytest.approx(fisher_crb(jac, mean, exposure, burst), rel=1e-9)


def test_each_step_moves_only_its_nuisance():
    base = BodyParams(posture="standing", facing_deg=30.0, height_m=1.7, albedo=np.array([0.4, 0.5, 0.6]))
    t = np.array([1.0, 2.0, 0.0])
    for name, h in STEPS.items():
        p, tt = perturbed(base, t, name, h)
        moved = {k for k in ("facing_deg", "height_m") if getattr(p, k) != getattr(base, k)}
        moved |= {f"albedo_{c}" for c, a, b in zip("rgb", p.albedo, base.albedo) if a != b}
        moved |= {c for c, a, b in zip("xy", tt, t) if a != b}
        assert moved == {name}, name
        assert (p.posture, p.pose_seed, p.weight) == (base.posture, base.pose_seed, base.weight)


@pytest.mark.parametrize("albedo, hidden, spot", [
    ((0.4, 0.5, 0.6), 0.0, True),     # the spot's light alone: linear in albedo
    ((0.4, 0.5, 0.6), 0.02, True),    # with the hidden room's light, which the body blocks: affine
    ((0.995, 0.3, 0.0), 0.02, True),  # a step clipped at 1; a black channel
    ((0.4, 0.5, 0.6), 0.02, False),   # the projector off: the hidden light alone
])
def test_jacobian_equals_its_central_differences(small_corner, albedo, hidden, spot):
    """The ceiling's derivatives (albedo columns from one render at albedo 0, one sampled body for
    the floor steps) against every column a central difference of two renders."""
    from types import SimpleNamespace

    from nlos_spotlight.render.transport import Renderer, RenderSettings
    from nlos_spotlight.scene.examples import SPOT_TARGET
    from nlos_spotlight.scene.format import Ambient

    scene = small_corner
    scene.ambient = Ambient(np.full(3, hidden), np.full(3, hidden)) if hidden else None
    r = Renderer(scene, RenderSettings(pixel_samples=1, transport_pixel_samples=1, spot_samples=16,
                                       person_samples=128, dtype="float64", device="cpu"),
                 aim_points=SPOT_TARGET[None])
    y = r.spot_vector(0) if spot else torch.zeros_like(r.spot_vector(0))
    dcfg = SimpleNamespace(body_faces=400, render=ImageSampling(person_samples=128, person_quadrature="faces"))
    hr = scene.hidden_region
    t = np.array([*(hr.min + hr.max) / 2, hr.floor_z])
    params = BodyParams(posture="sitting", facing_deg=20.0, height_m=1.7, albedo=np.array(albedo))
    calls, render = [], r.render
    r.render = lambda *a, **k: calls.append(1) or render(*a, **k)
    fast = jacobian(r, y, params, t, dcfg)
    assert len(calls) == 10 + 2 * albedo.count(0.0)  # the light, at albedo 0, x, y, facing and height both ways
    ref = jacobian_reference(r, y, params, t, dcfg)
    for j, name in enumerate(STEPS):
        scale = float(ref[:, j].abs().max())
        assert scale > 0, name
        torch.testing.assert_close(fast[:, j], ref[:, j], rtol=1e-9, atol=1e-12 * scale, msg=name)
