"""The transport against closed forms: form factors, spot irradiance, reciprocity."""

from __future__ import annotations

import math

import numpy as np
import torch
from scipy.integrate import quad as integrate

from nlos_spotlight.render.brdf import brdf, ggx_d
from nlos_spotlight.render.camera import pixel_rays
from nlos_spotlight.render.kernels import form_factor
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.spot import spot_profile
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.builders import quad


def ff_parallel(a, b, c):
    """Parallel, directly opposed a x b rectangles at distance c (Howell's catalog C-11)."""
    X, Y = a / c, b / c
    return 2 / (math.pi * X * Y) * (
        0.5 * math.log((1 + X**2) * (1 + Y**2) / (1 + X**2 + Y**2))
        + X * math.sqrt(1 + Y**2) * math.atan(X / math.sqrt(1 + Y**2))
        + Y * math.sqrt(1 + X**2) * math.atan(Y / math.sqrt(1 + X**2))
        - X * math.atan(X) - Y * math.atan(Y))


def ff_perpendicular(h, w, l):
    """Perpendicular rectangles sharing an edge of length l; from w x l to h x l (Howell C-14)."""
    H, W = h / l, w / l
    s = H**2 + W**2
    log = math.log((1 + W**2) * (1 + H**2) / (1 + s)
                   * (W**2 * (1 + s) / ((1 + W**2) * s)) ** (W**2)
                   * (H**2 * (1 + s) / ((1 + H**2) * s)) ** (H**2))
    return (W * math.atan(1 / W) + H * math.atan(1 / H) - math.sqrt(s) * math.atan(1 / math.sqrt(s))
            + 0.25 * log) / (math.pi * W)


def ff_point_corner(a, b, c):
    """Differential area to a parallel a x b rectangle at distance c, above one corner (Howell B-3)."""
    X, Y = a / c, b / c
    return (X / math.sqrt(1 + X**2) * math.atan(Y / math.sqrt(1 + X**2))
            + Y / math.sqrt(1 + Y**2) * math.atan(X / math.sqrt(1 + Y**2))) / (2 * math.pi)


def _samples(mesh, n):
    p = Person.from_mesh(mesh, [1, 1, 1], n)
    t = lambda x: torch.as_tensor(x, dtype=torch.float64)
    return t(p.pos), t(p.normal), t(p.area)


def test_form_factor_parallel_squares():
    a = _samples(quad([0, 0, 0], [1, 0, 0], [0, 1, 0], 16, 16), 4096)
    b = _samples(quad([0, 0, 1], [1, 0, 0], [0, 1, 0], 16, 16), 4096)
    f = float(form_factor(*a, *b))
    assert abs(ff_parallel(1, 1, 1) - 0.19982) < 1e-4
    assert f == pytest_approx(ff_parallel(1, 1, 1), 2e-3)


def test_distance_floor_bounds_only_the_near_pairs():
    """``pair_geometry(..., r2_min)``: 1 / max(r^2, r2_min), the directions and cosines unchanged."""
    from nlos_spotlight.render.kernels import pair_geometry

    pa = torch.tensor([[0.0, 0.0, 0.0]], dtype=torch.float64)
    na = torch.tensor([[0.0, 0.0, 1.0]], dtype=torch.float64)
    pb = torch.tensor([[0.0, 0.0, 0.01], [0.3, 0.0, 1.0], [0.0, 0.0, 2.0]], dtype=torch.float64)
    nb = -na.expand(3, 3)
    free, floor = pair_geometry(pa, na, pb, nb), pair_geometry(pa, na, pb, nb, 0.25)
    r2 = (pb ** 2).sum(-1)
    assert torch.allclose(free.inv_r2[0], 1 / r2)
    assert torch.allclose(floor.inv_r2[0], 1 / r2.clamp(min=0.25))
    assert torch.equal(floor.cos_a, free.cos_a) and torch.equal(floor.dir_ab, free.dir_ab)
    assert float(floor.g[0, 2]) == float(free.g[0, 2])  # 2 m: beyond the floor, untouched


def test_form_factor_perpendicular_squares():
    """Floor square to a perpendicular unit square lifted 0.25 m off the shared edge line.

    By superposition F = F(1 -> 1.25 m tall) - F(1 -> 0.25 m tall), both sharing the edge; the gap
    keeps the point-sampled 1/r^2 kernel away from its singularity.
    """
    assert abs(ff_perpendicular(1, 1, 1) - 0.20004) < 1e-4
    a = _samples(quad([0, 0, 0], [1, 0, 0], [0, 1, 0], 16, 16), 4096)  # floor, y in [0, 1]
    b = _samples(quad([0, 0, 0.25], [1, 0, 0], [0, 0, 1], 16, 16), 4096)  # wall y = 0, z in [0.25, 1.25]
    f = float(form_factor(*a, *b))
    exact = ff_perpendicular(1.25, 1, 1) - ff_perpendicular(0.25, 1, 1)
    assert f == pytest_approx(exact, 2e-3)


def test_form_factor_reciprocity():
    a = _samples(quad([0, 0, 0], [1, 0, 0], [0, 2, 0], 8, 16), 2048)
    b = _samples(quad([0, 0, 0.8], [1, 0, 0], [0, 1, 0], 8, 8), 2048)
    fab, fba = float(form_factor(*a, *b)), float(form_factor(*b, *a))
    assert 2.0 * fab == pytest_approx(1.0 * fba, 1e-9)
    # the 1x1 sees the directly opposed 1x1 half of the 1x2 plate plus more
    assert fba > ff_parallel(1, 1, 0.8) * 1.05


