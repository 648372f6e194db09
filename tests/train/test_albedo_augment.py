"""Albedo augmentation: the person's light re-dressed in another albedo, against renders."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.render.person import Person
from nlos_spotlight.train.imaging import albedo_factors, form_images
from nlos_spotlight.world.body import _clothing_albedo, clothing_albedo


def test_person_light_scales_with_albedo_as_rendered(glossy_corner_pair):
    """Rendering the same body in two albedos gives what ``albedo_factors`` predicts from one."""
    _, r, person = glossy_corner_pair(300, "float64", pair_loops=True)
    mesh = r.scene.human.mesh
    a0, a1 = np.array([0.6, 0.3, 0.15]), np.array([0.1, 0.45, 0.7])
    imgs = []
    for a in (a0, a1):
        p = Person.from_mesh(mesh, a, 300, "faces")
        with torch.no_grad():
            imgs.append(r.transport_images(p, [0.05, -0.03], nlos_ambient=True))
    lit_a0, lit_a1 = imgs[0][:-1], imgs[1][:-1]
    amb_a0, amb_a1 = imgs[0][-1], imgs[1][-1]
    assert float(lit_a0.abs().max()) > 0 and float(amb_a0.abs().max()) > 0

    class Room:  # the one field albedo_factors reads
        albedo = torch.as_tensor(a0)[None]
        scene_dir = ""

    lit, amb = albedo_factors(Room, torch.tensor([0]), torch.as_tensor(a1)[None])
    assert torch.allclose(lit[0] * lit_a0, lit_a1, rtol=1e-9, atol=1e-12 * float(lit_a1.abs().max()))
    assert torch.allclose(amb[0, 0] * amb_a0, amb_a1, rtol=1e-9, atol=1e-12 * float(amb_a1.abs().max()))


def test_form_images_in_own_albedo_is_unchanged(micro_scene):
    _, s = micro_scene
    idx = torch.arange(s.num_samples)
    spot = int(torch.nonzero(s.landed & s.stored).flatten()[0])
    y = torch.nn.functional.one_hot(torch.tensor(spot), len(s.landed)).float()
    flash = s.flash_direct is not None and s.flash_nlos is not None
    for mode in ("spot", "ambient") + (("flash",) * flash):
        want, static = form_images(s, idx, y, mode)
        got, static2 = form_images(s, idx, y, mode, s.albedo[idx])
        assert torch.equal(static, static2)
        assert torch.allclose(got, want, rtol=1e-5, atol=1e-6 * float(want.abs().max()))
    bright = form_images(s, idx, y, "spot", torch.full((len(idx), 3), 0.8))[0] - static
    dark = form_images(s, idx, y, "spot", torch.full((len(idx), 3), 0.05))[0] - static
    assert float(bright.sum()) > float(dark.sum())  # a brighter body gives the walls more light


def test_torch_draws_follow_the_datasets_distribution():
    """The training-time draws and the generator's numpy draws: same mean, spread and bounds per
    channel (20,000 each; the standard error of a mean is about 0.001)."""
    rng = np.random.default_rng(0)
    ref = np.stack([_clothing_albedo(rng) for _ in range(20_000)])
    got = clothing_albedo(20_000, torch.Generator().manual_seed(0)).numpy()
    assert got.shape == (20_000, 3)
    assert np.allclose(got.mean(0), ref.mean(0), atol=0.006)
    assert np.allclose(got.std(0), ref.std(0), atol=0.006)
    assert got.min() >= 0.05 and got.max() <= 0.8
    assert np.allclose(np.corrcoef(got.T), np.corrcoef(ref.T), atol=0.02)


def test_albedo_factors_need_stored_albedos(toy_scene):
    from nlos_spotlight.errors import NlosError

    s = toy_scene(4)
    with pytest.raises(NlosError, match="albedo"):
        albedo_factors(s, torch.arange(2), torch.full((2, 3), 0.3))


def test_camera_clothing_reaches_black_and_white_fabric():
    """The 'camera' range covers dark (0.05) and white (0.9) clothing; the dataset's stops short."""
    g = torch.Generator().manual_seed(0)
    cam = clothing_albedo(20_000, g, kind="camera").mean(1)
    data = clothing_albedo(20_000, g, kind="dataset").mean(1)
    assert float(cam.min()) < 0.05 and float(cam.max()) > 0.85
    assert float(data.min()) > 0.06 and float(data.max()) < 0.7


