"""The hidden person: posed, decimated and cached bodies of the Anny parametric model.

Model: ``anny`` (PyPI, Apache-2.0 code, CC0-1.0 MakeHuman data; see ``docs/body-model.md``),
loaded once per process (:func:`anny_model`), posed on the CPU by bone rotations, offline.

Frames. Anny works in its own frame: z up, meters, the body's front is -y, its left side +x,
the root bone (pelvis) at the origin. A library body is stored in the *canonical* frame: the
front turned to +x (the body's left is then +y), the pelvis above (0, 0) and the soles on z = 0.
:func:`posed_body` only scales and turns a stored body, so a person costs milliseconds once the
library is on disk.

Postures are targets for the directions of ten body segments (upper arms, forearms, thighs,
shins, torso, neck) in the body frame; each segment's bone gets the rotation that brings its
reference direction onto the target (the smallest rotation, so no twist is introduced), its
descendants follow, and the feet are kept level. The "unknown" posture draws random segment
directions within anatomical bounds and rejects any draw whose RMS angle to one of the five
named postures is below :data:`UNKNOWN_MIN_DISTANCE_DEG`.

Cache scheme (:class:`BodyCache`). A library entry is keyed by
``(posture, build bucket, pose variant)`` and the decimation target:

* build bucket: gender, weight, muscle and proportions snapped to the nearest level of
  :data:`BUILD_LEVELS`, and the requested height to the nearest of :data:`STATURE_LEVELS_M`
  (Anny's height phenotype is solved so that the body is about that tall, so the final uniform
  scale stays within +-4% and barely changes the build);
* pose variant: ``pose_seed % variants_per_posture``; the variant seeds the pose jitter and,
  for "unknown", the gesture (together with posture and bucket, so every bucket has its own).

Entries are ``.npz`` files under ``<root>/<library_tag()>/f<target_faces>/<posture>/``,
written to a temporary file in the same folder and renamed with ``os.replace`` (atomic: a
reader sees a whole file or none, and concurrent writers of one key write identical bytes).
"""

from __future__ import annotations

import contextlib
import gzip
import inspect
import io
import math
import os
import tempfile
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import NlosError
from ..scene.decimate import DECIMATION_TRIES as _DECIMATION_TRIES  # part of library_tag's digest
from ..scene.decimate import decimate_closed, largest_part
from ..scene.format import TriMesh

POSTURES = ("standing", "sitting", "crouching", "hands_90", "hands_45", "unknown")
"""Posture classes, in the class-index order of the networks."""

HEIGHT_RANGE_M = (1.52, 1.89)
"""Standing heights of the people, m (5 ft to 6 ft 2 in)."""

BUILD_LEVELS: dict[str, tuple[float, ...]] = {
    "gender": (0.0, 0.5, 1.0),
    "weight": (0.15, 0.5, 0.85),
    "muscle": (0.3, 0.7),
    "proportions": (0.2, 0.8),
}
"""Lattice of Anny phenotype values (all in [0, 1]) that the cached builds use."""

STATURE_LEVELS_M = (1.58, 1.705, 1.83)
"""Standing heights the cached builds are made at, before the exact uniform scale."""

ADULT_AGE = 0.8
"""Anny age phenotype of every body: about 40 years by Anny's morphological-age calibration
(0.77 is 18 years, 0.83 is 64); the adult body shape changes little with age."""

UNKNOWN_MIN_DISTANCE_DEG = 25.0
"""Least RMS segment angle between an "unknown" gesture and each named posture."""

JITTER_DEG = 2.5
"""Standard deviation of the pose jitter, per rotation axis, degrees."""

DEFAULT_VARIANTS = 8
"""Pose variants per (posture, build bucket) in the library."""

LIBRARY_VERSION = 1
"""Bump when the posing or decimation code or the file layout change. Changes of the constants
in this module change the library folder by themselves (see :func:`library_tag`)."""

_LIBRARY_SEED = 0x4E4C4F53  # fixes the library's randomness independently of the callers' seeds

# Segments: name -> (bone whose rotation is set, bone whose head ends the segment).
SEGMENTS: dict[str, tuple[str, str]] = {
    "upperarm.L": ("upperarm01.L", "lowerarm01.L"),
    "upperarm.R": ("upperarm01.R", "lowerarm01.R"),
    "forearm.L": ("lowerarm01.L", "wrist.L"),
    "forearm.R": ("lowerarm01.R", "wrist.R"),
    "thigh.L": ("upperleg01.L", "lowerleg01.L"),
    "thigh.R": ("upperleg01.R", "lowerleg01.R"),
    "shin.L": ("lowerleg01.L", "foot.L"),
    "shin.R": ("lowerleg01.R", "foot.R"),
    "torso": ("spine05", "neck01"),
    "neck": ("neck01", "head"),
}
_LEVEL_BONES = ("foot.L", "foot.R")  # kept in their reference (level) orientation, see _free_feet

JOINTS = ("root", "spine05", "neck01", "head",
          "upperarm01.L", "lowerarm01.L", "wrist.L", "finger3-1.L", "upperleg01.L", "lowerleg01.L", "foot.L",
          "upperarm01.R", "lowerarm01.R", "wrist.R", "finger3-1.R", "upperleg01.R", "lowerleg01.R", "foot.R")
