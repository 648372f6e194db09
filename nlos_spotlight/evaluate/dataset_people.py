"""A dataset room's people re-posed from the dataset's deterministic specs, and the room's renderer.

The physics bounds (the position CRB, the ideal observer: ``experiments/physics-bounds``) render
the same people as a dataset again, at other positions or postures; the specs are what the
dataset's generator drew (``data.scene_builder.SceneBuilder``), so no person is stored twice.
"""

from __future__ import annotations

from pathlib import Path

from ..data.config import DatasetConfig, transport_count
from ..data.scene_builder import SceneBuilder
from ..data.static import read_static
from ..render.transport import Renderer
from ..world.rooms import generate_room


def room_renderer(cfg: DatasetConfig, p, data: Path, faces: list[int]):
    """(builder, scene, renderer) of the dataset's room ``p`` (a ``data.generate.plan`` entry) with
    the dataset's render settings, under the stored candidate spots ``faces``."""
    b = SceneBuilder(cfg, p, data)
    scene = generate_room(p.seed, b._room_config()).scene
    st = read_static(b.dir)
    settings = cfg.render_settings()
    return b, scene, Renderer(scene, settings, aim_points=st["aim_points"][faces])


def seen_test_specs(cfg: DatasetConfig, p, builder: SceneBuilder, scene, people: int) -> list[dict]:
    """The first ``people`` test people of ``train.recipe.split_room`` in a training room (image sample k - m
    with (k - m) % 10 == 9, m the room's full-transport people), each spec with its ``index``."""
    specs = builder._specs(scene)
    m = transport_count(cfg, p.split)
    keep = [k for k in range(m, len(specs)) if (k - m) % 10 == 9 and specs[k]["trajectory"] < 0][:people]
    return [specs[k] | {"index": k} for k in keep]


def static_specs(builder: SceneBuilder, scene, people: int) -> list[dict]:
    """The first ``people`` static people of a room (walkers left out), each spec with its ``index``."""
    specs = builder._specs(scene)
    return [specs[k] | {"index": k} for k in range(len(specs)) if specs[k]["trajectory"] < 0][:people]