def test_camera_log_clothing_is_log_uniform_in_brightness():
    """'camera-log': the 'camera' range with log-uniform brightness. Unclipped, a draw's channel mean
    is its brightness, so P(brightness < 0.1) = ln(0.1 / 0.03) / ln(0.9 / 0.03) = 0.354 and its
    median sqrt(0.03 x 0.9) = 0.164 (uniform: 0.080 and 0.465); 20,000 draws, standard error 0.004."""
    import math

    from nlos_spotlight.cli import build_parser
    from nlos_spotlight.fit.config import CLOTHING
    from nlos_spotlight.world.body import CLOTHING_RANGES

    g = torch.Generator().manual_seed(0)
    log = clothing_albedo(20_000, g, kind="camera-log")
    lin = clothing_albedo(20_000, g, kind="camera")
    (lo, hi), clip = CLOTHING_RANGES["camera-log"]
    free = ((log > clip[0]) & (log < clip[1])).all(1)  # draws no channel was clipped in
    b = log[free].mean(1)
    assert free.float().mean() > 0.9
    assert abs(float((b < 0.1).float().mean()) - math.log(0.1 / lo) / math.log(hi / lo)) < 0.015
    assert abs(float(b.median()) - math.sqrt(lo * hi)) < 0.01
    assert abs(float((lin.mean(1) < 0.1).float().mean()) - (0.1 - lo) / (hi - lo)) < 0.015
    assert float(log.min()) >= clip[0] - 1e-6 and float(log.max()) <= clip[1] + 1e-6
    choices = next(a.choices for a in build_parser()._subparsers._group_actions[0].choices["fit"]._actions
                   if a.dest == "clothing")
    assert tuple(choices) == CLOTHING and set(CLOTHING) - {"dataset"} <= set(CLOTHING_RANGES)


def test_shadow_term_joins_the_spot_light_not_the_clothing(micro_scene):
    """A stored shadow term adds to the projector's person light as is, whatever the albedo (the
    blocked light does not depend on the clothing), and only under its own spot."""
    import dataclasses

    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.train.imaging import form_parts

    _, s = micro_scene
    idx = torch.arange(s.num_samples)
    spot = int(torch.nonzero(s.stored if s.stored is not None else torch.ones(len(s.faces), dtype=torch.bool))[0])
    y = torch.zeros(len(s.faces), dtype=s.v.dtype)
    y[spot] = 1
    shadow = -torch.rand(s.num_samples, *s.nlos_ambient.shape[1:], generator=torch.Generator().manual_seed(1),
                         dtype=s.v.dtype) * float(s.v.abs().max())
    with_sh = dataclasses.replace(s, shadow=shadow, shadow_spot=spot)
    albedo = torch.full((s.num_samples, 3), 0.05, dtype=s.v.dtype)
    lit0, amb0, st0 = form_parts(s, idx, y, "spot", albedo)
    lit1, amb1, st1 = form_parts(with_sh, idx, y, "spot", albedo)
    assert torch.equal(lit1, lit0 + shadow) and torch.equal(amb1, amb0) and torch.equal(st1, st0)
    assert torch.equal(form_parts(with_sh.subset(idx[1:]), idx[:-1], y)[0], form_parts(s, idx[1:], y)[0] + shadow[1:])
    other = torch.zeros_like(y)
    other[(spot + 1) % len(y)] = 1
    with pytest.raises(NlosError, match=f"stored for spot {spot} only"):
        form_parts(with_sh, idx, other, "spot")
