"""The Dr.Jit occlusion engine (``render/rays_drjit.py``) against embreex, the reference engine."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.render import rays_drjit
from nlos_spotlight.render.rays import RayEngine, SceneRays, occlusion_engine

pytestmark = pytest.mark.skipif(not rays_drjit.available("cpu"), reason="Mitsuba 3 (LLVM) not available")


def test_occlusion_matches_embree_on_random_segments(box):
    """Segments between random points in and around two boxes: the same answer from both engines,
    and the closed form (a segment between two points outside a convex box is blocked iff the
    slab test says it crosses it) for the segments that miss the second box."""
    v1, f1 = box.mesh([-1, -1, -1], [1, 1, 1])
    rng = np.random.default_rng(3)
    a, b = rng.uniform(-3, 3, (20000, 2, 3)).transpose(1, 0, 2)
    ref = RayEngine(v1, f1).occluded(a, b)
    got = rays_drjit.DrJitRays(v1, f1, "cpu", threads=1).occluded(a, b)
    assert 0.2 < ref.mean() < 0.9  # both outcomes are common
    assert np.mean(got != ref) <= 1e-4
    clear, crosses = box.crossings(a, b)
    assert np.array_equal(got[clear], crosses[clear])


def test_with_body_sees_both_meshes(box):
    """The room's mesh instanced beside a body blocks what either blocks, as one embreex BVH of both."""
    v1, f1 = box.mesh([-1, -1, -1], [1, 1, 1])
    v2, f2 = box.mesh([2, -0.5, -0.5], [3, 0.5, 0.5])

    class Body:
        vertices, faces = v2, f2

    rng = np.random.default_rng(4)
    a = rng.uniform(-4, 5, (20000, 3))
    b = rng.uniform(-4, 5, (20000, 3))
    joined_ref = RayEngine(np.concatenate([v1, v2]), np.concatenate([f1, f2 + len(v1)])).occluded(a, b)
    engine = occlusion_engine(RayEngine(v1, f1), "drjit", "cpu")
    got = SceneRays(engine, Body()).occluded(a, b)
    alone = engine.occluded(a, b)
    assert np.mean(got != joined_ref) <= 1e-4
    assert (got & ~alone).sum() > 100  # the body blocks segments the room does not


def test_renderer_images_equal_with_either_engine(glossy_corner_pair):
    """A person's images (every candidate, flash-free) through either engine: within 1e-4."""
    import dataclasses

    from nlos_spotlight.render.transport import Renderer

    torch_r, drjit_r, person = glossy_corner_pair(300, "float64", pair_loops=True, rays="drjit")
    base = Renderer(torch_r.scene, dataclasses.replace(drjit_r.settings, rays="embree"), aim_points=torch_r.aim_points)
    assert isinstance(drjit_r.rays, rays_drjit.DrJitRays) and isinstance(base.rays, RayEngine)
    with torch.no_grad():
        want = base.transport_images(person, [0.05, -0.03], nlos_ambient=True)
        got = drjit_r.transport_images(person, [0.05, -0.03], nlos_ambient=True)
    assert float(want.abs().max()) > 0
    assert float((got - want).norm() / want.norm()) < 1e-4


def test_auto_picks_drjit_where_it_runs(box):
    v, f = box.mesh([-1, -1, -1], [1, 1, 1])
    engine = RayEngine(v, f)
    assert isinstance(occlusion_engine(engine, "auto", "cpu"), rays_drjit.DrJitRays)
    assert occlusion_engine(engine, "embree", "cpu") is engine
    with pytest.raises(ValueError, match="rays"):
        occlusion_engine(engine, "optix", "cpu")


def test_torch_kernels_with_drjit_rays_equal_embree(glossy_corner_pair):
    """The path a GPU takes (torch pair kernels, Dr.Jit rays), here on the CPU: the same images as the
    torch kernels with embreex rays, within 1e-4."""
    import dataclasses

    from nlos_spotlight.render.transport import Renderer

    torch_r, _, person = glossy_corner_pair(300, "float64")
    gpu_like = Renderer(torch_r.scene, dataclasses.replace(torch_r.settings, rays="drjit"), aim_points=torch_r.aim_points)
    assert isinstance(gpu_like.rays, rays_drjit.DrJitRays) and not gpu_like.settings.pair_loops
    with torch.no_grad():
        want = torch_r.transport_images(person, [0.05, -0.03], nlos_ambient=True)
        got = gpu_like.transport_images(person, [0.05, -0.03], nlos_ambient=True)
    assert float((got - want).norm() / want.norm()) < 1e-4


def test_ray_tally_counts_every_query(box):
    """``rays.TALLY`` counts each ray a ``SceneRays`` query tests (the render benchmark's ray budget),
    whichever engine answers it."""
    from nlos_spotlight.render.rays import TALLY

    v1, f1 = box.mesh([-1, -1, -1], [1, 1, 1])
    rng = np.random.default_rng(5)
    o = rng.uniform(-3, 3, (1000, 3)).astype(np.float32)
    d = rng.normal(size=(1000, 3))
    d = (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)
    length = np.full(1000, 2.0, np.float32)
    TALLY.reset()
    for engine in (RayEngine(v1, f1), occlusion_engine(RayEngine(v1, f1), "drjit", "cpu")):
        SceneRays(engine).occluded_rays(o, d, length)
        SceneRays(engine).occluded_rays(o[:10], d[:10], length[:10])
    assert (TALLY.rays, TALLY.calls) == (2020, 4) and TALLY.seconds > 0
