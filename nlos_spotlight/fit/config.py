"""Settings of ``nlos fit``: how many synthetic people, which spot policy, the capture, the training."""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field

from ..errors import NlosError
from ..render.settings import ImageSampling, ShadowSampling

CLOTHING = ("camera", "camera-log", "dataset")
"""Clothing distributions training redresses people in (``world.body.CLOTHING_RANGES``)."""
POLICIES = ("oracle", "ien", "adaptive", "center", "random")
"""Spot policies ``nlos fit`` can use (``lighting``; 'ien' needs a trained run's checkpoint)."""


FIT_SAMPLING = ImageSampling(pixel_samples=2, transport_pixel_samples=1, spot_samples=16, person_samples=1500,
                             person_quadrature="faces", pixel_footprint=8)
"""A fit's people are sampled as a dataset's (``render.settings.DATASET_SAMPLING``) but with 1,500
body points (the face rule at 1,500 faces: under 0.5% error) and each pixel's footprint at 8 x 8."""

FIT_SHADOW = ShadowSampling(shadow_samples=4096, shadow_depth=10, bounce_body_samples=1024)
"""A fit's shadow step. ``shadow_depth`` 10 adds the room's later relays of the spot's light that
the body stops (``render/tail.py``; copy room: 0.44 of the first relay's shadow where Mitsuba finds
0.46 (0.40-0.55), and the whole photograph within 1% of Mitsuba's at depth 10 where the shadow
alone gives 0.81: experiments/bounce-tail; trained with it, the copy room reads camera photographs
at 66.8% / 14.9 cm where the model without it read 60.3% / 16.2 cm); 4: the first relay alone
(the recipe before it); another depth renders only the shadow again (``fit/shadow.py``).
``bounce_body_samples`` 1,024 body samples of the bounce's body <-> relay exchange (0: the body's
own quadrature, the recipe before it). Copy room: the shadow step 1.9x faster, the bounce 3%
(median) from the body's own, under its relay points' own 7% Monte Carlo noise
(benchmarks/bounce_body_samples.py)."""