"""Skeleton joints (Anny bone heads) stored with each library body: the ends of the posed
segments, the pelvis (``root``) and the knuckles of the middle fingers (``finger3-1``)."""

# Anny frame unit vectors: front, the body's left, up.
_F = np.array([0.0, -1.0, 0.0])
_L = np.array([1.0, 0.0, 0.0])
_U = np.array([0.0, 0.0, 1.0])
# Anny frame -> canonical frame: a quarter turn about z takes the front (-y) to +x.
_TO_CANONICAL = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


# --------------------------------------------------------------------------- parameters

@dataclass
class BodyParams:
    """Everything that makes one hidden person."""

    posture: str
    """One of :data:`POSTURES`."""
    height_m: float
    """Standing height (soles to crown) in meters, within :data:`HEIGHT_RANGE_M`; a sitting or
    crouching body is the same person folded, so it is lower."""
    gender: float = 0.5
    """Anny gender phenotype in [0, 1]: 0 male, 1 female."""
    weight: float = 0.5
    """Anny weight phenotype in [0, 1]: 0 thin, 1 heavy."""
    muscle: float = 0.5
    """Anny muscle phenotype in [0, 1]: 0 little muscle tone, 1 muscular."""
    proportions: float = 0.5
    """Anny proportions phenotype in [0, 1]: 0 ideal, 1 uncommon body proportions."""
    facing_deg: float = 0.0
    """Rotation about z, degrees; 0 means the body faces +x, 90 faces +y."""
    albedo: np.ndarray = field(default_factory=lambda: np.full(3, 0.4))
    """(3,) clothing/skin albedo in [0, 1] (the scene's ``human.albedo``)."""
    pose_seed: int = 0
    """Seed of the pose jitter (and of the gesture for "unknown"); selects a library variant."""

    def validate(self) -> None:
        """Raise :class:`NlosError` naming the first bad field."""
        if self.posture not in POSTURES:
            raise NlosError(f"body: unknown posture {self.posture!r} (known: {', '.join(POSTURES)})")
        _finite(self.height_m, "height_m")
        lo, hi = HEIGHT_RANGE_M
        if not lo - 1e-9 <= self.height_m <= hi + 1e-9:
            raise NlosError(f"body: height_m {self.height_m!r} outside [{lo}, {hi}]")
        for name in BUILD_LEVELS:
            value = _finite(getattr(self, name), name)
            if not 0.0 <= value <= 1.0:
                raise NlosError(f"body: {name} {value!r} outside [0, 1]")
        _finite(self.facing_deg, "facing_deg")
        albedo = np.asarray(self.albedo, dtype=np.float64)
        if albedo.shape != (3,) or not np.all(np.isfinite(albedo)):
            raise NlosError(f"body: albedo must be 3 finite numbers, got {self.albedo!r}")
        if np.any(albedo < 0) or np.any(albedo > 1):
            raise NlosError(f"body: albedo {albedo.tolist()} outside [0, 1]")
        if isinstance(self.pose_seed, bool) or not isinstance(self.pose_seed, (int, np.integer)):
            raise NlosError(f"body: pose_seed must be an integer, got {self.pose_seed!r}")


