"""NLOS network: ResNet-18 layer-for-layer size, heads, exposure invariance, gradients."""

from __future__ import annotations

import torch

from nlos_spotlight.models.nlos_net import NLOSNet, NLOSNetConfig
from nlos_spotlight.models.resnet import ResNet18


def test_resnet18_has_torchvisions_parameter_count():
    # torchvision.models.resnet18(): 11,689,512 parameters, of which the 1000-way fc holds 513,000
    n = sum(p.numel() for p in ResNet18(3, "imagenet").parameters())
    assert n == 11_689_512 - 513_000
    assert ResNet18(3, "imagenet")(torch.zeros(2, 3, 64, 64)).shape == (2, 512)


def test_heads_shapes_and_exposure_invariance():
    torch.manual_seed(0)
    net = NLOSNet().eval()
    img = torch.rand(4, 32, 32, 3)
    pos, logits = net(img)
    assert pos.shape == (4, 2) and logits.shape == (4, 6)
    pos2, logits2 = net(img * 37.0)  # a longer exposure changes nothing after normalization
    assert torch.allclose(pos, pos2, atol=1e-5) and torch.allclose(logits, logits2, atol=1e-5)
    heads = [m for m in net.position_head if isinstance(m, torch.nn.Linear)]
    assert len(heads) == 4  # three hidden fully connected layers, then the last one


def test_background_subtraction_option_and_gradients():
    torch.manual_seed(0)
    from nlos_spotlight.models.registry import build_network

    net = build_network("resnet18", NLOSNetConfig(background_subtract=True))
    img, bg = torch.rand(2, 32, 32, 3), torch.rand(2, 32, 32, 3)
    pos, logits = net(img, bg)  # signed differences: the RMS normalization has no sign to lose
    (pos.sum() + logits.sum()).backward()
    assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in net.parameters() if p.requires_grad)


def test_coordinate_channels_locate_pixels():
    """CoordConv channels hold each pixel center's (x, y) in [-1, 1], appended after the image."""
    from nlos_spotlight.models.nlos_net import with_coordinates

    img = torch.rand(2, 3, 4, 5)
    x = with_coordinates(img)
    assert x.shape == (2, 5, 4, 5) and torch.equal(x[:, :3], img)
    assert torch.allclose(x[0, 3, 2], torch.tensor([-1.0, -0.5, 0.0, 0.5, 1.0]))  # x along a row
    assert torch.allclose(x[1, 4, :, 3], torch.tensor([-1.0, -1 / 3, 1 / 3, 1.0]))  # y down a column
    net = NLOSNet(NLOSNetConfig(coord_channels=True)).eval()
    assert net.backbone.stem[0].in_channels == 6 and net(torch.rand(2, 16, 16, 3))[0].shape == (2, 2)


def test_clip_flag_is_an_input_channel():
    """The camera's clip flag reaches the backbone: a flagged pixel changes the output."""
    torch.manual_seed(0)
    net = NLOSNet(NLOSNetConfig()).eval()
    assert net.backbone.stem[0].in_channels == 4
    img = torch.rand(1, 16, 16, 3)
    flag = torch.zeros(1, 16, 16, dtype=torch.bool)
    base = net(img)[1]
    torch.testing.assert_close(net(img, flag)[1], base)  # no flag = nothing clipped
    flag[0, 3:6, 3:6] = True
    assert not torch.allclose(net(img, flag)[1], base)
    assert NLOSNet(NLOSNetConfig(clip_flag=False)).backbone.stem[0].in_channels == 3


def test_narrow_backbone_is_a_smaller_resnet():
    """'resnet10-narrow': one BasicBlock per stage at half width, 256 features, about a ninth of the weights."""
    from nlos_spotlight.models.resnet import backbone

    small, big = backbone("resnet10-narrow", 3, "cifar"), backbone("resnet18", 3, "cifar")
    count = lambda m: sum(p.numel() for p in m.parameters())
    assert small.out_features == 256 and len(small.stages) == 4 and all(len(s) == 1 for s in small.stages)
    assert 8 < count(big) / count(small) < 10
    net = NLOSNet(NLOSNetConfig(backbone="resnet10-narrow")).eval()
    assert net(torch.rand(2, 32, 32, 3))[1].shape == (2, 6)


def test_background_normalization_is_exposure_invariant_but_keeps_brightness():
    """normalize='background': (photo - background) / rms(background); scaling both by c changes nothing,
    while a brighter person (same background) changes the input, unlike per-image normalization."""
    import pytest

    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.models.registry import build_network

    torch.manual_seed(0)
    net = build_network("resnet18", NLOSNetConfig(background_subtract=True, normalize="background",
                                                  backbone="resnet10-narrow")).eval()
    bg = torch.rand(2, 16, 16, 3) + 0.5
    person = 1e-3 * torch.rand(2, 16, 16, 3)
    out = net(bg + person, bg)[1]
    torch.testing.assert_close(net(7.0 * (bg + person), 7.0 * bg)[1], out, rtol=1e-4, atol=1e-5)
    assert not torch.allclose(net(bg + 3 * person, bg)[1], out, atol=1e-4)
    with pytest.raises(NlosError, match="normalize"):
        build_network("resnet18", NLOSNetConfig(normalize="background"))


def test_half_stem_and_pool_grid_keep_where_the_light_fell():
    """'half' halves the image once (32 -> 16 before the stages, a 2 x 2 last map); pool_grid g
    averages that map over g x g cells, equal to a hand-made average of each cell."""
    from nlos_spotlight.models.resnet import backbone

    m = backbone("resnet10-narrow", 3, "half", pool_grid=2).eval()
    x = torch.rand(3, 3, 32, 32)
    feat = m.stages(m.stem(x))
    assert feat.shape == (3, 256, 2, 2) and m.out_features == 1024
    ref = feat.reshape(3, 256 * 4)  # 1 x 1 cells of a 2 x 2 map: the map itself, flattened
    torch.testing.assert_close(m(x), ref)
    g1 = backbone("resnet10-narrow", 3, "half").eval()
    g1.load_state_dict(m.state_dict())
    torch.testing.assert_close(g1(x), feat.mean(dim=(2, 3)))