@dataclass
class FitConfig:
    """One fit of a room model (saved as ``ROOM_MODEL/fit.json``). A method without a spot
    (:attr:`light`: 'tancik', 'dlnlos') trains without the spot's terms: no shadow, bounce, drawn
    worlds or capture drift (``method``)."""

    name: str = "default"
    """Preset name."""
    people: int = 3000
    """Synthetic training people (the learning curve flattens near 3,000 a room: docs/results.md)."""
    heldout: int = 100
    """Held-out test people (and as many validation people) besides them."""
    transport_people: int = 24
    """The first people, rendered under every candidate spot: the spot policies' SNR."""
    policy: str = "oracle"
    """Spot policy: exhaustive physics search (oracle) or one of ``POLICIES``."""
    method: str = "ours"
    """What is fitted, from the methods of ``evaluate/methods.py`` (``fit_method``): 'ours' (the
    ``policy`` spot and ResNet-18), a baseline that aims with a spot (e.g. 'chandran': Adaptive
    Lighting's spot and Chandran's CNN), or one that lights none (:attr:`light`): 'tancik' (the
    flash, Tancik et al.'s CNN) or 'dlnlos' (projector off, DL-NLOS's CNN); ``policy`` must then
    be the method's own. Without a spot the fit renders no spot term: no shadow, bounce, drawn
    worlds or capture drift (``shadow_samples`` 0, ``bounce`` off, ``world_variation`` and
    ``capture_preset`` 'ideal', else refused): its photographs hold the person's flash or room
    light (``flash_nlos``, ``nlos_ambient``) but not the flash or room light the body blocks."""
    checkpoint: str = ""
    """Trained run whose IEN picks the spot (policy 'ien')."""
    seed: int = 0
    """Master seed: people, training, sensor noise."""
    burst_frames: int = 16
    """Frames averaged per still capture (and in the empty-room capture):
    experiments/seen-rooms-learning-curve/learning_curve.py --burst, oracle spot, 3,000 people: 1 -> 35.2 cm, 4 -> 27.8, 8 -> 24.9, 16 -> 21.9."""
    resolution: int = 32
    """Image width and height, binned pixels."""
    los_vertices: int = 200
    """Spot candidates: the camera-visible mesh decimated to about this many vertices."""
    body_faces: int = 1500
    """Decimated body faces."""
    render: ImageSampling = field(default_factory=lambda: dataclasses.replace(FIT_SAMPLING))
    """How each person's photograph is sampled (``render.settings.ImageSampling``, :data:`FIT_SAMPLING`):
    the dataset's sampling of the per-scene terms and the spot, 1,500 body points (the face rule at
    1,500 faces: under 0.5% error), and ``pixel_footprint`` 8: the person's light integrated over
    each pixel as a camera does, n x n sub-samples sharing out the body samples (0: at the pixel's
    centre, the recipe before it, which room models learned as a pattern: experiments/camera-photographs/robustness.py).
    ``footprint_jitter`` puts the footprint's sub-samples anywhere in their cells, a draw per set of
    people (``data.config.footprint_draw``; the shadow's relay sets use the same sets), instead of at
    the cells' centres: the centres' footprint mean is biased (about 7% at 8 x 8 in the copy room,
    falling as 1/n) and one fixed pattern for every person (experiments/camera-photographs/robustness.py)."""
    shadow: ShadowSampling = field(default_factory=lambda: dataclasses.replace(FIT_SHADOW))
    """How the light each body stops and bounces is sampled (``render.settings.ShadowSampling``,
    :data:`FIT_SHADOW`): ``shadow_samples`` static points relaying the spot light each person's body
    blocks (``nlos_shadow``, in every real with-minus-without photograph), rendered under the chosen
    spot and added to every training photograph (``fit/shadow.py``), 0 leaving it out (the recipe
    before it); ``shadow_depth`` and ``bounce_body_samples`` as :data:`FIT_SHADOW` says."""
    bounce: bool = True
    """Also each person's light over one more static bounce (``nlos_bounce``, ``render/bounce.py``:
    the room relaying the spot onto the body and the body's light to the camera; 24% of the
    person's light in the copy room), rendered in the shadow step through its relay points and
    added to every training photograph. Every photograph holds it: room models trained without it
    read photographs with it 33 points worse in the copy room (experiments/camera-photographs/robustness.py, ``bounce``
    rows); off is the recipe before it."""
    bounce_scale: float = 1.9
    """What training multiplies the stored ``nlos_bounce`` by (with ``bounce``; moot without, and
    recorded as 1):
    :data:`render.bounce.BOUNCE_TAIL` (1.9) stands in for every later bounce of the light off the
    body as Mitsuba measures them (1.8-2.0 in three reference scenes and the scanned copy room), 1
    the fifth bounce alone."""
    shadow_relay: str = "per-person"
    """The shadow's relay points: 'per-person' (each person its own strata offset, one of
    ``fit.shadow.RELAY_SETS`` a block, so that their sampling error is noise, not a pattern the
    network can learn) or 'fixed' (one set for all, the recipe before it)."""
    clothing: str = "camera-log"
    """Clothing albedos training redresses people in (exact: the light is linear in albedo):
    'camera-log' (0.03-0.9, black to white fabric, log-uniform in brightness: each decade of the
    person's light weighted alike, 35% of the draws under 0.1), 'camera' (the same range uniform in
    brightness, 8% under 0.1: the recipe before it) or 'dataset' (the rendered people's own
    0.08-0.65). Three scans, 100 held-out people each, camera photographs (experiments/dark-clothing):
    dark (0.05) clothing reads 62.1% / 14.3 cm on average against 'camera''s 56.0% / 16.7 cm (the
    office 60.4% against 45.2%: the issue's 10 points met in every room, where 'camera' misses it by
    4.6), the people's own clothing 64.4% / 15.4 cm against 60.9% / 14.3 cm: about 1 cm of error
    (8%) traded for the clothing real people wear."""
    epochs: float = 60.0
    """Passes over the training people (copyroom, 3,000 people, held-out six-way posture / error:
    10 -> 63% / 11.0 cm, 30 -> 74% / 11.6 cm (experiments/fit-budget/fit_budget.py), 60 -> 86% / 11.2 cm (the
    fit); 3.4 min on 2 cores beside 21.5 min of rendering)."""
    min_steps: int = 800
    """At least this many optimizer steps of 64 images."""
    workers: int = 0
    """Processes rendering people (one torch thread each); 0: one a core this process may use, as
    many as the memory holds (:func:`auto_workers`)."""
    render_device: str = "cpu"
    """Where people are rendered: 'cpu', 'cuda' or 'auto' (``render.settings.resolve_device``; an
    execution choice like ``workers``: a resumed fit may change it)."""
    capture_preset: str = "tripod"
    """Capture variation the room model is trained to survive (``render.variation``: ideal, tripod,
    rough); 'ideal' is the recipe before drift was modelled."""
    world_variation: str = "ideal"
    """Scan-versus-world calibration error the room model is trained to survive (the preset's camera
    pose, projector aim, albedo and scan-geometry fields, ``world.mismatch``): 'ideal' renders every
    person in the scan itself (the recipe before it); 'tripod' or 'rough' render the image samples
    under the chosen spot in ``fit.shadow.RELAY_SETS`` drawn worlds a block (``fit/shadow.py``). Measured
    in the copy room at 1,000 people, 'tripod' against 'ideal': posture better in some worlds, worse
    with jittered walls, position 2-6 cm worse everywhere (docs/results.md): not the default."""
    ceiling_people: int = 6
    """Held-out people the room's ceiling is computed on (``fit/ceiling.py``: an ideal observer's
    six-way posture and the position Cramer-Rao bound, in the report; about 0.5 min a person on 2
    cores); 0 leaves it out."""
    project_nuisance: bool = True
    """Under a capture variation, project its directions out of every photograph (``models.nuisance``)
    before the network reads it (False: the network alone learns to ignore the drift)."""

    FLAT_BLOCKS = ("render", "shadow")
    """Blocks whose fields a YAML file, a flag or an older (flat) ``fit.json`` may give by their own
    names (``config_file.nest``)."""

    def __post_init__(self) -> None:
        self._blocks()
        r, sh = self.render, self.shadow
        checks = {"people": 1, "heldout": 1, "ceiling_people": 0, "transport_people": 1, "burst_frames": 1, "resolution": 8,
                  "los_vertices": 8, "body_faces": 100, "min_steps": 0, "workers": 0}
        values = {**{k: getattr(self, k) for k in checks},
                  **{k: getattr(r, k) for k in ("person_samples", "pixel_samples", "transport_pixel_samples", "spot_samples")}}
        for k, v in values.items():
            lo = checks.get(k, 1)
            if isinstance(v, bool) or not isinstance(v, int) or v < lo:
                raise NlosError(f"fit: {k} must be an integer of at least {lo}, got {v!r}")
        from ..render.person import QUADRATURES

        if r.person_quadrature not in QUADRATURES:
            raise NlosError(f"fit: person_quadrature must be one of {', '.join(QUADRATURES)}, got {r.person_quadrature!r}")
        self._check_light()
        if isinstance(sh.shadow_samples, bool) or not isinstance(sh.shadow_samples, int) \
                or not 0 <= sh.shadow_samples <= 1_000_000:
            raise NlosError(f"fit: shadow_samples must be an integer from 0 (off) to 1000000, got {sh.shadow_samples!r}")
        if isinstance(sh.shadow_depth, bool) or not isinstance(sh.shadow_depth, int) or not 4 <= sh.shadow_depth <= 16:
            raise NlosError(f"--shadow-depth: expected an integer from 4 (the first relay alone) to 16, got {sh.shadow_depth!r}")
        if self.bounce is not False and (self.bounce is not True or sh.shadow_samples == 0):
            raise NlosError(f"--bounce: expected on or off, and on (the default) needs the shadow's relay points "
                            f"(shadow_samples > 0; add --bounce off), got {self.bounce!r} with shadow_samples "
                            f"{sh.shadow_samples}")
        n = sh.bounce_body_samples
        if isinstance(n, bool) or not isinstance(n, int) or not 0 <= n <= 1_000_000:
            raise NlosError(f"fit: bounce_body_samples must be an integer from 0 (the body's own) to 1000000, got {n!r}")
        scale = self.bounce_scale
        if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0 < scale <= 10:
            raise NlosError(f"--bounce-scale: expected a number in (0, 10], got {scale!r}")
        if self.shadow_relay not in ("per-person", "fixed"):
            raise NlosError(f"--shadow-relay: expected 'per-person' or 'fixed', got {self.shadow_relay!r}")
        if self.clothing not in CLOTHING:
            raise NlosError(f"--clothing: expected one of {', '.join(CLOTHING)}, got {self.clothing!r}")
        if not isinstance(r.pixel_footprint, int) or isinstance(r.pixel_footprint, bool) or not 0 <= r.pixel_footprint <= 64:
            raise NlosError(f"fit: pixel_footprint must be an integer from 0 (off) to 64, got {r.pixel_footprint!r}")
        if not isinstance(r.footprint_jitter, bool):
            raise NlosError(f"fit: footprint_jitter must be true or false, got {r.footprint_jitter!r}")
        from ..render.settings import DEVICES

        if self.render_device not in DEVICES:
            raise NlosError(f"--device: expected one of {', '.join(DEVICES)}, got {self.render_device!r}")
        if self.workers > MAX_WORKERS:
            raise NlosError(f"--workers: at most {MAX_WORKERS} processes (each holds a room's renderer; 0: one a "
                            f"core), got {self.workers}")
        if self.people > 100_000 or self.resolution > 256 or self.burst_frames > 1000:
            raise NlosError(f"fit: absurd size (people {self.people}, resolution {self.resolution}, "
                            f"burst {self.burst_frames})")
        e = self.epochs
        if isinstance(e, bool) or not isinstance(e, (int, float)) or not 0 < e <= 10_000:
            raise NlosError(f"--epochs: expected passes over the training people in (0, 10000], got {e!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or not 0 <= self.seed < 2 ** 63:
            raise NlosError(f"--seed: expected an integer from 0 to 2^63 - 1, got {self.seed}")
        from ..render.variation import preset

        try:
            preset(self.capture_preset)
        except NlosError as exc:
            raise NlosError(f"--capture-preset: {str(exc).split(': ', 1)[1]}") from None
        try:
            preset(self.world_variation)
        except NlosError as exc:
            raise NlosError(f"--world-variation: {str(exc).split(': ', 1)[1]}") from None
        if self.world_variation != "ideal" and sh.shadow_samples == 0:
            raise NlosError("--world-variation renders the people again with their shadow: it needs --shadow-samples > 0")
        from ..evaluate.methods import LIGHTS, UNAIMED, fit_method, unaimed_method

        m = fit_method(self.method)
        if self.policy not in POLICIES and not (self.policy in UNAIMED and self.policy == m.policy):
            hint = f" (it lights no spot: --method {unaimed_method(self.policy)})" if self.policy in UNAIMED else ""
            raise NlosError(f"--policy: expected one of {', '.join(POLICIES)}, got {self.policy!r}{hint}")
        if self.method != "ours" and self.policy != m.policy:
            what = (f"lights no spot ({LIGHTS[m.policy].words}: policy {m.policy})" if m.policy in UNAIMED
                    else f"aims with the {m.policy} spot")
            raise NlosError(f"--method {self.method} {what}, not --policy {self.policy}")
        if (self.policy == "ien") != bool(self.checkpoint):
            raise NlosError("--policy ien needs --checkpoint RUN (a run trained with policy 'ien'), "
                            "and --checkpoint goes only with --policy ien")

    def _blocks(self) -> None:
        """The sampling blocks as their dataclasses (a mapping of their fields, as a record writes
        them, over :data:`FIT_SAMPLING` / :data:`FIT_SHADOW`; ``config_file.as_block``)."""
        from ..config_file import as_block

        self.render = as_block(self.render, FIT_SAMPLING, "fit: render")
        self.shadow = as_block(self.shadow, FIT_SHADOW, "fit: shadow")

    @property
    def light(self) -> str:
        """What lights the photographs: 'spot' (aimed), or the policy of a method that lights none
        ('flash', 'ambient': ``evaluate.methods.UNAIMED``)."""
        from ..evaluate.methods import fit_method, light_of

        return light_of(fit_method(self.method).policy)

    def _check_light(self) -> None:
        """Refuse, in one line, a setting that renders a spot's term when the method lights no spot."""
        from ..evaluate.methods import LIGHTS

        if self.light == "spot":
            return
        why = f"--method {self.method} lights no spot ({LIGHTS[self.light].words})"
        spot_only = ((self.bounce is not False, "--bounce on", "the bounce relays the spot's light", "--bounce off"),
                     (self.shadow.shadow_samples != 0, f"--shadow-samples {self.shadow.shadow_samples}",
                      "the body's shadow is rendered under a spot only", "--shadow-samples 0"),
                     (self.world_variation != "ideal", f"--world-variation {self.world_variation}",
                      "the drawn worlds are rendered under the spot", "--world-variation ideal"),
                     (self.capture_preset != "ideal", f"--capture-preset {self.capture_preset}",
                      "capture drift is modelled for the spot's light only", "--capture-preset ideal"))
        for bad, flag, reason, fix in spot_only:
            if bad:
                raise NlosError(f"{flag}: {reason}, and {why}; give {fix}")

    @property
    def samples(self) -> int:
        """People rendered in all: full-transport, training, validation and test."""
        return self.transport_people + self.people + 2 * self.heldout

    def to_dict(self) -> dict:
        """The record (``fit.json``'s settings). Without the bounce (the shadow) its settings are moot
        and recorded as the recipe before them (:data:`BEFORE`), so a fit without it matches an older
        one's record."""
        d = dataclasses.asdict(self)
        if not self.bounce:
            d["bounce_scale"] = BEFORE["bounce_scale"]
            d["shadow"]["bounce_body_samples"] = BEFORE["bounce_body_samples"]
        if not self.shadow.shadow_samples:
            d["shadow"]["shadow_depth"] = BEFORE["shadow_depth"]
        return d

    @classmethod
    def from_record(cls, settings: dict) -> "FitConfig":
        """The config a room model was fitted with (``fit.json``'s settings): a setting its version
        did not have yet takes the value that version used (:data:`BEFORE`), not today's default;
        flat (before the sampling blocks) or nested."""
        from ..config_file import nest

        return cls(**{k: v for k, v in nest(cls, recorded(settings)).items() if k in cls.__dataclass_fields__})


UNAIMED_DEFAULTS = {"shadow_samples": 0, "bounce": False, "capture_preset": "ideal"}
"""What ``nlos fit --method tancik|dlnlos`` sets where no flag or config file says: the settings
without a spot term (``FitConfig._check_light`` refuses any other value)."""


MAX_WORKERS = 256
"""Most rendering processes a fit starts (each holds the room's renderer and its people in flight)."""
WORKER_BYTES = 1.8e9
"""Memory :func:`auto_workers` sets aside a rendering process: the room's renderer and its people in
flight. Measured (``report.json``'s ``peak_memory_mb``, each process's own ``VmHWM``): ``make
demo``'s copy-room fit peaked at 1,612 MiB (1.69 GB) in its largest rendering process and 1,688
MiB in the demo's own process (session 17; session 16's 1,450 MB for the rendering process read
``ru_maxrss``, which counts a spawned process's parent's peak). The default's sampling (twice the relay points, four
times the bounce's body samples) was not measured."""


def auto_workers(workers: int, device: str = "cpu", cores: int | None = None,
                 available_bytes: float | None = None) -> int:
    """The rendering processes of ``FitConfig.workers``: itself when given; for 0, one a core this
    process may use (its CPU affinity), no more than the available memory holds at
    :data:`WORKER_BYTES` each, at least one; on a GPU one process (each would hold its own CUDA
    context; give a count to try more).
    ``cores`` and ``available_bytes`` replace what this machine says (tests)."""
    if workers > 0:
        return workers
    from ..render.settings import resolve_device

    if resolve_device(device) != "cpu":
        return 1
    if cores is None:
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    if available_bytes is None:
        available_bytes = _available_memory()
    by_memory = int(available_bytes // WORKER_BYTES) if available_bytes is not None else cores
    return max(1, min(cores, by_memory, MAX_WORKERS))


def _available_memory() -> float | None:
    """Bytes the system can give new processes (Linux's MemAvailable), or None where unknown."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    return None


BEFORE = {"pixel_samples": 2, "transport_pixel_samples": 1, "spot_samples": 16, "method": "ours", "capture_preset": "ideal", "project_nuisance": True, "pixel_footprint": 0, "footprint_jitter": False, "shadow_samples": 0,
          "clothing": "dataset", "bounce": False, "bounce_scale": 1.0, "bounce_body_samples": 0, "shadow_depth": 4, "shadow_relay": "fixed", "world_variation": "ideal", "ceiling_people": 0}
"""What a room model fitted before each of these settings existed did (see their docstrings)."""





def recorded(settings: dict) -> dict:
    """A ``fit.json``'s settings, flat (``config_file.flatten``: the sampling blocks' fields by their
    own names, as they are compared), with those its version did not have yet at the value that
    version used (:data:`BEFORE`): a setting added since is no difference where it keeps that behaviour."""
    from ..config_file import flatten

    return {**BEFORE, **flatten(FitConfig, settings)} if isinstance(settings, dict) else settings


PRESETS = {
    "default": FitConfig(),
    # tests and a first look: tens of people, coarse bodies, seconds to a minute
    "tiny": FitConfig(name="tiny", people=40, heldout=10, transport_people=3, burst_frames=4, resolution=16,
                      los_vertices=40, body_faces=400,
                      render=dataclasses.replace(FIT_SAMPLING, person_samples=96, person_quadrature="mc", pixel_footprint=2),
                      shadow=dataclasses.replace(FIT_SHADOW, shadow_samples=128),
                      epochs=2.0,
                      min_steps=20, workers=1, ceiling_people=1),
    # make demo: a real scan fitted in under 20 minutes on 2 cores (600 people, 30 epochs). The shadow
    # step (each person's shadow and bounce) was 25 of its 37 minutes at the default's sampling; half
    # the relay points and a quarter of the bounce's body samples make it 2.8x faster (545 s against
    # 1,527 s, each demo's timing.json; the bounce 6% from the body's own quadrature, under its relay
    # noise: docs/results/bounce-body-samples.txt)
    "demo": FitConfig(name="demo", people=600, heldout=60, transport_people=16, epochs=30.0, min_steps=300,
                      ceiling_people=2, shadow=dataclasses.replace(FIT_SHADOW, shadow_samples=2048, bounce_body_samples=256)),
}
