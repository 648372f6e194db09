"""Baseline NLOS networks: registry, architecture as documented, exposure invariance, they can learn."""

from __future__ import annotations

import inspect

import pytest
import torch
import torch.nn.functional as F
from torch import nn

from nlos_spotlight.models.baselines import BASELINES, DLNLOS
from nlos_spotlight.models.nlos_net import NLOSNetConfig
from nlos_spotlight.models.registry import NETWORKS, build_network

NAMES = ("chandran", "tancik", "dlnlos")


@pytest.fixture(autouse=True)
def _one_thread():
    """These networks are small: one thread is as fast, and does not spin against other jobs."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def test_registered_with_documented_sources():
    assert set(NAMES) <= set(BASELINES) and all(NETWORKS[n] is BASELINES[n] for n in NAMES)
    for n in NAMES:  # what the trainer builds: the network inside the position standardizer
        assert isinstance(build_network(n).net, BASELINES[n])
    papers = {"chandran": "Adaptive Lighting for Data-Driven", "tancik": "Flash Photography for Data-Driven",
              "dlnlos": "based on deep learning"}
    for name, cls in BASELINES.items():
        doc = inspect.getmodule(cls).__doc__
        assert papers[name] in doc and "Shapes:" in doc


@pytest.mark.parametrize("name", NAMES)
def test_shapes_at_every_dataset_resolution(name):
    net = BASELINES[name]().eval()
    for side in (12, 32, 64):  # micro, tiny/small, paper datasets
        pos, logits = net(torch.rand(2, side, side, 3))
        assert pos.shape == (2, 2) and logits.shape == (2, 6)
    pos_cf, _ = net(torch.rand(2, 3, 20, 28))  # channels-first and non-square input too
    assert pos_cf.shape == (2, 2)


@pytest.mark.parametrize("name", NAMES)
def test_exposure_does_not_matter(name):
    g = torch.Generator().manual_seed(3)
    img = torch.rand(4, 24, 24, 3, generator=g) * 0.02  # radiance-scale values
    for mode in ("eval", "train"):
        torch.manual_seed(0)
        net = BASELINES[name]()
        getattr(net, mode)()
        torch.manual_seed(1)  # same dropout mask for both calls in train mode
        pos, logits = net(img)
        torch.manual_seed(1)
        pos2, logits2 = net(img * 37.5)  # a 37.5x longer exposure
        torch.testing.assert_close(pos, pos2, rtol=1e-4, atol=1e-5)
        torch.testing.assert_close(logits, logits2, rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("name", NAMES)
def test_fits_a_tiny_batch(name):
    """Memorize 8 images: position MSE + posture cross-entropy falls by 10x in 40 Adam steps."""
    g = torch.Generator().manual_seed(1)
    images = torch.rand(8, 16, 16, 3, generator=g) + 0.1
    target = torch.rand(8, 2, generator=g) * 2 - 1
    posture = torch.arange(8) % 6
    torch.manual_seed(0)
    net = BASELINES[name]()
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)

    def loss() -> torch.Tensor:
        pos, logits = net(images)
        return F.mse_loss(pos, target) + F.cross_entropy(logits, posture)

    with torch.no_grad():
        start = float(loss())
    for _ in range(40):
        opt.zero_grad()
        value = loss()
        value.backward()
        opt.step()
    net.eval()  # batch norm on running statistics, no dropout
    with torch.no_grad():
        end = float(loss())
        acc = float((net(images)[1].argmax(1) == posture).float().mean())
    assert end < start / 10 and acc == 1.0


@pytest.mark.parametrize("name", NAMES)
def test_reset_parameters_reinitializes_everything(name):
    net = BASELINES[name]()
    opt = torch.optim.SGD(net.parameters(), lr=0.1)
    pos, logits = net(torch.rand(4, 16, 16, 3))
    (pos.sum() + logits.sum()).backward()
    opt.step()
    trained = {k: v.clone() for k, v in net.state_dict().items()}
    torch.manual_seed(7)
    net.reset_parameters()
    first = {k: v.clone() for k, v in net.state_dict().items()}
    torch.manual_seed(7)
    net.reset_parameters()
    for k, v in net.state_dict().items():
        torch.testing.assert_close(v, first[k])  # deterministic in the seed
    weights = [k for k, v in first.items() if k.endswith("weight") and v.dim() > 1]
    assert all(not torch.equal(first[k], trained[k]) for k in weights)  # every layer was redrawn
    bn_means = [k for k in first if k.endswith("running_mean")]
    assert bn_means and all(torch.count_nonzero(first[k]) == 0 for k in bn_means)  # batch-norm stats too


def test_dlnlos_has_five_convolutions_and_three_fully_connected_layers_per_head():
    net = DLNLOS()
    assert sum(isinstance(m, nn.Conv2d) for m in net.features.modules()) == 5
    for head in (net.position_head, net.posture_head):
        assert sum(isinstance(m, nn.Linear) for m in head.modules()) == 3


@pytest.mark.parametrize("name", ["resnet18", *NAMES])
def test_background_subtraction_reads_the_difference(name):
    """With background_subtract every network sees photograph - empty room, and refuses to run without it."""
    from nlos_spotlight.models.registry import build_network

    torch.manual_seed(0)
    plain = build_network(name, NLOSNetConfig()).eval()
    sub = build_network(name, NLOSNetConfig(background_subtract=True)).eval()
    sub.load_state_dict(plain.state_dict())
    img, bg = torch.rand(2, 16, 16, 3) + 0.5, torch.rand(2, 16, 16, 3)
    with torch.no_grad():
        a, b = sub(img, bg), plain(img - bg)
    assert torch.allclose(a[0], b[0], atol=1e-6) and torch.allclose(a[1], b[1], atol=1e-6)
    with pytest.raises(ValueError, match="background"):
        sub(img)
