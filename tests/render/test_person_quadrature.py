"""Body sampling (``Person.from_mesh``): the per-face quadrature and its accuracy at dataset settings.

The accuracy test renders the person light a dataset sample stores (transport images of the
candidate spots) of one Anny body in a generated room, with the ``small`` renderer settings, and
compares it with a 4x finer quadrature of the same body (``benchmarks/person_convergence.py``
measures all presets and postures against 30,000 samples).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from nlos_spotlight.data.config import PRESETS
from nlos_spotlight.render.person import (QUADRATURES, SHADOW_FLOOR, Person, face_quadrature, face_splits,
                                          shadow_variation, subtriangle_centroids)
from nlos_spotlight.scene.builders import mannequin

GOAL = 0.005  # relative L2 of the stored person light against a converged render


@pytest.mark.parametrize("k", [1, 2, 3, 7])
def test_subtriangle_centroids_tile_the_triangle(k):
    b = subtriangle_centroids(k)
    assert b.shape == (k * k, 3)
    assert np.allclose(b.sum(1), 1) and (b > 0).all()
    assert np.allclose(b.mean(0), 1 / 3)  # the sub-triangles tile the triangle evenly
    assert len(np.unique(b.round(12), axis=0)) == k * k


@pytest.mark.parametrize("quadrature", QUADRATURES)
@pytest.mark.parametrize("n", [1, 100, 5000])
def test_sample_areas_sum_to_the_mesh_area(quadrature, n):
    mesh = mannequin([0.0, 0.0, 0.0], 1.75)
    p = Person.from_mesh(mesh, [0.5, 0.4, 0.3], n, quadrature)
    assert np.isclose(p.area.sum(), mesh.face_areas().sum(), rtol=1e-12)
    assert p.pos.shape == p.normal.shape == p.albedo.shape == (len(p), 3) and p.area.shape == (len(p),)
    assert np.allclose(np.linalg.norm(p.normal, axis=1), 1)


def test_faces_rule_covers_every_face_by_its_weight():
    mesh = mannequin([0.0, 0.0, 0.0], 1.75, arms_deg=20.0)
    areas = mesh.face_areas()
    weight = SHADOW_FLOOR + shadow_variation(mesh)
    assert (weight >= SHADOW_FLOOR).all() and (weight <= 1 + SHADOW_FLOOR).all() and weight.max() > 2 * SHADOW_FLOOR
    n = 4 * len(areas)
    face, bary, area = face_quadrature(areas, n, weight)
    k = face_splits(areas, n, weight)
    assert np.array_equal(np.bincount(face, minlength=len(areas)), k**2)  # k x k samples on every face
    assert np.all(np.diff(face) >= 0) and (bary > 0).all()
    assert np.allclose(np.bincount(face, area, len(areas)), areas)
    p = Person.from_mesh(mesh, [0.5, 0.5, 0.5], n, "faces")
    assert np.array_equal(p.area, area) and np.allclose(p.normal, mesh.face_normals()[face])
    split = k[face] > 1  # there, a sample's area times its face's weight is about sum(a w) / n
    density = area[split] * weight[face[split]] * n / (areas * weight).sum()
    assert split.any() and 0.5 < density.min() and density.max() < 1.6
    assert len(Person.from_mesh(mesh, [0.5] * 3, 1, "faces")) == len(areas)  # at least one a face


def test_a_sampling_block_samples_the_body_by_its_count_and_rule():
    """``Person.sampled``: a config's ``render`` block (or a ``RenderSettings``) gives the body its
    count and its rule, as ``from_mesh`` given both."""
    from nlos_spotlight.render.settings import ImageSampling, RenderSettings

    mesh = mannequin([0.0, 0.0, 0.0], 1.75)
    for s in (PRESETS["small"].render, ImageSampling(person_samples=300), RenderSettings(person_samples=200)):
        p, q = Person.sampled(mesh, [0.5] * 3, s), Person.from_mesh(mesh, [0.5] * 3, s.person_samples, s.person_quadrature)
        assert np.array_equal(p.pos, q.pos) and np.array_equal(p.area, q.area)
    faces, mc = (Person.sampled(mesh, [0.5] * 3, ImageSampling(person_samples=300, person_quadrature=r))
                 for r in ("faces", "mc"))
    assert len(mc) == 300 and len(faces) >= len(mesh.faces) and not np.array_equal(faces.area, mc.area[:len(faces)])


def test_unknown_quadrature_is_refused():
    with pytest.raises(ValueError, match="quadrature"):
        Person.from_mesh(mannequin([0.0, 0.0, 0.0], 1.75), [0.5] * 3, 10, "gauss")


@pytest.fixture(scope="module")
def room_and_body(tmp_path_factory):
    """The small preset's renderer on generated room 0 (every 6th candidate) and a hands_45 body there."""
    from nlos_spotlight.scene.los import los_mesh
    from nlos_spotlight.render.surface import StaticSurfaces
    from nlos_spotlight.render.transport import Renderer
    from nlos_spotlight.world.body import BodyCache, posed_body, sample_body_params
    from nlos_spotlight.world.rooms import RoomConfig, generate_room, person_positions

    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # as dataset generation runs
    cfg = PRESETS["small"]
    scene = generate_room(0, RoomConfig(resolution=cfg.resolution)).scene
    surf = StaticSurfaces(scene)
    los = los_mesh(surf.mesh, surf.engine, scene.camera, cfg.los_vertices)
    settings = cfg.render_settings()
    r = Renderer(scene, settings, aim_points=los.centroids()[::6])
    rng = np.random.default_rng([0, 7])  # the benchmark's person
    xy = person_positions(scene, rng, 1)[0]
    params = dataclasses.replace(sample_body_params(rng, "standing"), posture="hands_45")
    body = posed_body(params, target_faces=cfg.body_faces, cache=BodyCache(tmp_path_factory.mktemp("bodies")))
    yield cfg, r, body, params.albedo, np.array([xy[0], xy[1], scene.hidden_region.floor_z])
    torch.set_num_threads(threads)