def test_point_to_plate_form_factor_through_renderer(plate_scene):
    """nlos_ambient at the wall point facing a dark plate: -kd * L_h * F(point -> plate)."""
    sc = plate_scene()
    r = Renderer(sc, RenderSettings(pixel_samples=1, transport_pixel_samples=1, person_samples=4096,
                                    dtype="float64"))
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, 4096)
    out = r.render(r.spot_vector(0), person, components=("nlos_ambient",))["nlos_ambient"]
    center = out[1, 1].numpy()
    expected = -0.8 * 1.0 * 4 * ff_point_corner(0.5, 0.5, 1.0)
    assert np.allclose(center, expected, rtol=2e-3), (center, expected)


def test_spot_irradiance_on_plane_matches_formula(plate_scene):
    sc = plate_scene(res=16, fov=60.0)
    aim = np.array([0.3, 0.0, 1.2])
    r = Renderer(sc, RenderSettings(pixel_samples=1, dtype="float64"), aim_points=aim[None])
    img = r.render(r.spot_vector(0), components=("direct",))["direct"].numpy()
    dirs, origin = pixel_rays(sc.camera, 1)
    d = dirs[:, :, 0]
    t = -origin[1] / d[..., 1]  # hit the plane y = 0
    x = origin + t[..., None] * d
    p = sc.projector
    to_x = x - p.position
    dist = np.linalg.norm(to_x, axis=-1)
    axis = (aim - p.position) / np.linalg.norm(aim - p.position)
    theta = np.arccos(np.clip((to_x / dist[..., None]) @ axis, -1, 1))
    cos_x = np.abs(to_x[..., 1]) / dist
    expected = 0.8 / np.pi * 10.0 * spot_profile(theta, p.beam_width_deg, p.cutoff_deg) * cos_x / dist**2
    assert (expected > 0).mean() > 0.2 and (expected == 0).mean() > 0.1  # beam, ramp and dark all present
    # Embree hit points are float32: 1e-5 relative is the precision of the ray engine
    assert np.allclose(img[..., 0], expected, rtol=1e-5, atol=1e-12)


def test_spot_quadrature_carries_the_beam_flux(plate_scene):
    sc = plate_scene()
    p = sc.projector
    sc.projector.position = np.array([0.0, 1.0, 1.0])  # face the wall head-on so every ray lands
    r = Renderer(sc, RenderSettings(spot_samples=512, dtype="float64"), aim_points=np.array([[0.0, 0.0, 1.0]]))
    b, c = math.radians(p.beam_width_deg), math.radians(p.cutoff_deg)
    flux = 2 * math.pi * integrate(lambda t: float(spot_profile(np.array(t), p.beam_width_deg,
                                                                p.cutoff_deg)) * math.sin(t), 0, c,
                                   points=[b])[0] * 10.0
    assert float(r.spot_flux[:, 0].sum()) == pytest_approx(flux, 2e-3)


def test_brdf_reciprocity_and_hemisphere_rule():
    g = torch.Generator().manual_seed(1)
    n = torch.nn.functional.normalize(torch.randn(500, 3, generator=g, dtype=torch.float64), dim=1)
    wi = torch.nn.functional.normalize(torch.randn(500, 3, generator=g, dtype=torch.float64), dim=1)
    wo = torch.nn.functional.normalize(torch.randn(500, 3, generator=g, dtype=torch.float64), dim=1)
    kd = torch.rand(500, 3, generator=g, dtype=torch.float64)
    ks = torch.rand(500, 3, generator=g, dtype=torch.float64)
    alpha = 0.05 + torch.rand(500, generator=g, dtype=torch.float64)
    f1, f2 = brdf(n, wi, wo, kd, ks, alpha), brdf(n, wo, wi, kd, ks, alpha)
    assert torch.allclose(f1, f2, rtol=1e-12)
    opposite = ((n * wi).sum(-1) * (n * wo).sum(-1)) < 0
    assert opposite.any() and torch.all(f1[opposite] == 0)
    assert torch.allclose(brdf(-n, wi, wo, kd, ks, alpha), f1)  # two-sided


def test_ggx_normalized_and_energy_conserving():
    """Projected D integrates to 1; the glossy lobe's directional albedo is <= 1 and -> 1 as alpha -> 0."""
    g = torch.Generator().manual_seed(2)
    u = torch.rand(2_000_000, 2, generator=g, dtype=torch.float64)
    z = u[:, 0]  # uniform hemisphere directions: pdf 1 / (2 pi)
    r = torch.sqrt(1 - z**2)
    w = torch.stack([r * torch.cos(2 * math.pi * u[:, 1]), r * torch.sin(2 * math.pi * u[:, 1]), z], 1)
    n = torch.tensor([[0.0, 0.0, 1.0]], dtype=torch.float64)
    zero, one = torch.zeros(1, 3, dtype=torch.float64), torch.ones(1, 3, dtype=torch.float64)
    albedos = []
    for a in (0.1, 0.2, 0.5):
        alpha = torch.tensor([a], dtype=torch.float64)
        assert float((ggx_d(z, alpha) * z).mean() * 2 * math.pi) == pytest_approx(1.0, 1.5e-2)
        wi = torch.tensor([[math.sin(0.5), 0.0, math.cos(0.5)]], dtype=torch.float64)
        f = brdf(n, wi, w, zero, one, alpha)[:, 0]
        albedos.append(float((f * z).mean() * 2 * math.pi))
    assert albedos[0] == pytest_approx(1.0, 2e-2)
    assert all(a <= 1.0 + 1e-2 for a in albedos) and albedos[0] > albedos[1] > albedos[2] > 0.5


def pytest_approx(x, rel):
    import pytest

    return pytest.approx(x, rel=rel)
