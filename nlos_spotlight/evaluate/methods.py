"""The methods of the paper's experiments: a spot policy paired with an NLOS network.

``ours`` is the run given to ``nlos evaluate`` (IEN trained end to end with the ResNet-18
network); every other method is trained by the evaluation with the same training config, its
policy and network swapped (docs/baselines.md says where each pairing comes from).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Method:
    """A spot policy and an NLOS network, trained and evaluated together."""

    name: str
    """Key used in tables, CSVs and run folders."""
    label: str
    """Name shown in the report."""
    policy: str
    """'ien' or a fixed policy of ``lighting.POLICIES``."""
    arch: str
    """Network of ``models.registry.NETWORKS``, or 'floor-net' (``evaluate/floor_net.py``: FloorNet on
    the backprojection, trained across the training rooms, under ours' IEN spot)."""
    overrides: tuple[tuple[str, object], ...] = ()
    """Further TrainConfig fields that differ from the evaluated run's."""


FLOOR_NET = "floor-net"
"""``Method.arch`` of FloorNet (``evaluate/floor_net.py``), the one arch not in ``models.registry``."""

METHODS: tuple[Method, ...] = (
    Method("ours", "Ours (IEN + ResNet-18)", "ien", "resnet18"),
    Method("floor_net", "IEN + FloorNet (ours across rooms)", "ien", FLOOR_NET),
    Method("ours_task_only", "IEN (task loss only) + ResNet-18", "ien", "resnet18", (("snr_weight", 0.0),)),
    Method("ien_cnn", "IEN + CNN (Chandran)", "ien", "chandran"),
    Method("al_resnet", "AL + ResNet-18", "adaptive", "resnet18"),
    Method("random_resnet", "Random + ResNet-18", "random", "resnet18"),
    Method("center_resnet", "Center + ResNet-18", "center", "resnet18"),
    Method("oracle_resnet", "Oracle + ResNet-18", "oracle", "resnet18"),
    Method("chandran", "Chandran & Jayasuriya (AL + CNN)", "adaptive", "chandran"),
    Method("tancik", "Tancik et al. (Flash + CNN)", "flash", "tancik"),
    Method("dlnlos", "DL-NLOS (ambient + CNN)", "ambient", "dlnlos"),
)
"""Every method of Tables 1-3, ours first."""

TABLE3 = ("ien_cnn", "al_resnet", "random_resnet", "center_resnet", "ours_task_only", "ours", "oracle_resnet")
"""Rows of Table 3 (the spot-policy and network ablation), in the paper's order plus the oracle."""

BY_NAME = {m.name: m for m in METHODS}


FIT_POLICIES = ("oracle", "ien", "adaptive", "center", "random")
"""Spot policies ``nlos fit`` can aim with."""

@dataclass(frozen=True)
class Light:
    """A light without a spot (a policy of :data:`UNAIMED`), in the words every message uses."""

    words: str
    """What lights the photographs, as a clause ('the projector off')."""
    photograph: str
    """What ``nlos predict`` tells the user to photograph."""
    capture: str
    """The fit report's capture: the light in the person's and the empty-room photographs."""
    blocked: str
    """The light the body blocks, which such a fit does not render ('the flash')."""


LIGHTS = {
    "flash": Light("the flash at the camera lighting its whole view",
                   "flash photographs (a flash at the camera lighting its whole view, no projector spot)",
                   "a flash at the camera lighting its whole view (Tancik et al.; modelled at the camera's centre of "
                   "projection with the projector spot's total flux, data/flash.py), in the person's photographs and "
                   "the empty-room photograph alike; no projector spot", "the flash"),
    "ambient": Light("the projector off", "projector-off photographs (the room's own light only)",
                     "the projector off: the room's own light only, in the person's photographs and the empty-room "
                     "photograph alike", "the room's own light"),
}
"""The lights without a spot: the flash (Tancik et al.) and the projector off (DL-NLOS)."""

UNAIMED = tuple(LIGHTS)
"""Policies that light no spot, which ``nlos fit`` fits too (:data:`LIGHTS`)."""


def fittable(m: Method) -> bool:
    """Whether ``nlos fit --method`` can fit ``m`` in a room: a spot policy or no spot
    (:data:`UNAIMED`) and an image network, no setting of the IEN's own training."""
    return m.policy in FIT_POLICIES + UNAIMED and m.arch != FLOOR_NET and not m.overrides  # no network import


def light_of(policy: str) -> str:
    """What a policy's photographs are lit by: 'spot' (aimed), or the light of :data:`UNAIMED`."""
    return policy if policy in UNAIMED else "spot"


def unaimed_method(light: str) -> str:
    """The method ``nlos fit`` fits under a light without a spot (the first fittable one of it)."""
    return next(m.name for m in METHODS if m.policy == light and fittable(m))


def fit_method(name: str) -> Method:
    """The method ``nlos fit --method NAME`` fits ('ours': the fit's ``--policy`` spot and ResNet-18),
    or a one-line error naming those it can."""
    from ..errors import NlosError

    m = BY_NAME.get(name)
    if m is None or not fittable(m):
        ok = ", ".join(k for k, v in BY_NAME.items() if fittable(v))
        why = f" ({NOT_FITTED[name]})" if name in NOT_FITTED else ""
        raise NlosError(f"--method: nlos fit fits {ok}; not {name!r}{why}")
    return m


NOT_FITTED = {
    "floor_net": "FloorNet is the method for rooms nobody fitted: it reads posture at chance everywhere, and "
               "in rooms it trained on it only draws level with the image network in position (36.1 against "
               "35.2 cm, docs/results.md, seen rooms): a fitted room trains the image network",
    "ours_task_only": "a setting of the IEN's own training; a fit aims with --policy instead",
}
"""Why ``nlos fit`` refuses a method of Tables 1-3 (:func:`fittable`), said in its error."""


def select(names: list[str] | None) -> list[Method]:
    """Methods by name (all when ``names`` is empty); ``ours`` is always included."""
    from ..errors import NlosError

    if not names:
        return list(METHODS)
    bad = [n for n in names if n not in BY_NAME]
    if bad:
        raise NlosError(f"--methods: unknown method '{bad[0]}' (choose from {', '.join(BY_NAME)})")
    return [BY_NAME["ours"]] + [BY_NAME[n] for n in names if n != "ours"]
