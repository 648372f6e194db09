"""A toy world in memory where one candidate spot is clearly best (shared by the training tests)."""

from __future__ import annotations

import numpy as np
import torch

from nlos_spotlight.scene.builders import quad
from nlos_spotlight.scene.graph import mesh_to_graph, normalize_positions
from nlos_spotlight.train.scenes import SceneTensors

BEST = 5


def toy_scene(n: int = 64, seed: int = 0, res: int = 8, best: int = BEST) -> SceneTensors:
    """8 candidate faces; only under spot ``best`` does the image carry the person's position and posture."""
    rng = np.random.default_rng(seed)
    mesh = quad([0, 0, 0], [2, 0, 0], [0, 2, 0], 2, 2)
    g = mesh_to_graph(mesh)
    x = torch.cat([normalize_positions(torch.as_tensor(g.pos, dtype=torch.float32))[0],
                   torch.as_tensor(g.normals, dtype=torch.float32)], dim=1)
    t = len(mesh.faces)
    direct = torch.zeros(t, res, res, 3)
    for k in range(t):
        direct[k, k % res, (3 * k) % res] = 5.0  # every spot is equally bright
    target = rng.uniform(-1, 1, (n, 2))
    posture = rng.integers(0, 6, n)
    v = torch.zeros(n, 1, res, res, 3)
    cols = torch.arange(res, dtype=torch.float32)
    for i in range(n):
        ramp = (1 + 0.8 * target[i, 0] * (cols / res - 0.5))[None, :, None]
        v[i, 0] = ramp * (1 + 0.6 * target[i, 1] * (cols / res - 0.5))[:, None, None]
        v[i, 0, posture[i] % res, :, :] += 1.0  # posture shows as a bright row
    u = torch.zeros(n, t, 1)
    u[:, best, 0] = 1.0
    return SceneTensors(x=x, edge_index=torch.as_tensor(g.edge_index, dtype=torch.long),
                        faces=torch.as_tensor(mesh.faces, dtype=torch.long), landed=torch.ones(t, dtype=torch.bool),
                        direct=direct, ambient=torch.full((res, res, 3), 0.5), u=u, v=v,
                        nlos_ambient=torch.zeros(n, res, res, 3),
                        target=torch.as_tensor(target, dtype=torch.float32), posture=torch.as_tensor(posture),
                        trajectory=-torch.ones(n, 2, dtype=torch.long), camera_xy=torch.zeros(2),
                        forward_xy=torch.tensor([1.0, 0.0]))