def _finite(value, name: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise NlosError(f"body: {name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise NlosError(f"body: {name} is not finite ({value!r})")
    return x


def sample_body_params(rng: np.random.Generator, posture: str | None = None) -> BodyParams:
    """Draw a person: uniform height, build, facing and posture (unless given), clothing albedo."""
    if posture is not None and posture not in POSTURES:
        raise NlosError(f"body: unknown posture {posture!r} (known: {', '.join(POSTURES)})")
    chosen = POSTURES[int(rng.integers(len(POSTURES)))] if posture is None else posture
    return BodyParams(
        posture=chosen,
        height_m=float(rng.uniform(*HEIGHT_RANGE_M)),
        gender=float(rng.uniform(0.0, 1.0)),
        weight=float(rng.uniform(0.05, 0.95)),
        muscle=float(rng.uniform(0.1, 0.9)),
        proportions=float(rng.uniform(0.0, 1.0)),
        facing_deg=float(rng.uniform(0.0, 360.0)),
        albedo=_clothing_albedo(rng),
        pose_seed=int(rng.integers(0, 2**31 - 1)),
    )


CLOTHING_BRIGHTNESS = (0.08, 0.65)
"""Range of a person's clothing brightness (uniform), shared by every channel."""
CLOTHING_TINT_SIGMA = 0.25
"""Standard deviation of the log per-channel tint."""
CLOTHING_ALBEDO_RANGE = (0.05, 0.8)
"""Every channel is clipped to this range."""


def _clothing_albedo(rng: np.random.Generator) -> np.ndarray:
    """Fabric-like RGB: one brightness for all channels times a mild per-channel tint, so the
    channels are strongly correlated (real clothing is rarely a saturated primary)."""
    brightness = rng.uniform(*CLOTHING_BRIGHTNESS)
    tint = np.exp(rng.normal(0.0, CLOTHING_TINT_SIGMA, size=3))
    return np.clip(brightness * tint / tint.mean(), *CLOTHING_ALBEDO_RANGE)


CAMERA_CLOTHING = ((0.03, 0.9), (0.02, 0.95))
"""Brightness and channel range of clothing a camera meets: black fabric (diffuse reflectance
0.02-0.05) to white cotton (0.8-0.9). The rendered people's own range (:data:`CLOTHING_BRIGHTNESS`)
leaves both ends out; room models are trained on this one (``nlos fit``: log-uniform, ``--clothing camera-log``)."""
CLOTHING_RANGES = {"dataset": (CLOTHING_BRIGHTNESS, CLOTHING_ALBEDO_RANGE), "camera": CAMERA_CLOTHING,
                   "camera-log": CAMERA_CLOTHING}
"""Named clothing distributions of :func:`clothing_albedo`."""
LOG_BRIGHTNESS = ("camera-log",)
"""Distributions whose brightness is log-uniform over their range: as many people from 0.03 to
0.1 as from 0.3 to 0.9 (35% under 0.1, where uniform puts 8%): dark fabric gives the walls a tenth
of white's light, so a network sees it rarely and learns it last."""


def clothing_albedo(n: int, generator: "torch.Generator | None" = None, device="cpu",
                    kind: str = "dataset") -> "torch.Tensor":
    """(n, 3) clothing albedos drawn as :func:`_clothing_albedo` draws one, in torch (training-time
    albedo augmentation draws with the run's generator), from the :data:`CLOTHING_RANGES` ``kind``:
    the dataset's own distribution or the wider one of real clothing (log-uniform in brightness for
    :data:`LOG_BRIGHTNESS`)."""
    import torch

    (lo, hi), clip = CLOTHING_RANGES[kind]
    u = torch.rand(n, 1, generator=generator, device=device)
    brightness = lo * (hi / lo) ** u if kind in LOG_BRIGHTNESS else lo + (hi - lo) * u
    tint = torch.exp(CLOTHING_TINT_SIGMA * torch.randn(n, 3, generator=generator, device=device))
    return (brightness * tint / tint.mean(1, keepdim=True)).clamp(*clip)


def build_bucket(params: BodyParams) -> tuple[int, ...]:
    """Indices of the nearest :data:`BUILD_LEVELS` (in their order) and :data:`STATURE_LEVELS_M`."""
    idx = [int(np.argmin(np.abs(np.asarray(levels) - getattr(params, name))))
           for name, levels in BUILD_LEVELS.items()]
    idx.append(int(np.argmin(np.abs(np.asarray(STATURE_LEVELS_M) - params.height_m))))
    return tuple(idx)


# --------------------------------------------------------------------------- postures

def _n(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: rotation by ``angle`` radians about the unit ``axis``."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def _align(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking direction ``a`` to direction ``b``."""
    a, b = _n(a), _n(b)
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), float(np.dot(a, b))
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        perp = np.cross(a, _L if abs(a[0]) < 0.9 else _U)
        return _rotation(_n(perp), math.pi)
    return _rotation(axis / s, math.atan2(s, c))


def _sides(left: np.ndarray, name: str) -> dict[str, np.ndarray]:
    """A left-side direction and its mirror image (x -> -x) for the right side."""
    return {f"{name}.L": _n(left), f"{name}.R": _n(left * np.array([-1.0, 1.0, 1.0]))}


def _named_posture(posture: str) -> dict[str, np.ndarray]:
    """Segment target directions (Anny frame) of the five named postures, without jitter."""
    F, L, U = _F, _L, _U
    legs_straight = {**_sides(-U + 0.08 * L, "thigh"), **_sides(-U + 0.08 * L, "shin")}
    upright = {"torso": _n(U), "neck": _n(U + 0.37 * F)}   # the neck's natural forward tilt
    if posture == "standing":
        arms = {**_sides(-U + 0.22 * L + 0.03 * F, "upperarm"), **_sides(-U + 0.16 * L + 0.15 * F, "forearm")}
        return {**arms, **legs_straight, **upright}
    if posture == "hands_90":    # arms raised sideways to horizontal, elbows straight
        arms = {**_sides(L + 0.05 * F, "upperarm"), **_sides(L + 0.08 * F, "forearm")}
        return {**arms, **legs_straight, **upright}
    if posture == "hands_45":    # upper arms raised sideways 45 degrees, forearms a bit more, as when waving
        arms = {**_sides(-U + L + 0.05 * F, "upperarm"), **_sides(-U + 2.1 * L + 0.12 * F, "forearm")}
        return {**arms, **legs_straight, **upright}
    if posture == "sitting":     # as on a chair: thighs level, knees at 90 degrees, hands on the lap
        return {**_sides(-U + 0.15 * L + 0.35 * F, "upperarm"), **_sides(F - 0.12 * U + 0.05 * L, "forearm"),
                **_sides(F + 0.12 * L, "thigh"), **_sides(-U + 0.05 * L, "shin"),
                "torso": _n(U - 0.2 * F), "neck": _n(U + 0.45 * F)}   # leaning back ~11 degrees
    if posture == "crouching":   # deep squat: hips at knee height, knees apart, torso leaning forward
        return {**_sides(-U + 0.6 * F + 0.15 * L, "upperarm"), **_sides(-0.7 * U + F - 0.1 * L, "forearm"),
                **_sides(F + 0.2 * U + 0.45 * L, "thigh"), **_sides(-U - 0.65 * F + 0.05 * L, "shin"),
                "torso": _n(U + 0.75 * F), "neck": _n(U + 0.45 * F)}
    raise NlosError(f"body: unknown posture {posture!r} (known: {', '.join(POSTURES)})")


NAMED_POSTURES = POSTURES[:5]
"""The five postures with a fixed definition; "unknown" is everything far from them."""


def posture_directions(posture: str) -> dict[str, np.ndarray]:
    """Segment directions (unit vectors) of a named posture without jitter, in the body frame
    of a person with ``facing_deg = 0``: front +x, the body's left +y, z up."""
    if posture == "unknown":
        raise NlosError("body: 'unknown' has no canonical directions (it is anything far from the others)")
    return {k: _TO_CANONICAL @ v for k, v in _named_posture(posture).items()}


def joint_directions(joints: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Segment directions (unit vectors) measured on posed joints (:func:`posed_joints`)."""
    return {seg: _n(joints[end] - joints[bone]) for seg, (bone, end) in SEGMENTS.items()}


def pose_distance_deg(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> float:
    """RMS over :data:`SEGMENTS` of the angle between the two poses' segment directions, degrees."""
    angles = [math.degrees(math.acos(float(np.clip(np.dot(_n(a[s]), _n(b[s])), -1.0, 1.0)))) for s in SEGMENTS]
    return float(np.sqrt(np.mean(np.square(angles))))


def _sagittal(flexion_deg: float) -> np.ndarray:
    """Direction in the sagittal plane: 0 = straight down, 90 = forward, -90 = backward."""
    a = math.radians(flexion_deg)
    return -_U * math.cos(a) + _F * math.sin(a)


def _random_arm(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Left upper arm and forearm directions of a random, anatomically bounded arm gesture."""
    elevation = math.radians(rng.uniform(0.0, 170.0))    # from hanging
    plane = math.radians(rng.uniform(-30.0, 110.0))      # 0 sideways, 90 forward, >90 across the body
    upper = -_U * math.cos(elevation) + math.sin(elevation) * (math.cos(plane) * _L + math.sin(plane) * _F)
    tilt = math.radians(rng.uniform(0.0, 90.0))          # the elbow bends the hand forward ... up
    bend_to = _n(_F * math.cos(tilt) + _U * math.sin(tilt))
    axis = np.cross(upper, bend_to)
    if np.linalg.norm(axis) < 1e-6:
        return _n(upper), _n(upper)
    fore = _rotation(_n(axis), math.radians(rng.uniform(0.0, 130.0))) @ upper   # elbow flexion
    return _n(upper), _n(fore)


def _random_legs(rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Legs of a random gesture: one leg raised, a wide stance, or standing."""
    mirror = np.array([-1.0, 1.0, 1.0])
    legs = {**_sides(-_U + 0.08 * _L, "thigh"), **_sides(-_U + 0.08 * _L, "shin")}
    u = rng.random()
    if u < 0.45:                                     # one leg raised, knee bent, on the other foot
        side = "L" if rng.random() < 0.5 else "R"
        hip, knee = rng.uniform(20.0, 95.0), rng.uniform(0.0, 110.0)
        # a positive turn about the front axis swings a hanging leg towards the body's left
        abduct = _rotation(_F, math.radians(rng.uniform(0.0, 35.0)) * (1 if side == "L" else -1))
        legs[f"thigh.{side}"] = _n(abduct @ _sagittal(hip))
        legs[f"shin.{side}"] = _n(abduct @ _sagittal(hip - knee))
    elif u < 0.75:                                   # wide stance, both legs straight
        for side, m in (("L", np.ones(3)), ("R", mirror)):
            d = _rotation(_F, math.radians(rng.uniform(12.0, 30.0))) @ -_U
            legs[f"thigh.{side}"] = legs[f"shin.{side}"] = _n(d * m)
    return legs


def _free_feet(directions: dict[str, np.ndarray]) -> set[str]:
    """Sides whose shin is more than 45 degrees from vertical: that foot follows the shin
    (a rigid ankle); the other feet are kept level, as on the floor."""
    return {s for s in ("L", "R") if directions[f"shin.{s}"][2] > -math.cos(math.radians(45.0))}


def unknown_directions(rng: np.random.Generator, jitter_deg: float = JITTER_DEG,
                       max_tries: int = 1000) -> dict[str, np.ndarray]:
    """A random, jittered gesture at least :data:`UNKNOWN_MIN_DISTANCE_DEG` from every named posture."""
    named = [_named_posture(p) for p in NAMED_POSTURES]
    for _ in range(max_tries):
        left_upper, left_fore = _random_arm(rng)
        right_upper, right_fore = _random_arm(rng)
        mirror = np.array([-1.0, 1.0, 1.0])
        bend, lean = math.radians(rng.uniform(0.0, 45.0)), math.radians(rng.uniform(-20.0, 20.0))
        d = {"upperarm.L": left_upper, "forearm.L": left_fore,
             "upperarm.R": _n(right_upper * mirror), "forearm.R": _n(right_fore * mirror),
             "torso": _n(_U + math.tan(bend) * _F + math.tan(lean) * _L),
             "neck": _n(_U + rng.uniform(0.0, 0.7) * _F + rng.uniform(-0.4, 0.4) * _L),
             **_random_legs(rng)}
        d = _jitter(d, rng, jitter_deg)   # checked after the jitter: what is posed is what is tested
        if min(pose_distance_deg(d, n) for n in named) >= UNKNOWN_MIN_DISTANCE_DEG:
            return d
    raise NlosError("body: could not draw an 'unknown' gesture far from the named postures")


def _jitter(directions: dict[str, np.ndarray], rng: np.random.Generator, sigma_deg: float) -> dict[str, np.ndarray]:
    """Turn every segment direction by a small random rotation (sigma per axis, clipped at 3 sigma)."""
    out = {}
    for name in SEGMENTS:
        rotvec = np.clip(rng.normal(0.0, math.radians(sigma_deg), 3), -3 * math.radians(sigma_deg),
                         3 * math.radians(sigma_deg))
        angle = float(np.linalg.norm(rotvec))
        rot = _rotation(rotvec / angle, angle) if angle > 0 else np.eye(3)
        out[name] = _n(rot @ directions[name])
    return out


def pose_directions(posture: str, bucket: tuple[int, ...], variant: int) -> dict[str, np.ndarray]:
    """The library's segment targets (Anny frame) for one key: the posture (drawn for "unknown")
    plus jitter."""
    seq = np.random.SeedSequence([_LIBRARY_SEED, POSTURES.index(posture), *bucket, int(variant)])
    rng = np.random.default_rng(seq)
    if posture == "unknown":
        return unknown_directions(rng, JITTER_DEG)
    return _jitter(_named_posture(posture), rng, JITTER_DEG)


# --------------------------------------------------------------------------- the Anny model

_MODEL = None
_MODEL_LOCK = threading.Lock()
MODEL_LOAD_SECONDS: float | None = None
"""Wall time the process spent in :func:`anny_model`'s first call (None before it)."""


def _load_target_fast(filename, vertices_count, world_transformation, dtype):
    """Drop-in for ``anny.models.full_model.load_blend_shape`` (anny 0.6.2): the same parse
    (Python float conversion, the last line of a repeated vertex wins) vectorized with numpy."""
    import torch

    with gzip.open(filename, "rt") as fh:
        table = np.array(fh.read().split(), dtype=np.float64).reshape(-1, 4)
    ids = table[:, 0].astype(np.int64)
    if np.any(ids != table[:, 0]) or np.any(ids < 0) or np.any(ids >= vertices_count):
        raise ValueError(f"bad vertex index in {filename}")
    _, last_rev = np.unique(ids[::-1], return_index=True)
    keep = len(ids) - 1 - last_rev
    blend_shape = torch.zeros((vertices_count, 3), dtype=dtype)
    blend_shape[torch.from_numpy(ids[keep])] = torch.as_tensor(table[keep, 1:], dtype=dtype)
    return world_transformation.apply(blend_shape)


@contextlib.contextmanager
def _fast_target_parser():
    """Speed up Anny's first build of its asset cache (93 s -> 15 s measured on 2 cores).

    anny 0.6.2 parses its 1136 MakeHuman ``.target.gz`` files line by line in Python. Our
    parser gives tensors identical to the original's (checked on every tensor of Anny's
    cache files); it is used only for this exact anny version and only during construction.
    """
    import anny
    import anny.models.full_model as full_model

    original = getattr(full_model, "load_blend_shape", None)
    expected = ["filename", "vertices_count", "world_transformation", "dtype"]
    if (anny.__version__ != "0.6.2" or original is None
            or list(inspect.signature(original).parameters) != expected):
        yield
        return
    full_model.load_blend_shape = _load_target_fast
    try:
        yield
    finally:
        full_model.load_blend_shape = original


def anny_model():
    """The process-wide Anny model (rig ``anny``, topology ``anny``, float64, torch skinning).

    The first call builds Anny's own asset cache if it is missing (``$ANNY_CACHE_DIR`` or
    ``~/.cache/anny``, about 0.8 GB, 15-55 s on 2 cores) and otherwise loads it (1.5-4 s).
    Nothing is downloaded: this rig and topology ship with the wheel (only Anny's SMPL/SMPL-X
    topologies, which we never ask for, would fetch non-commercial files).
    """
    global _MODEL, MODEL_LOAD_SECONDS
    with _MODEL_LOCK:
        if _MODEL is None:
            start = time.perf_counter()
            try:
                import anny
            except ImportError as exc:  # pragma: no cover - a declared dependency
                raise NlosError("body: human bodies need the 'anny' package (pip install anny==0.6.2)") from exc
            with _fast_target_parser():
                # "lbs" skinning is plain torch: no warp kernel compile, no CUDA probing.
                _MODEL = anny.Anny(rig="anny", topology="anny", skinning_method="lbs")
            MODEL_LOAD_SECONDS = time.perf_counter() - start
        return _MODEL


@dataclass
class _Build:
    """One build bucket's rest state, shared by all its postures and variants."""

    rest: dict                # Anny rest model (vertices, bone poses)
    ref_heads: np.ndarray     # (J, 3) bone heads of the reference pose (identity deltas)
    phenotype: dict[str, float]
    standing_height: float    # soles-to-crown height of the canonical standing pose, m


_BUILDS: dict[tuple[int, ...], _Build] = {}
_BUILDS_LOCK = threading.Lock()


def _phenotype(bucket: tuple[int, ...], height: float) -> dict[str, float]:
    values = {name: levels[i] for (name, levels), i in zip(BUILD_LEVELS.items(), bucket)}
    return {**values, "age": ADULT_AGE, "height": height}


def _rest(model, phenotype: dict[str, float]) -> tuple[dict, np.ndarray, np.ndarray]:
    """Anny's rest state for a phenotype, and the reference pose (all deltas identity):
    its skinned vertices (V, 3) and bone heads (J, 3), Anny frame."""
    import torch

    with torch.no_grad():
        out = model(phenotype_kwargs={k: float(v) for k, v in phenotype.items()})
    rest = {"rest_vertices": out["rest_vertices"], "rest_bone_poses": out["rest_bone_poses"]}
    vertices = out["vertices"][0].numpy().astype(np.float64)
    return rest, vertices, out["bone_poses"][0, :, :3, 3].numpy().astype(np.float64)


def _pose(model, rest: dict, deltas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Skinned vertices (V, 3) and bone heads (J, 3), Anny frame, for (J, 3, 3) local rotations."""
    import torch

    with torch.no_grad():
        d = torch.eye(4, dtype=model.dtype).repeat(1, model.bone_count, 1, 1)
        d[0, :, :3, :3] = torch.as_tensor(deltas, dtype=model.dtype)
        transforms, poses = model.get_bone_transforms(d, rest["rest_bone_poses"])
        verts = model.get_skinned_vertices(rest["rest_vertices"], transforms)
    return verts[0].numpy().astype(np.float64), poses[0, :, :3, 3].numpy().astype(np.float64)


def _get_build(bucket: tuple[int, ...]) -> _Build:
    """Solve Anny's height phenotype for the bucket's stature level, then measure the standing height."""
    with _BUILDS_LOCK:
        if bucket in _BUILDS:
            return _BUILDS[bucket]
    model = anny_model()
    target = STATURE_LEVELS_M[bucket[-1]]
    # Vertices are linear in the height phenotype (two blend anchors), so two probes solve it;
    # the probes measure the reference (A) pose, the exact standing height is measured below.
    probes = [np.ptp(_rest(model, _phenotype(bucket, h))[1][:, 2]) for h in (0.0, 1.0)]
    h = float(np.clip((target - probes[0]) / (probes[1] - probes[0]), 0.0, 1.0))
    phenotype = _phenotype(bucket, h)
    rest, _, ref_heads = _rest(model, phenotype)
    verts, _ = _pose(model, rest, _deltas(model, ref_heads, _named_posture("standing")))
    build = _Build(rest, ref_heads, phenotype, float(np.ptp(verts[_body_vertices(model), 2])))
    with _BUILDS_LOCK:
        return _BUILDS.setdefault(bucket, build)


def _deltas(model, ref_heads: np.ndarray, directions: dict[str, np.ndarray]) -> np.ndarray:
    """Local rotations (J, 3, 3) for Anny's "local-ref" parameterization.

    With "local-ref" deltas a bone's world rotation relative to the reference pose is
    ``G_c = G_parent @ D_c``. We set G for each segment bone (the smallest rotation from its
    reference direction to the target) and for the feet (identity: level), let every other
    bone inherit its parent's G, and return ``D_c = G_parent^T G_c``.
    """
    index = {name: i for i, name in enumerate(model.bone_labels)}
    target_g = {}
    for seg, (bone, end) in SEGMENTS.items():
        ref_dir = ref_heads[index[end]] - ref_heads[index[bone]]
        target_g[index[bone]] = _align(ref_dir, directions[seg])
    free = _free_feet(directions)
    for foot in _LEVEL_BONES:
        if foot[-1] not in free:
            target_g[index[foot]] = np.eye(3)
    parents = model.bone_parents
    g = np.zeros((model.bone_count, 3, 3))
    deltas = np.tile(np.eye(3), (model.bone_count, 1, 1))
    for c in range(model.bone_count):   # parents precede children in Anny's bone order
        p = parents[c]
        if p >= c:
            raise NlosError("body: Anny bone order has a child before its parent")
        g_parent = g[p] if p >= 0 else np.eye(3)
        g[c] = target_g.get(c, g_parent)
        deltas[c] = g_parent.T @ g[c]
    return deltas


_BODY_VERTICES: np.ndarray | None = None


def _body_vertices(model) -> np.ndarray:
    """Indices of the vertices of the skin (the largest connected part: no eyes, teeth, tongue)."""
    global _BODY_VERTICES
    if _BODY_VERTICES is None:
        faces = np.asarray(model.faces, dtype=np.int64)
        _BODY_VERTICES = largest_part(faces, int(faces.max()) + 1)
    return _BODY_VERTICES


def _skin_mesh(model, verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The skin component with compact vertex numbering."""
    keep = _body_vertices(model)
    faces = np.asarray(model.faces, dtype=np.int64)
    remap = np.full(len(verts), -1, dtype=np.int64)
    remap[keep] = np.arange(len(keep))
    f = remap[faces]
    return verts[keep], f[np.all(f >= 0, axis=1)]


def generate_library_body(posture: str, bucket: tuple[int, ...], variant: int, target_faces: int) -> dict:
    """Pose, clean, frame and decimate one library body (the slow path, ~0.1 s).

    Returns the arrays stored in a cache entry: ``vertices`` (V, 3) and ``faces`` (F, 3) in the
    canonical frame, ``joints`` (len(JOINTS), 3) in the same frame, ``closed`` (the decimated
    skin is a closed, consistently oriented manifold), ``standing_height`` (m, of this build
    standing, before the final scale) and the Anny ``phenotype`` values by name.
    """
    model = anny_model()
    build = _get_build(bucket)
    directions = pose_directions(posture, bucket, variant)
    verts, heads = _pose(model, build.rest, _deltas(model, build.ref_heads, directions))
    verts, faces = _skin_mesh(model, verts)
    index = {name: i for i, name in enumerate(model.bone_labels)}
    joints = heads[[index[j] for j in JOINTS]]
    # Canonical frame: front to +x, pelvis (root head) above the origin, soles on z = 0.
    shift = np.array([heads[0, 0], heads[0, 1], verts[:, 2].min()])
    verts = (verts - shift) @ _TO_CANONICAL.T
    joints = (joints - shift) @ _TO_CANONICAL.T
    verts, faces, closed = decimate_closed(verts, faces, target_faces)
    floor = verts[:, 2].min()   # collapsed vertices may sit a little below the old soles
    verts[:, 2] -= floor
    joints[:, 2] -= floor
    return {"vertices": verts, "faces": faces.astype(np.int32), "joints": joints, "closed": np.bool_(closed),
            "standing_height": np.float64(build.standing_height),
            "phenotype": np.array([build.phenotype[k] for k in sorted(build.phenotype)]),
            "phenotype_names": np.array(sorted(build.phenotype))}


# --------------------------------------------------------------------------- the cache

def library_tag() -> str:
    """Name of the library folder: the code version, the Anny version and a digest of every
    setting that shapes a library body, so stale entries are never read after a change."""
    import hashlib
    from importlib.metadata import PackageNotFoundError, version

    try:
        anny_version = version("anny")
    except PackageNotFoundError:
        anny_version = "none"
    settings = repr((BUILD_LEVELS, STATURE_LEVELS_M, ADULT_AGE, UNKNOWN_MIN_DISTANCE_DEG, JITTER_DEG,
                     _LIBRARY_SEED, SEGMENTS, JOINTS, _DECIMATION_TRIES,
                     [np.round(np.stack(list(_named_posture(p).values())), 9).tolist() for p in NAMED_POSTURES]))
    digest = hashlib.sha256(settings.encode()).hexdigest()[:10]
    return f"v{LIBRARY_VERSION}-anny{anny_version}-{digest}"


def default_cache_dir() -> Path:
    """``$NLOS_CACHE/bodies`` if ``NLOS_CACHE`` is set, else ``~/.cache/nlos-spotlight/bodies``."""
    root = os.environ.get("NLOS_CACHE")
    return Path(root) / "bodies" if root else Path.home() / ".cache" / "nlos-spotlight" / "bodies"


@dataclass(frozen=True)
class BodyKey:
    """Address of one library body."""

    posture: str
    """One of :data:`POSTURES`."""
    bucket: tuple[int, ...]
    """Level indices of :data:`BUILD_LEVELS` (in order) then of :data:`STATURE_LEVELS_M`."""
    variant: int
    """Pose variant, ``pose_seed % variants_per_posture``."""

    def filename(self) -> str:
        return "b" + "".join(str(i) for i in self.bucket) + f"_v{self.variant:03d}.npz"


class BodyCache:
    """A disk library of posed, decimated bodies, filled lazily, plus a small in-memory LRU.

    ``stats`` counts ``generated`` (posed with Anny), ``disk_loads`` and ``memory_hits``.
    A person's mesh depends on ``variants_per_posture`` (it picks the variant), so caches
    that should agree must use the same value.
    """

    def __init__(self, root: str | os.PathLike | None = None, variants_per_posture: int = DEFAULT_VARIANTS,
                 memory_entries: int = 512) -> None:
        if isinstance(variants_per_posture, bool) or not isinstance(variants_per_posture, int) \
                or variants_per_posture < 1:
            raise NlosError("body cache: variants_per_posture must be a positive integer, "
                            f"got {variants_per_posture!r}")
        self.root = Path(root) if root is not None else default_cache_dir()
        self.tag = library_tag()
        self.variants_per_posture = variants_per_posture
        self.memory_entries = memory_entries
        self.stats = {"generated": 0, "disk_loads": 0, "memory_hits": 0}
        self._memory: OrderedDict[tuple, dict] = OrderedDict()
        self._lock = threading.Lock()

    def path(self, key: BodyKey, target_faces: int) -> Path:
        """Where the entry for ``key`` at this decimation target lives."""
        return self.root / self.tag / f"f{int(target_faces)}" / key.posture / key.filename()

    def key(self, params: BodyParams) -> BodyKey:
        """The library key a person maps to."""
        return BodyKey(params.posture, build_bucket(params), int(params.pose_seed) % self.variants_per_posture)

    def get(self, key: BodyKey, target_faces: int) -> dict:
        """The entry's arrays (do not modify them): memory, else disk, else generated and stored."""
        mem_key = (key, int(target_faces))
        with self._lock:
            if mem_key in self._memory:
                self._memory.move_to_end(mem_key)
                self.stats["memory_hits"] += 1
                return self._memory[mem_key]
        path = self.path(key, target_faces)
        entry = self._load(path)
        if entry is None:
            self._store(path, generate_library_body(key.posture, key.bucket, key.variant, target_faces))
            self.stats["generated"] += 1
            entry = self._load(path)   # return what is on disk, so every later call is identical
            if entry is None:
                raise NlosError(f"body cache: could not read back {path}")
        else:
            self.stats["disk_loads"] += 1
        with self._lock:
            self._memory[mem_key] = entry
            while len(self._memory) > self.memory_entries:
                self._memory.popitem(last=False)
        return entry

    @staticmethod
    def _load(path: Path) -> dict | None:
        try:
            with np.load(path, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}
        except FileNotFoundError:
            return None
        except (OSError, ValueError, EOFError):
            return None   # a damaged file (e.g. a foreign partial copy): regenerate it

    @staticmethod
    def _store(path: Path, arrays: dict) -> None:
        """Write to a temporary file next to ``path``, then rename: readers never see half a file."""
        path.parent.mkdir(parents=True, exist_ok=True)
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem + ".", suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(buf.getvalue())
            os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            raise

    def warm(self, postures=POSTURES, variants_per_posture: int | None = None, target_faces: int = 2000,
             buckets: list[tuple[int, ...]] | None = None) -> int:
        """Make sure the library holds these entries (all build buckets unless given); returns
        how many were generated. Safe to run in several processes at once."""
        variants = self.variants_per_posture if variants_per_posture is None else variants_per_posture
        if variants > self.variants_per_posture:
            raise NlosError(f"body cache: {variants} variants asked, the cache uses {self.variants_per_posture}")
        for p in postures:
            if p not in POSTURES:
                raise NlosError(f"body: unknown posture {p!r} (known: {', '.join(POSTURES)})")
        before = self.stats["generated"]
        for bucket in (buckets if buckets is not None else all_buckets()):
            for posture in postures:
                for variant in range(variants):
                    key = BodyKey(posture, tuple(bucket), variant)
                    if not self.path(key, target_faces).exists():
                        self.get(key, target_faces)
        return self.stats["generated"] - before


def all_buckets() -> list[tuple[int, ...]]:
    """Every build bucket of the lattice."""
    sizes = [len(v) for v in BUILD_LEVELS.values()] + [len(STATURE_LEVELS_M)]
    return [tuple(int(i) for i in idx) for idx in np.ndindex(*sizes)]


_DEFAULT_CACHE: BodyCache | None = None


def _default_cache() -> BodyCache:
    global _DEFAULT_CACHE
    if _DEFAULT_CACHE is None or _DEFAULT_CACHE.root != default_cache_dir():
        _DEFAULT_CACHE = BodyCache()
    return _DEFAULT_CACHE


# --------------------------------------------------------------------------- public entry point

def _check_target_faces(target_faces) -> int:
    if isinstance(target_faces, bool) or not isinstance(target_faces, (int, np.integer)):
        raise NlosError(f"body: target_faces must be an integer, got {target_faces!r}")
    if not 200 <= int(target_faces) <= 20000:
        raise NlosError(f"body: target_faces {target_faces} outside [200, 20000]")
    return int(target_faces)


def _placement(params: BodyParams, entry: dict) -> tuple[float, np.ndarray]:
    """Uniform scale to the requested standing height and the facing rotation."""
    scale = params.height_m / float(entry["standing_height"])
    a = math.radians(params.facing_deg)
    rot = np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
    return scale, rot


def posed_body(params: BodyParams, target_faces: int = 2000, cache: BodyCache | None = None) -> TriMesh:
    """The person's mesh: soles on z = 0, pelvis above (0, 0), z up, meters, facing ``facing_deg``.

    Cheap once the library entry exists (a scale and a rotation of a cached mesh).
    """
    params.validate()
    target_faces = _check_target_faces(target_faces)
    cache = cache if cache is not None else _default_cache()
    entry = cache.get(cache.key(params), target_faces)
    scale, rot = _placement(params, entry)
    vertices = (entry["vertices"] * scale) @ rot.T
    return TriMesh(np.ascontiguousarray(vertices, dtype=np.float64), entry["faces"].astype(np.int64, copy=True))


def posed_joints(params: BodyParams, target_faces: int = 2000, cache: BodyCache | None = None) -> dict[str, np.ndarray]:
    """Skeleton joints (:data:`JOINTS`, bone heads) of the same body, in the same frame."""
    params.validate()
    target_faces = _check_target_faces(target_faces)
    cache = cache if cache is not None else _default_cache()
    entry = cache.get(cache.key(params), target_faces)
    scale, rot = _placement(params, entry)
    joints = (entry["joints"] * scale) @ rot.T
    return {name: joints[i] for i, name in enumerate(JOINTS)}
