"""A darker or brighter hidden region without rendering again, against renders at two radiances."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from nlos_spotlight.errors import NlosError
from nlos_spotlight.scene.format import Ambient
from nlos_spotlight.train.imaging import form_images, relit_hidden_region
from nlos_spotlight.world.calibration import ambient_radiance_per_channel, illuminance_lux


def test_hidden_light_scales_the_person_light_as_rendered(glossy_corner_pair):
    """``relit_hidden_region`` from one render equals a render of the hidden region at 0.2x its
    radiance, and neither the projector's light on the person nor the person-free image change."""
    _, r, person = glossy_corner_pair(300, "float64", pair_loops=True)
    y = r.spot_vector(0)
    renders = []
    for radiance in (0.05, 0.01):
        r.scene.ambient = Ambient(r.scene.ambient.radiance, np.full(3, radiance))
        with torch.no_grad():
            renders.append((r.transport_images(person, [0.05, -0.03], nlos_ambient=True),
                            r.render(y, None, components=("direct", "ambient")).image))
    (bright, empty_bright), (dark, empty_dark) = renders
    assert float(bright[-1].abs().max()) > 0
    assert torch.allclose(dark[:-1], bright[:-1], rtol=1e-12, atol=0)  # the projector's light
    assert torch.allclose(empty_dark, empty_bright, rtol=1e-12, atol=0)  # hence the exposure

    room = dataclasses.make_dataclass("Room", [("nlos_ambient", torch.Tensor)])  # the field it changes
    got = relit_hidden_region(room(bright[-1][None]), 0.2)
    assert torch.allclose(got.nlos_ambient[0], dark[-1], rtol=1e-9, atol=1e-12 * float(dark[-1].abs().max()))


def test_relit_room_changes_only_the_person_light_under_the_projector_off(micro_scene):
    _, s = micro_scene
    idx = torch.arange(s.num_samples)
    spot = int(torch.nonzero(s.landed & s.stored).flatten()[0])
    y = torch.nn.functional.one_hot(torch.tensor(spot), len(s.landed)).float()
    off, empty = form_images(s, idx, y, "ambient")
    dark_off, dark_empty = form_images(relit_hidden_region(s, 0.0), idx, y, "ambient")
    assert torch.equal(dark_empty, empty) and torch.equal(dark_off, dark_empty.expand_as(dark_off))
    assert float((off - empty).abs().max()) > 0
    lit, _ = form_images(s, idx, y, "spot")
    dark_lit, _ = form_images(relit_hidden_region(s, 0.0), idx, y, "spot")
    assert torch.allclose(lit - dark_lit, off - empty, atol=1e-6 * float(lit.abs().max()))


@pytest.mark.parametrize("scale", [-0.5, float("nan"), float("inf")])
def test_relit_rejects_a_bad_scale(micro_scene, scale):
    with pytest.raises(NlosError, match="hidden light scale"):
        relit_hidden_region(micro_scene[1], scale)


def test_illuminance_inverts_the_radiance_of_a_light_field():
    for lux in (0.01, 0.45, 2.0, 40.0):
        assert illuminance_lux([ambient_radiance_per_channel(lux)] * 3) == pytest.approx(lux, rel=1e-12)
    tint = ambient_radiance_per_channel(1.0) * np.array([1.08, 1.0, 0.92])
    assert illuminance_lux(tint) == pytest.approx(1.0, rel=1e-12)
