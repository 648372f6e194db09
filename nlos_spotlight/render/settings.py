"""Sampling and numerics of the renderer (``render.transport.Renderer``), and named presets; kept
apart from the renderer so that reading them (``nlos render --help``) does not import torch."""

from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass
class ImageSampling:
    """How a person's photograph is sampled: the render knobs that set a dataset's images, declared
    once here and nested as ``render`` in ``DatasetConfig`` and ``FitConfig`` (their defaults differ
    per config: :data:`DATASET_SAMPLING`, ``fit.config``)."""

    pixel_samples: int = 4
    """n: n x n stratified sub-samples per pixel for the per-scene terms (direct, ambient, interreflection)."""
    transport_pixel_samples: int = 2
    """n x n sub-samples per pixel for person -> pixel transport (the per-person cost)."""
    pixel_footprint: int = 0
    """n > 0: the person's light integrated over each pixel's footprint from n x n sub-samples that
    share out the body samples (and the shadow's static points) among them, each pair once, at about
    the cost of one sub-sample (``Renderer`` docstring); 0: ``transport_pixel_samples`` sub-samples
    each see every body sample."""
    footprint_jitter: bool = False
    """Footprint sampling: each sub-sample anywhere in its cell (uniform, drawn from the seed and the
    call's ``footprint_draw``), not at the cell's centre. The centres integrate the footprint with a
    bias that falls only as about 1/n (about 7% at 8 x 8 in the copy room); jittered sub-samples
    estimate it without bias, so a network trained on many draws learns the pixel's mean light."""
    spot_samples: int = 64
    """Projector rays per candidate spot (equal solid angle)."""
    person_samples: int = 512
    """Area samples on the body."""
    person_quadrature: str = "mc"
    """Body sampling rule: 'faces' (per-face centroid rule, at least one sample a face: datasets'
    and fits') or 'mc' (``Person.from_mesh``'s default, ``render/person.py``); read where the body
    becomes a ``Person``."""


@dataclass
class ShadowSampling:
    """How the light the body stops (``nlos_shadow``) and the light it bounces back (``nlos_bounce``)
    are sampled: nested as ``shadow`` in ``FitConfig`` (a fit's shadow step; datasets render neither)."""

    shadow_samples: int = 4096
    """Area samples of the static surfaces relaying the spot light the person blocks (``nlos_shadow``)."""
    shadow_depth: int = 4
    """Mitsuba's ``max_depth`` ``nlos_shadow`` counts to: 4, the spot's first relay alone; more, also
    the room's later relays of it, which the body stops on their way to the camera's points
    (``render/tail.py``)."""
    bounce_body_samples: int = 0
    """Body samples of ``nlos_bounce``'s body <-> relay exchange: 0 the person's own quadrature (the
    reference), else this many stratified ones at the relay points' offset (``Person.resampled``):
    the term is smooth over the body, and its relay points already carry Monte Carlo noise
    (benchmarks/bounce_body_samples.py)."""


@dataclass
class RenderSettings(ImageSampling, ShadowSampling):
    """Sampling (:class:`ImageSampling`, :class:`ShadowSampling`) and numerics of :class:`Renderer`."""

    footprint_seed: int = 20_241
    """Seed of the pixels' fixed slot offsets in footprint sampling (images are deterministic)."""
    relay_offset: float = 0.5
    """Offset in [0, 1) of those samples' strata (``person.monte_carlo``); ``Renderer.render`` may
    take another per call, so that people need not share one fixed pattern of relay points."""
    chunk: int = 2048
    """Receiver rows per block in the pair kernels (bounds memory)."""
    dtype: str = "float32"
    """torch dtype name for everything after ray casting ('float64' for gradcheck)."""
    fuse: bool = False
    """Compile the per-person pair kernels with torch.compile (``render/fused.py``; no-gradient calls only)."""
    pair_loops: bool = True
    """On CPU, no-gradient calls sum the per-person pairs in compiled loops (``render/pair_loops.py``)."""
    device: str = "auto"
    """'cpu', 'cuda' or 'auto' (cuda when available)."""
    rays: str = "auto"
    """Engine of the per-person occlusion rays: 'embree' (embreex, one ray at a time: the reference),
    'drjit' (Mitsuba 3's array ray tests: all cores, or OptiX on the GPU) or 'auto' (drjit where it runs)."""

    @classmethod
    def of(cls, image: ImageSampling, shadow: ShadowSampling | None = None, **execution) -> "RenderSettings":
        """The settings of a config's sampling blocks (the one place they pass to the renderer), with
        ``execution`` (``device``, ``fuse``, ``rays``, ...) or further overrides."""
        blocks = {**asdict(shadow or ShadowSampling()), **asdict(image)}
        return cls(**{**blocks, **execution})


DATASET_SAMPLING = ImageSampling(pixel_samples=2, transport_pixel_samples=1, spot_samples=16, person_samples=3500,
                                 person_quadrature="faces")
"""A dataset's sampling unless its config says otherwise: per-scene terms at 2 x 2 and the person's
at one sub-sample a pixel (the per-person cost), 16 projector rays a spot, 3,500 body samples (the
faces rule on 1,500 faces: under 0.5% from converged, ``benchmarks/person_convergence.py``)."""


DEVICES = ("cpu", "cuda", "auto")
"""Where a renderer runs: ``auto`` is cuda when torch sees a GPU."""


def resolve_device(device: str) -> str:
    """'cpu' or 'cuda' for a :data:`DEVICES` name (refused with a one-line reason if unknown or absent)."""
    from ..errors import NlosError

    if device not in DEVICES:
        raise NlosError(f"--device: expected one of {', '.join(DEVICES)}, got {device!r}")
    if device == "cpu":
        return "cpu"
    import torch

    if torch.cuda.is_available():
        return "cuda"
    if device == "cuda":
        raise NlosError("--device cuda: torch sees no CUDA GPU here (use --device cpu or auto)")
    return "cpu"


RENDER_PRESETS = {
    "default": RenderSettings(),
    "single-image": RenderSettings(person_samples=1024, spot_samples=256),
    "fast": RenderSettings(transport_pixel_samples=1, person_samples=256, spot_samples=32),
}
"""Named render settings: ``default`` (per-person rendering in datasets takes its counts from the
dataset config), ``single-image`` (``nlos render``: one image, more samples for less noise),
``fast`` (a frame at video rate: 44-47 ms for a 64 x 64 image after the precompute on 2 CPU cores,
``benchmarks/render_speed.py``; its ``nlos`` is within 3.3% of ``default``'s in total)."""

__all__ = ["DATASET_SAMPLING", "DEVICES", "ImageSampling", "RENDER_PRESETS", "RenderSettings", "ShadowSampling",
           "resolve_device"]
