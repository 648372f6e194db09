"""Spot policies (DESIGN section 9): where the projector points in a scene, by name.

``ien`` is the learned policy (``lighting.ien``, needs a trained IEN); the fixed ones are functions
``(SceneTensors, scene_dir, rng) -> Illumination`` in :data:`POLICIES`.
"""

from __future__ import annotations

from .base import MODES, Illumination, PolicyFn
from .simple import ambient_only, random_spot

POLICIES: dict[str, PolicyFn] = {"random": random_spot, "ambient": ambient_only}
"""Fixed policy name -> function (the learned 'ien' policy is not here: it needs a checkpoint)."""

try:  # geometry- and oracle-based policies
    from .extra import EXTRA_POLICIES

    POLICIES.update(EXTRA_POLICIES)
except ImportError:  # pragma: no cover
    pass



def policy_rng(seed: int, room: int, new_room: bool = False):
    """The random generator a fixed policy draws with in a room. In a training room, ``[seed, room]``
    (the run's seed, the room's position in the train split): what training used, what the stored
    image samples hold, what evaluation in that room must redraw. In a new room ``[seed, 7919,
    room]`` (the evaluation seed), apart from any training draw."""
    import numpy as np

    return np.random.default_rng([seed, 7919, room] if new_room else [seed, room])


__all__ = ["MODES", "POLICIES", "Illumination", "PolicyFn", "policy_rng"]