def light(r, body, albedo, t, n, quadrature, batch=6000) -> torch.Tensor:
    """Transport images of every candidate, summed over batches of body samples."""
    p = Person.from_mesh(body, albedo, n, quadrature)
    out = 0
    for a in range(0, len(p), batch):
        sl = slice(a, a + batch)
        part = Person(p.mesh, p.pos[sl], p.normal[sl], p.area[sl], p.albedo[sl], p.closed)
        out = out + r.transport_images(part, t).double()
    return out


def test_person_light_within_goal_at_every_preset(room_and_body):
    """The body of every dataset preset (the faces rule, 3500 or 4000) within the 0.5% goal of a 4x
    finer quadrature; the learning-curve and unseen-room datasets' 1500 within their documented 1%
    and farther (the rule converges). The error is the body's: the presets' renderer settings
    change it by under 0.05% (``benchmarks/person_convergence.py``), so one room at ``small``'s
    settings stands for all."""
    _, r, body, albedo, t = room_and_body
    assert all(p.render.person_quadrature == "faces" for p in PRESETS.values())
    ns = sorted({p.render.person_samples for p in PRESETS.values()})
    ref = light(r, body, albedo, t, 4 * max(ns), "faces")
    assert ref.norm() > 0
    errs = {}
    for n, bound in [(n, GOAL) for n in ns] + [(1500, 0.01)]:
        errs[n] = err = float((light(r, body, albedo, t, n, "faces") - ref).norm() / ref.norm())
        print(f"faces rule at {n}: {err:.3%} from a 4x finer quadrature")
        assert err < bound, f"faces rule at {n} samples: {err:.2%} from converged"
    assert errs[min(ns)] < errs[1500]


def test_closed_body_wound_inward_gets_the_same_light():
    """The person is two-sided: a closed body whose faces are wound inward is lit and seen as the
    same body wound outward (the closed-mesh shortcut must not depend on winding)."""
    from nlos_spotlight.render.person import Person, signed_volume
    from nlos_spotlight.render.transport import Renderer, RenderSettings
    from nlos_spotlight.scene.builders import box
    from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene
    from nlos_spotlight.scene.format import TriMesh

    scene = corner_scene("diffuse_corner", resolution=8)
    out = box([1.0, 1.4, 0.0], [1.3, 1.7, 1.7])
    inward = TriMesh(out.vertices, out.faces[:, ::-1].copy())
    assert signed_volume(out) == pytest.approx(0.3 * 0.3 * 1.7) and signed_volume(inward) < 0
    r = Renderer(scene, RenderSettings(pixel_samples=1, transport_pixel_samples=1, spot_samples=8,
                                       person_samples=128), aim_points=SPOT_TARGET[None])
    imgs = [r.render(r.spot_vector(0), Person.from_mesh(m, [0.5] * 3, 128), components=("nlos",)).image
            for m in (out, inward)]
    # reversing a face's vertex order moves its quasi-random samples within it: equal up to the
    # quadrature's own error, which 4x4 blocks average down (before the fix: inward gave 0)
    total = float(imgs[0].sum())
    assert total > 0 and float(imgs[1].sum()) == pytest.approx(total, rel=0.03)
    blocks = [im.reshape(2, 4, 2, 4, 3).sum((1, 3)) for im in imgs]
    torch.testing.assert_close(blocks[1], blocks[0], rtol=0.05, atol=0.01 * float(blocks[0].max()))


@pytest.mark.parametrize("inward", [False, True])
def test_resampled_body_is_the_mc_rule_of_the_same_mesh(inward):
    """``Person.resampled`` (the bounce's coarser body): at offset 0.5 exactly the ``"mc"`` rule's
    samples of the same mesh (positions, areas and normals, turned outward on a closed mesh wound
    inward), whatever quadrature the person was made with; at another offset other points of it."""
    from nlos_spotlight.scene.builders import box
    from nlos_spotlight.scene.format import TriMesh

    out = box([1.0, 1.4, 0.0], [1.3, 1.7, 1.7])
    mesh = TriMesh(out.vertices, out.faces[:, ::-1].copy()) if inward else out
    fine = Person.from_mesh(mesh, [0.4, 0.5, 0.6], 400, "faces")
    coarse, ref = fine.resampled(64, 0.5), Person.from_mesh(mesh, [0.4, 0.5, 0.6], 64, "mc")
    for k in ("pos", "normal", "area", "albedo"):
        assert np.array_equal(getattr(coarse, k), getattr(ref, k)), k
    assert coarse.closed and (coarse.normal * (coarse.pos - out.vertices.mean(0))).sum(1).min() > 0  # outward
    other = fine.resampled(64, 0.2)
    assert not np.allclose(other.pos, coarse.pos) and np.isclose(other.area.sum(), coarse.area.sum())
