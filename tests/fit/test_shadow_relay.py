"""The fit's per-person relay sets (``fit.shadow.relay_offsets``)."""

from __future__ import annotations

import dataclasses

from nlos_spotlight.fit.config import PRESETS
from nlos_spotlight.fit.shadow import BLOCK, RELAY_SETS, relay_offsets


def test_each_block_draws_its_own_relay_sets():
    cfg = PRESETS["tiny"]
    assert relay_offsets([0, 1], dataclasses.replace(cfg, shadow_relay="fixed")) is None
    got = relay_offsets(list(range(3 * BLOCK)), cfg)
    assert all(0 <= o < 1 for o in got)
    blocks = [set(got[b * BLOCK:(b + 1) * BLOCK]) for b in range(3)]
    assert all(len(b) == RELAY_SETS for b in blocks)  # a block shares each set's visibility among its people
    assert not (blocks[0] & blocks[1]) and not (blocks[1] & blocks[2])  # and no two blocks share a set
    assert got[5] != got[6] and got[5] == got[5 + RELAY_SETS]
