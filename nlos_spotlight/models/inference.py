"""A trained NLOS network made fast for inference, with the same inputs and outputs.

Backends, in the order ``benchmarks/inference_latency.py`` measures them:

- ``eager``: the network as trained, under ``torch.inference_mode``.
- ``torch``: batch norm folded into the convolutions (``torch.fx`` fusion) and channels-last
  weights, so oneDNN runs its fused channels-last kernels. Same numbers to float rounding.
- ``onnx``: the whole network (background subtraction, normalization, heads) exported to ONNX and
  run by ONNX Runtime's CPU provider with its graph optimizations. Same numbers to float rounding.
- ``onnx-int8``: that graph quantized to 8-bit integers (static, per-channel weights, activation
  ranges calibrated on frames of the room: VNNI instructions where the CPU has them). It changes the
  numbers a little; the benchmark reports by how much on held-out people.

ONNX needs the optional packages of ``pip install 'nlos-spotlight[fast]'``.

Shapes:
    images (B, H, W, 3), background (B, H, W, 3) or None, clipped (B, H, W) bool or None
    -> position (B, 2) m, posture logits (B, 6), as numpy float32.
"""

from __future__ import annotations

import copy
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np
import torch
from torch import nn

from ..errors import NlosError

BACKENDS = ("eager", "torch", "onnx", "onnx-int8")
"""Inference backends, slowest and simplest first."""

Runner = Callable[[np.ndarray, np.ndarray | None, np.ndarray | None], tuple[np.ndarray, np.ndarray]]


def fold_batch_norm(net: nn.Module) -> nn.Module:
    """A copy of ``net`` in eval mode whose convolution + batch-norm pairs are single convolutions
    (w' = w * g / sqrt(v + eps), b' = (b - m) * g / sqrt(v + eps) + beta), channels-last."""
    from torch.fx.experimental.optimization import fuse

    from .resnet import ResNet

    net = copy.deepcopy(net).eval()
    for name, child in list(net.named_modules()):
        if isinstance(child, ResNet):  # traceable as is
            parent, attr = _parent(net, name)
            setattr(parent, attr, fuse(child))
    return net.to(memory_format=torch.channels_last)


def _parent(root: nn.Module, name: str) -> tuple[nn.Module, str]:
    *path, attr = name.split(".")
    for p in path:
        root = getattr(root, p)
    return root, attr


def _inputs(net: nn.Module, shape: tuple[int, int], batch: int = 1):
    h, w = shape
    bg = torch.zeros(batch, h, w, 3) if getattr(net, "subtract", False) else None
    return torch.rand(batch, h, w, 3), bg, torch.zeros(batch, h, w, dtype=torch.bool)


def export_onnx(net: nn.Module, shape: tuple[int, int], path: Path) -> Path:
    """The network (batch dimension dynamic) as an ONNX file at ``path``."""
    try:
        import onnx  # noqa: F401  (the exporter needs it)
    except ImportError:
        raise NlosError("the onnx backends need: pip install 'nlos-spotlight[fast]'") from None
    x, bg, cl = _inputs(net, shape, 2)
    names = ["images", "background", "clipped"] if bg is not None else ["images", "clipped"]
    args = (x, bg, cl) if bg is not None else (x, None, cl)
    batch = torch.export.Dim("batch", min=1, max=4096)
    dyn = {"images": {0: batch}, "background": {0: batch} if bg is not None else None, "clipped": {0: batch}}
    import contextlib
    import io
    import logging
    import warnings

    quiet = logging.getLogger("torch.onnx")  # its notes (torchvision absent, progress) are not ours to show
    level = quiet.level
    quiet.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")
            torch.onnx.export(copy.deepcopy(net).eval(), args, str(path), input_names=names,
                              output_names=["position", "logits"], dynamic_shapes=dyn, dynamo=True, optimize=True,
                              verbose=False)
    finally:  # the caller's logging as it was, even when the export fails
        quiet.setLevel(level)
    return path


