"""Per-room fits of a dataset's test rooms: what each network is, where its run lives, its rows.

A test room no network trained in is fitted by rendering people in its own scan and training one
network per *variant* on them (``experiments/unseen-room-fit``). A variant is written
``FRAMES[+albedo][+eEPOCHS][+pPEOPLE][+wdDECAY][+xRENDERS][+sSEED][+init][+LIGHT][+ARCH][+luxLUX]``,
e.g. ``16+e120+adaptive+chandran``: a 16-frame burst, 120 epochs, Adaptive Lighting's spot and
Chandran's CNN. The light and the network are the method (:meth:`Variant.method` finds it in
``evaluate.methods``, the registry ``nlos fit --method`` and ``nlos evaluate`` select from); the
rest is the capture and the training. The studies built on those fits share this module instead of
importing one another.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from ..errors import NlosError
from ..lighting.oracle import SNR_RANKS
from .methods import METHODS, Method

LIGHTS = {"adaptive": "Adaptive Lighting spot", "center": "center spot", "flash": "flash", "ambient": "projector off",
          **{f"rank{k}": f"spot of SNR rank {k}" for k in SNR_RANKS}}
"""'+NAME': train and test under this fixed policy (``lighting.POLICIES``) instead of the fitted spot;
'+rankK': the fitted room's K-th best spot by its simulated people's SNR (the fit's spot is rank 1)."""

ARCHS = {"chandran": "Chandran's CNN", "tancik": "Tancik's network", "dlnlos": "DL-NLOS's network"}
"""'+NAME': this baseline network (``models.baselines``) instead of the light ResNet."""

VARIANT_HELP = ("FRAMES[+albedo][+eEPOCHS][+pPEOPLE][+wdDECAY][+xRENDERS][+sSEED][+init][+LIGHT][+ARCH][+luxLUX] "
                "(e.g. 16+albedo, 16+e120, 16+e120+p1396, 16+wd1e-3, 16+e120+x2, 16+e120+x2+s1, 16+e120+init, "
                f"16+e120+adaptive+chandran, 16+e120+lux0, 16+e120+ambient+lux0.01; LIGHT: {', '.join(LIGHTS)}; "
                f"ARCH: {', '.join(ARCHS)})")


@dataclasses.dataclass
class Variant:
    """One network's capture and training on a fitted room's people."""

    frames: int
    """Frames a still capture averages (training and test photographs)."""
    albedo: bool
    """Albedo augmentation (``TrainConfig.albedo_augment``)."""
    epochs: float | None
    """Passes over the training people; None: the study's ``--epochs``."""
    people: int | None = None
    """Only the first this many training people; None: all of them."""
    weight_decay: float | None = None
    """Adam's L2 weight decay; None: the seen-rooms recipe's."""
    renders: int = 1
    """Training people from this many independent renders (validation and held-out people always
    from the first)."""
    train_seed: int = 0
    """Added to the master seed for the training only (weights, batches, training noise); the scores
    keep the master seed's noise draws, so two training seeds are scored on the same photographs."""
    init: bool = False
    """Start from a network trained in other rooms instead of random weights."""
    light: str = "fit"
    """The illumination of training and test photographs: 'fit' (the spot chosen from the simulated
    people, ``nlos fit``'s), or a fixed policy of :data:`LIGHTS`."""
    arch: str = "resnet18"
    """The network: the seen-rooms recipe's light ResNet, or a baseline's (:data:`ARCHS`)."""
    hidden_lux: float | None = None
    """The hidden region's illuminance (lux) instead of the room's own (0: the projector's light only)."""

    def method(self) -> Method | None:
        """The registry's method with this light and network (the fitted spot is the oracle on the
        room's simulated people), or None for a pairing the registry does not name."""
        policy = light_policy(self.light)
        return next((m for m in METHODS if (m.policy, m.arch) == (policy, self.arch) and not m.overrides), None)

    def fit_flags(self) -> tuple[list[str], list[str]]:
        """(the ``nlos fit`` flags that train this variant in a scanned room, the variant's options
        ``nlos fit`` has no flag for): the burst, the epochs, the people and the method map; albedo
        augmentation in the dataset's range, several renders, a training seed apart from the master
        seed, another network's weights, an SNR rank's spot and another hidden light do not."""
        flags = ["--burst", str(self.frames)]
        flags += ["--epochs", f"{self.epochs:g}"] if self.epochs else []
        flags += ["--people", str(self.people)] if self.people else []
        m = self.method()
        if m is not None and m.name != "oracle_resnet":  # the fitted spot + ResNet-18 is nlos fit's own
            flags += ["--method", m.name]
        left = [name for name, on in (("+albedo", self.albedo), (f"+x{self.renders}", self.renders > 1),
                                      (f"+s{self.train_seed}", self.train_seed), ("+init", self.init),
                                      (f"+wd{self.weight_decay:g}" if self.weight_decay is not None else "",
                                       self.weight_decay is not None),
                                      (f"+{self.light}", m is None and self.light != "fit"),
                                      (f"+{self.arch}", m is None and self.arch != "resnet18"),
                                      (f"+lux{self.hidden_lux:g}" if self.hidden_lux is not None else "",
                                       self.hidden_lux is not None)) if on]
        return flags, left

    def describe(self) -> str:
        what = f"{self.frames}-frame burst" if self.frames > 1 else "one frame"
        return ((f"{ARCHS[self.arch]}, " if self.arch != "resnet18" else "")
                + (f"{LIGHTS[self.light]}, " if self.light != "fit" else "") + what
                + ", albedo augmentation" * self.albedo + (f", {self.epochs:g} epochs" if self.epochs else "")
                + (f", weight decay {self.weight_decay:g}" if self.weight_decay is not None else "")
                + (f", people of {self.renders} renders" if self.renders > 1 else "")
                + (f", training seed +{self.train_seed}" if self.train_seed else "")
                + (", started from a network of other rooms" if self.init else "")
                + (f", hidden region at {self.hidden_lux:g} lux" if self.hidden_lux is not None else ""))


def _number(text: str, kind: type) -> float | None:
    try:
        v = kind(text)
    except ValueError:
        return None
    return v if v >= 0 else None


def _kind(e: str) -> str:
    """Which option a '+' element sets (each at most once in a spec)."""
    if e in ("albedo", "init"):
        return e
    return "light" if e in LIGHTS else "arch" if e in ARCHS else "wd" if e.startswith("wd") \
        else "lux" if e.startswith("lux") else e[:1]


def parse_variant(spec: str) -> Variant:
    """'16' -> 16 frames a still capture; '+albedo' albedo augmentation, '+eN' N epochs, '+pN' only
    the first N training people, '+wdX' weight decay X, '+xN' people of N renders, '+sN' training seed
    +N, '+init' a network of other rooms' weights, '+LIGHT', '+ARCH', '+luxX' (:data:`VARIANT_HELP`).
    A malformed spec is a one-line :class:`NlosError`."""
    frames, *extra = spec.split("+")
    v = Variant(int(frames) if frames.isdigit() else 0, False, None)
    ok = v.frames >= 1 and len({_kind(e) for e in extra}) == len(extra)
    for e in extra:
        if e == "albedo":
            v.albedo = True
        elif e == "init":
            v.init = True
        elif e in LIGHTS:
            v.light = e
        elif e in ARCHS:
            v.arch = e
        elif e.startswith("wd"):
            v.weight_decay = _number(e[2:], float)
            ok &= v.weight_decay is not None
        elif e.startswith("lux"):  # 0 allowed: no hidden light at all
            v.hidden_lux = _number(e[3:], float)
            ok &= v.hidden_lux is not None
        elif e[:1] in ("e", "p", "x", "s"):
            n = _number(e[1:], float if e[0] == "e" else int)
            ok &= bool(n)
            if n:
                setattr(v, {"e": "epochs", "p": "people", "x": "renders", "s": "train_seed"}[e[0]], n)
        else:
            ok = False
    ok &= not (v.init and v.arch != "resnet18")  # a network of other rooms is a light ResNet
    if not ok:
        raise NlosError(f"--variants: expected {VARIANT_HELP}, got {spec!r}")
    return v


def light_policy(light: str) -> str:
    """The ``lighting.POLICIES`` name of a variant's light ('fit' is the oracle on the fitted room's
    simulated people, 'rankK' its K-th best spot by SNR)."""
    return "oracle" if light == "fit" else f"oracle-{light[4:]}" if light.startswith("rank") else light


def fitted_spot(light: str) -> bool:
    """Whether the light is chosen from the fitted room's simulated people (so the test room, whose
    own SNR comes from its test people, must not choose again: its face is the fit's)."""
    return light == "fit" or light.startswith("rank")


def run_dir(room_out: Path, spec: str) -> Path:
    """A variant's run folder in a fitted room's folder ('1': ``run``, the first fits' name)."""
    return room_out / ("run" if spec == "1" else f"run-{spec.replace('+', '-')}")


def training_split(data: Path):
    """A fitted room's render split into training pool, 100 validation and 100 held-out people."""
    from ..data.tensors import load_split
    from ..train.recipe import split_room

    s, = load_split(data, "train", ["normals"], samples="images")
    return split_room(s, period=10, max_eval=100)


def static_people(room: Path):
    """A test room's static people (those a fitted room is scored on; walkers are left out)."""
    import torch

    from ..data.tensors import load_scene_tensors

    t = load_scene_tensors(room, ["normals"], samples="transport")
    return t.subset(torch.nonzero(t.trajectory[:, 0] < 0).flatten())


def read_fit_rows(path: Path) -> list[dict]:
    """A room-fit CSV's rows (fits written before variants: variant '1', one frame, no augmentation)."""
    with path.open(newline="") as f:
        return [{"variant": "1", **r} for r in csv.DictReader(f)]


def first_seconds(path: Path, t0: float) -> float:
    """Seconds since ``t0`` the first time a step finishes, kept at ``path``: a resumed or rescored
    room reports the time its work took, not the rerun's."""
    if not path.exists():
        path.write_text(json.dumps(time.perf_counter() - t0))
    return float(json.loads(path.read_text()))


def room_interval(accuracy: list[float]) -> str:
    """95% interval of the mean over rooms (Student's t on the per-room accuracies, clipped to
    0-100%): the rooms are a sample of the test set's layouts, so this holds room-to-room spread and
    each room's people together, where a binomial interval on the pooled people holds the people
    only. '' for fewer than two rooms."""
    if len(accuracy) < 2:
        return ""
    from scipy import stats

    a = np.asarray(accuracy, dtype=float)
    half = stats.t.ppf(0.975, len(a) - 1) * a.std(ddof=1) / np.sqrt(len(a))
    return f"{max(a.mean() - half, 0):.1f}-{min(a.mean() + half, 100):.1f}%"


def room_range(text: str) -> list[int]:
    """'0-5' -> [0, ..., 5]; '0,3,7' -> [0, 3, 7]; anything else a one-line :class:`NlosError`."""
    try:
        if "-" in text:
            a, b = (int(x) for x in text.split("-"))
            if b < a:
                raise ValueError
            return list(range(a, b + 1))
        return [int(x) for x in text.split(",")]
    except ValueError:
        raise NlosError(f"expected rooms as A-B or A,B,C, got {text!r}") from None
