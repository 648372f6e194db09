"""Matched-filter backprojection (``data/backprojection.py``): its kernel against a slow reference
with another ray engine, and its answer against people the renderer puts in the hidden area."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.data.backprojection import FloorGrid, backprojector, camera_kernel
from nlos_spotlight.render.gbuffer import render_gbuffer
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.surface import StaticSurfaces
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene


def segment_blocked(tri: np.ndarray, a: np.ndarray, b: np.ndarray, eps: float = 1e-3) -> bool:
    """Some triangle of ``tri`` (F, 3, 3) crosses the segment a -> b short of its ends
    (Moller-Trumbore over all triangles, no acceleration structure)."""
    d = b - a
    length = np.linalg.norm(d)
    d = d / length
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    pvec = np.cross(d, e2)
    det = (e1 * pvec).sum(1)
    ok = np.abs(det) > 1e-12
    inv = 1.0 / np.where(ok, det, 1.0)
    tvec = a - tri[:, 0]
    u = (tvec * pvec).sum(1) * inv
    qvec = np.cross(tvec, e1)
    v = (qvec @ d) * inv
    t = (qvec * e2).sum(1) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > eps) & (t < length - eps)
    return bool(hit.any())


def slow_kernel(mesh, points, pos, normal, albedo):
    """K(p, c) pair by pair: the formula written out, visibility by a brute-force segment test."""
    tri = mesh.vertices[mesh.faces]
    out = np.zeros((len(points), len(pos)))
    for i, p in enumerate(points):
        for j, (c, n, a) in enumerate(zip(pos, normal, albedo)):
            d = p - c
            r = np.linalg.norm(d)
            cos = n @ d / r
            if cos <= 0:
                continue
            out[i, j] = 0.0 if segment_blocked(tri, p, c) else a.mean() * cos / r ** 2
    return out


def test_camera_kernel_matches_a_slow_reference():
    sc = corner_scene("furniture", 8)
    surf = StaticSurfaces(sc)
    g = render_gbuffer(sc, surf)
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.uniform(-2.3, 2.3, 12), rng.uniform(0.2, 3.5, 12), rng.uniform(0.2, 1.6, 12)])
    pos, nrm, alb = g.position[g.hit], g.normal[g.hit], g.albedo[g.hit]
    fast = camera_kernel(surf.engine, points, pos, nrm, alb)
    slow = slow_kernel(surf.mesh, points, pos, nrm, alb)
    both = (fast > 0) & (slow > 0)
    # the partition and the furniture block some pairs; the engines may differ only on grazing ones
    assert 0.1 < (slow > 0).mean() < 0.9 and (slow == 0).sum() > 50
    assert ((fast > 0) != (slow > 0)).mean() < 0.01
    np.testing.assert_allclose(fast[both], slow[both], rtol=1e-9)


def test_backprojection_finds_a_rendered_person():
    """The renderer's body (not the point scatterer the templates assume) at four places: the best
    cell is within 0.35 m of each (grid 0.2 m), far better than the grid's center."""
    sc = corner_scene("diffuse_corner", 24)
    settings = RenderSettings(pixel_samples=1, transport_pixel_samples=1, spot_samples=16, person_samples=256)
    r = Renderer(sc, settings, aim_points=SPOT_TARGET[None])
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, 256)
    reg = sc.hidden_region
    origin = (reg.min + reg.max) / 2
    bp = backprojector(sc, origin, np.array([1.0, 0.0]), FloorGrid(extent=1.4, step=0.2))
    spot = bp.spot_factor(SPOT_TARGET, np.array([0.0, 1.0, 0.0]))
    at = sc.human.mesh.vertices.mean(0)
    places = np.array([(0.6, 1.2), (1.0, 2.6), (1.8, 1.5), (1.3, 2.0)])
    images = []
    with torch.no_grad():
        for xy in places:
            t = np.array([xy[0] - at[0], xy[1] - at[1], 0.0])
            images.append(r.render(r.spot_vector(0), person, translation=t, components=("nlos",))["nlos"].numpy())
    found = bp.locate(np.stack(images), spot)
    err = np.linalg.norm(found - (places - origin), axis=1)
    assert err.max() < 0.35, err
    assert err.mean() < 0.3 * np.linalg.norm(places - origin, axis=1).mean()
    # scaling the image or weighting every pixel alike changes nothing
    np.testing.assert_array_equal(bp.locate(3.0 * np.stack(images), spot, np.full((24, 24), 2.0)), found)


def test_free_mask_keeps_every_placement_cell():
    sc = corner_scene("furniture", 8)
    origin, fwd = np.array([1.35, 2.1]), np.array([1.0, 0.0])
    placement = backprojector(sc, origin, fwd, FloorGrid(extent=1.4, step=0.2)).valid
    free = backprojector(sc, origin, fwd, FloorGrid(extent=1.4, step=0.2, mask="free")).valid
    assert placement.sum() > 10 and (free >= placement).all() and free.sum() > placement.sum()
    with pytest.raises(ValueError, match="mask"):
        backprojector(sc, origin, fwd, FloorGrid(mask="everywhere"))


def test_matched_filter_is_the_same_in_numpy_and_torch():
    """The weighted normalized correlation, written out per template; a template of zeros scores 0."""
    from nlos_spotlight.data.backprojection import matched_filter

    rng = np.random.default_rng(1)
    img, t, w = rng.normal(size=(4, 30)), rng.uniform(size=(5, 30)), rng.uniform(0.5, 2.0, 30)
    t[2] = 0.0
    want = np.array([[(w * t[p] * img[b]).sum() / np.sqrt((w * t[p] ** 2).sum()) if p != 2 else 0.0
                      for p in range(5)] for b in range(4)])
    np.testing.assert_allclose(matched_filter(img, t, w), want, rtol=1e-12)
    got = matched_filter(*(torch.as_tensor(a) for a in (img, t, w)))
    np.testing.assert_allclose(got.numpy(), want, rtol=1e-12)
    np.testing.assert_allclose(matched_filter(img, t), matched_filter(img, t, np.ones(30)), rtol=1e-12)
