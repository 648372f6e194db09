"""Inference backends (``models.inference``) against the network as trained: the folded and ONNX
graphs give the same numbers, int8 close ones; the clip flag read from photographs."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.models.inference import compile_network, fold_batch_norm
from nlos_spotlight.models.nlos_net import NLOSNetConfig
from nlos_spotlight.models.registry import build_network


@pytest.fixture(scope="module")
def net():
    """A small network with batch-norm statistics far from the identity (what folding must honour)."""
    torch.manual_seed(3)
    n = build_network("resnet18", NLOSNetConfig(background_subtract=True, backbone="resnet10-narrow", stem="half"))
    for m in n.modules():
        if isinstance(m, torch.nn.BatchNorm2d):
            m.running_mean.uniform_(-0.5, 0.5), m.running_var.uniform_(0.3, 3.0)
            m.weight.data.uniform_(0.5, 1.5), m.bias.data.uniform_(-0.3, 0.3)
    n.position_mean.copy_(torch.tensor([0.4, -0.2])), n.position_std.copy_(torch.tensor([0.7, 1.1]))
    return n.eval()


def frames(n: int, seed: int):
    rng = np.random.default_rng(seed)
    bg = rng.random((n, 16, 16, 3), dtype=np.float32)
    return bg + 0.05 * rng.random((n, 16, 16, 3), dtype=np.float32), bg, rng.random((n, 16, 16)) > 0.9


def reference(net, x, bg, cl):
    with torch.no_grad():
        p, l = net(torch.as_tensor(x), torch.as_tensor(bg), torch.as_tensor(cl))
    return p.numpy(), l.numpy()


def test_folding_matches_the_network(net):
    x, bg, cl = frames(5, 0)
    folded = fold_batch_norm(net)
    assert not any(isinstance(m, torch.nn.BatchNorm2d) for m in folded.modules())
    for a, b in zip(compile_network(net, (16, 16), "torch")(x, bg, cl), reference(net, x, bg, cl)):
        np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5)


def test_onnx_matches_the_network_at_any_batch(net):
    run = compile_network(net, (16, 16), "onnx", threads=1)
    for n in (1, 7):
        x, bg, cl = frames(n, n)
        for a, b in zip(run(x, bg, cl), reference(net, x, bg, cl)):
            np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5)


def test_int8_stays_close(net):
    """Calibrated on frames like the ones it runs on, int8 moves the outputs by a few percent of
    their spread (the benchmark reports the effect on a trained room model's held-out people)."""
    cal = [tuple(a[i:i + 1] for a in frames(16, 100)) for i in range(16)]
    run = compile_network(net, (16, 16), "onnx-int8", threads=1, calibration=cal)
    x, bg, cl = frames(32, 200)
    for a, b in zip(run(x, bg, cl), reference(net, x, bg, cl)):
        assert np.abs(a - b).mean() < 0.1 * b.std(axis=0).mean() + 1e-3
    with pytest.raises(Exception, match="calibration"):
        compile_network(net, (16, 16), "onnx-int8")


def test_clip_flag_from_photographs(tmp_path):
    """A saturated input pixel flags exactly the output pixels whose footprint holds it."""
    from PIL import Image

    from nlos_spotlight.apps.images import load_frames

    a = np.full((8, 12, 3), 100, np.uint8)
    a[5, 7, 1] = 255  # one channel of one pixel at the largest code
    Image.fromarray(a).save(tmp_path / "f.png")
    np.save(tmp_path / "g.npy", np.ones((8, 12, 3)))
    f = load_frames([str(tmp_path / "f.png"), str(tmp_path / "g.npy")], (4, 4))
    want = np.zeros((4, 4), bool)
    want[5 * 4 // 8, 7 * 4 // 12] = True  # 8 -> 4 rows, 12 -> 4 columns: integer blocks
    np.testing.assert_array_equal(f.clipped[0], want)
    assert not f.clipped[1].any()  # .npy radiance carries no clipping
    assert f.bursts(2).clipped[0].sum() == 1