def quantize_int8(src: Path, dst: Path, frames: list[dict[str, np.ndarray]]) -> Path:
    """``src`` quantized to int8 at ``dst``: per-channel int8 weights, uint8 activations with ranges
    from ``frames`` (dicts of the graph's inputs, batch 1)."""
    from onnxruntime.quantization import CalibrationDataReader, QuantFormat, QuantType, quantize_static
    from onnxruntime.quantization.shape_inference import quant_pre_process

    class Frames(CalibrationDataReader):
        def __init__(self):
            self.it = iter(frames)

        def get_next(self):
            return next(self.it, None)

    pre = dst.with_name(dst.stem + ".pre.onnx")
    quant_pre_process(str(src), str(pre))
    quantize_static(str(pre), str(dst), Frames(), quant_format=QuantFormat.QDQ, per_channel=True,
                    activation_type=QuantType.QUInt8, weight_type=QuantType.QInt8)
    pre.unlink(missing_ok=True)
    return dst


def compile_network(net: nn.Module, shape: tuple[int, int], backend: str = "torch", threads: int | None = None,
                    calibration: list[tuple[np.ndarray, np.ndarray | None, np.ndarray | None]] | None = None) -> Runner:
    """``run(images, background, clipped) -> (position, logits)`` for a trained network (a
    ``models.registry.PositionScaled``) on frames of ``shape`` (H, W), with ``backend`` (``BACKENDS``).

    ``threads``: CPU threads of the ONNX Runtime session (torch backends use torch's setting).
    ``calibration``: frames (batch 1 each, as ``run`` takes them) for ``onnx-int8``.
    """
    if backend not in BACKENDS:
        raise NlosError(f"--backend: expected one of {', '.join(BACKENDS)}, got {backend!r}")
    net = net.eval()
    if backend in ("eager", "torch"):
        model = net if backend == "eager" else fold_batch_norm(net)
        device = next(model.parameters()).device

        def run(images, background=None, clipped=None):
            # a copy: the caller's arrays may be read-only views (torch warns on those)
            t = lambda a, dt=torch.float32: None if a is None else torch.tensor(np.asarray(a), dtype=dt, device=device)
            with torch.inference_mode():
                pos, logits = model(t(images), t(background), t(clipped, torch.bool))
            return pos.cpu().numpy(), logits.cpu().numpy()

        return run
    if getattr(net, "nuisance", None) is not None:
        raise NlosError(f"--backend {backend}: this room model projects the capture drift out (linear solves the "
                        "ONNX export does not carry yet); use --backend torch or eager")
    try:
        import onnxruntime as ort
    except ImportError:
        raise NlosError("the onnx backends need: pip install 'nlos-spotlight[fast]'") from None
    with tempfile.TemporaryDirectory() as d:
        path = export_onnx(net, shape, Path(d) / "net.onnx")
        if backend == "onnx-int8":
            if not calibration:
                raise NlosError("onnx-int8: needs calibration frames of the room")
            path = quantize_int8(path, Path(d) / "net-int8.onnx", [_feed(net, *c) for c in calibration])
        so = ort.SessionOptions()
        so.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
        if threads:
            so.intra_op_num_threads, so.inter_op_num_threads = threads, 1
        session = ort.InferenceSession(str(path), so, providers=["CPUExecutionProvider"])

    def run(images, background=None, clipped=None):
        pos, logits = session.run(None, _feed(net, images, background, clipped))
        return pos, logits

    return run


def _feed(net: nn.Module, images, background, clipped) -> dict[str, np.ndarray]:
    """The ONNX graph's inputs: float32 frames, a bool clip flag (all False when None)."""
    images = np.ascontiguousarray(images, np.float32)
    feed = {"images": images,
            "clipped": np.zeros(images.shape[:3], bool) if clipped is None else np.ascontiguousarray(clipped, bool)}
    if getattr(net, "subtract", False):
        if background is None:
            raise NlosError("this network reads photograph - empty-room photograph: pass the background")
        feed["background"] = np.ascontiguousarray(np.broadcast_to(background, images.shape), np.float32)
    return feed


__all__ = ["BACKENDS", "compile_network", "export_onnx", "fold_batch_norm", "quantize_int8"]
