"""The physics bounds' people: re-posed from a dataset's specs, they are the people it stored."""

import numpy as np
import torch

from nlos_spotlight.data.config import read_dataset_config
from nlos_spotlight.data.generate import plan
from nlos_spotlight.data.tensors import ground_frame, load_scene_tensors
from nlos_spotlight.evaluate.dataset_people import room_renderer, static_specs
from nlos_spotlight.world.body import POSTURES


def test_static_specs_are_the_stored_static_people(micro_scene):
    scene_dir, _ = micro_scene
    data = scene_dir.parent.parent
    cfg = read_dataset_config(data)
    p = next(q for q in plan(cfg) if q.id == scene_dir.name)
    builder, scene, r = room_renderer(cfg, p, data, [0])
    assert r.shape[:2] == (cfg.resolution, cfg.resolution)
    specs = static_specs(builder, scene, 100)
    s = load_scene_tensors(scene_dir, [], samples="transport")
    st = s.subset(torch.nonzero(s.trajectory[:, 0] < 0).flatten())
    assert len(specs) == st.num_samples > 0  # every static person, no walker
    pos = ground_frame(np.array([k["position"] for k in specs]), np.asarray(s.origin_xy), np.asarray(s.forward_xy))
    np.testing.assert_allclose(pos, st.target.numpy(), atol=1e-4)
    assert [POSTURES.index(k["params"].posture) for k in specs] == st.posture.tolist()
    np.testing.assert_allclose(np.array([k["params"].albedo for k in specs]), st.albedo.numpy(), atol=1e-6)
    assert [k["index"] for k in static_specs(builder, scene, 2)] == [k["index"] for k in specs[:2]]
