"""Procedural rooms: validity per family, determinism, round trip, the ray-cast hidden and relay
checks on independent denser points, materials that follow shapes, person positions, a render."""

from __future__ import annotations

import time

import numpy as np
import pytest
import torch

from nlos_spotlight.errors import NlosError
from nlos_spotlight.render.camera import pixel_rays, project
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.rays import RayEngine
from nlos_spotlight.render.transport import Renderer, RenderSettings
from nlos_spotlight.scene.builders import mannequin
from nlos_spotlight.scene.io import load_scene, save_scene
from nlos_spotlight.world.materials import CLASSES, EMISSIVE_KINDS, KIND_CLASSES, class_of, in_class
from nlos_spotlight.world.rooms import FAMILIES, RoomConfig, generate_room, person_positions, room_config_from_dict

SEEDS = (0, 1, 2)


@pytest.fixture(scope="module")
def rooms():
    out = {}
    for fam in FAMILIES:
        for seed in SEEDS:
            t0 = time.perf_counter()
            room = generate_room(seed, RoomConfig(families=[fam], resolution=24))
            room.stats["test_seconds"] = time.perf_counter() - t0
            out[fam, seed] = room
    return out


def _engine(scene) -> RayEngine:
    mesh, _ = scene.static_mesh()
    return RayEngine(mesh.vertices, mesh.faces)


def _camera_los(scene, engine, n=40):
    """Independent camera-visible points: first hits of an n x n pixel grid, normals toward the camera."""
    cam = scene.camera
    from nlos_spotlight.scene.format import Camera

    probe = Camera(cam.position, cam.look_at, cam.up, cam.fov_deg, n, n)
    d, o = pixel_rays(probe, 1)
    d = d.reshape(-1, 3)
    h = engine.first_hit(np.broadcast_to(o, d.shape).copy(), d)
    p = o + d[h.hit] * h.t[h.hit, None]
    tri = engine.vertices[engine.faces[h.face[h.hit]]]
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm *= np.sign(((o - p) * nrm).sum(1))[:, None]
    return p, nrm, h.face[h.hit]


# ------------------------------------------------------------------------------ validity
def test_every_family_generates_valid_scenes(rooms):
    for (fam, seed), room in rooms.items():
        sc = room.scene
        assert room.family == fam and room.seed == seed
        assert sc.human is None
        reg = sc.hidden_region
        assert np.all(reg.max - reg.min >= 3.0), (fam, seed, reg.max - reg.min)
        assert 2000 <= sc.num_faces <= 8000, (fam, seed, sc.num_faces)
        cam, pr = sc.camera, sc.projector
        assert 40 <= cam.fov_deg <= 60 and cam.width == cam.height == 24
        assert 1.1 <= cam.position[2] <= 1.7
        assert 1.5 <= room.stats["camera_wall_distance"] <= 4.0
        fwd = cam.look_at - cam.position
        fwd_h = np.array([fwd[0], fwd[1], 0.0]) / np.hypot(fwd[0], fwd[1])
        off = pr.position - cam.position
        lateral = abs(off[0] * fwd_h[1] - off[1] * fwd_h[0])
        assert 0.15 - 1e-9 <= lateral <= 0.6 + 1e-9, lateral
        # 4000 lm over a 1.5-throw 16:9 image, 300 lm/W, three channels (world/calibration.py)
        a, b = 2 * np.arctan(1 / 3.0), 2 * np.arctan(1 / (3.0 * 16 / 9))
        assert np.allclose(pr.intensity, 4000 / (4 * np.arcsin(np.sin(a / 2) * np.sin(b / 2))) / 900)
        assert pr.beam_width_deg == 3.0 and pr.cutoff_deg == 5.0
        lux = lambda L: L * np.pi * 900  # uniform radiance per channel -> illuminance
        assert np.all((lux(sc.ambient.radiance) >= 2 - 1e-9) & (lux(sc.ambient.radiance) <= 40 + 1e-9))
        assert np.all((lux(sc.ambient.hidden_radiance) >= 0.1 - 1e-9) & (lux(sc.ambient.hidden_radiance) <= 2 + 1e-9))
        assert sc.ambient is not None and np.all(sc.ambient.radiance > 0) and np.all(sc.ambient.hidden_radiance > 0)
        assert len(room.kinds) == len(sc.shapes)
        assert {"wall", "floor", "ceiling"} <= set(room.kinds)
        assert len(room.relay_faces) > 20 and np.all(np.diff(room.relay_faces) > 0)
        assert room.relay_faces.max() < sc.num_faces and 0 <= room.aim_face < sc.num_faces
        # the camera sees non-planar geometry: furniture or occluders, not just walls, floor, ceiling
        _, owner = sc.static_mesh()
        seen = {room.kinds[i] for i in owner[room.relay_faces]}
        assert seen - {"wall", "floor", "ceiling", "baseboard"}, (fam, seed, seen)
        mats = [sc.materials[s.material] for s in sc.shapes]
        for m in mats:
            assert np.all((m.diffuse >= 0) & (m.diffuse <= 1)) and np.all((m.specular >= 0) & (m.specular <= 1))


def test_generation_is_fast(rooms):
    t = [r.stats["test_seconds"] for r in rooms.values()]
    assert np.mean(t) < 2.0 and max(t) < 6.0, t


def test_deterministic_in_seed(rooms):
    a = rooms["doorway", 1]
    b = generate_room(1, RoomConfig(families=["doorway"], resolution=24))
    assert [s.mesh_file for s in a.scene.shapes] == [s.mesh_file for s in b.scene.shapes]
    for sa, sb in zip(a.scene.shapes, b.scene.shapes):
        assert np.array_equal(sa.mesh.vertices, sb.mesh.vertices) and np.array_equal(sa.mesh.faces, sb.mesh.faces)
        assert (sa.mesh.vertex_colors is None) == (sb.mesh.vertex_colors is None)
        if sa.mesh.vertex_colors is not None:
            assert np.array_equal(sa.mesh.vertex_colors, sb.mesh.vertex_colors)
        assert sa.material == sb.material
    assert a.scene.materials.keys() == b.scene.materials.keys()
    for k, m in a.scene.materials.items():
        assert m.to_dict() == b.scene.materials[k].to_dict()
    assert a.scene.camera.to_dict() == b.scene.camera.to_dict()
    assert a.scene.projector.to_dict() == b.scene.projector.to_dict()
    assert a.scene.hidden_region.to_dict() == b.scene.hidden_region.to_dict()
    assert np.array_equal(a.relay_faces, b.relay_faces) and np.array_equal(a.aim_point, b.aim_point)
    # other seeds differ
    c = rooms["doorway", 2]
    assert c.scene.camera.to_dict() != a.scene.camera.to_dict()
    assert c.scene.num_faces != a.scene.num_faces or not np.array_equal(
        c.scene.static_mesh()[0].vertices, a.scene.static_mesh()[0].vertices)


def test_family_is_drawn_from_config():
    fams = {generate_room(s, RoomConfig(resolution=8, families=["l_corner", "doorway"])).family for s in range(6)}
    assert fams <= {"l_corner", "doorway"}
    w = RoomConfig(resolution=8, family_weights={f: 0.0 for f in FAMILIES if f != "corridor_junction"})
    assert generate_room(3, w).family == "corridor_junction"
    with pytest.raises(NlosError, match="unknown family"):
        RoomConfig(families=["kitchen_island"])
    cfg = room_config_from_dict({"families": ["doorway"], "fov_range": [45, 50], "texture": False})
    assert cfg.fov_range == (45, 50) and not cfg.texture
    with pytest.raises(NlosError, match="unknown key"):
        room_config_from_dict({"colour": 1})


def test_save_load_round_trip(rooms, tmp_path):
    room = rooms["cluttered_office", 0]
    save_scene(room.scene, tmp_path / "room")
    back = load_scene(tmp_path / "room")
    assert back.human is None
    assert [s.mesh_file for s in back.shapes] == [s.mesh_file for s in room.scene.shapes]
    for s0, s1 in zip(room.scene.shapes, back.shapes):
        assert np.array_equal(s0.mesh.vertices, s1.mesh.vertices)
        assert np.array_equal(s0.mesh.faces, s1.mesh.faces)
        if s0.mesh.vertex_colors is None:
            assert s1.mesh.vertex_colors is None
        else:  # quantized to 8 bits by the generator, so PLY stores them exactly
            assert np.array_equal(s0.mesh.vertex_colors, s1.mesh.vertex_colors)
    for k, m in room.scene.materials.items():
        assert m.to_dict() == back.materials[k].to_dict()
    for part in ("camera", "projector", "ambient", "hidden_region"):
        assert getattr(room.scene, part).to_dict() == getattr(back, part).to_dict()


def test_texture_switch():
    on = generate_room(5, RoomConfig(resolution=8, families=["partitioned_room"]))
    off = generate_room(5, RoomConfig(resolution=8, families=["partitioned_room"], texture=False))
    assert any(s.mesh.vertex_colors is not None for s in on.scene.shapes)
    assert all(s.mesh.vertex_colors is None for s in off.scene.shapes)
    assert on.scene.camera.to_dict() == off.scene.camera.to_dict()  # textures do not change the layout
    assert off.scene.num_faces < on.scene.num_faces


# ------------------------------------------------------------------------------ ray-cast checks
def test_hidden_region_hidden_on_denser_points(rooms):
    """Independent of the generator's own check: jittered points every 5 cm over the region grown
    by the body radius (disk-rounded corners), 12 heights up to 1.9 m, segments to camera and projector."""
    rng = np.random.default_rng(1234)
    for (fam, seed), room in rooms.items():
        sc = room.scene
        eng = _engine(sc)
        reg = sc.hidden_region
        r = 0.25
        lo, hi = reg.min - r, reg.max + r
        n = np.ceil((hi - lo) / 0.05).astype(int) + 1
        gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], n[0]), np.linspace(lo[1], hi[1], n[1]), indexing="ij")
        xy = np.stack([gx.ravel(), gy.ravel()], 1) + rng.uniform(-0.025, 0.025, (gx.size, 2))
        d = np.linalg.norm(np.maximum(0, np.maximum(reg.min - xy, xy - reg.max)), axis=1)
        xy = xy[d <= r]
        hs = np.linspace(0.01, 1.9, 12)
        pts = np.concatenate([np.repeat(xy, len(hs), 0), reg.floor_z + np.tile(hs, len(xy))[:, None]], 1)
        for src in (sc.camera.position, sc.projector.position):
            vis = ~eng.occluded(np.broadcast_to(src, pts.shape).copy(), pts)
            assert not vis.any(), (fam, seed, pts[vis][:5])


def test_relay_surfaces_visible_from_hidden_region(rooms):
    """Light can go wall -> person -> wall: from points in the region, a good fraction of the
    camera-visible points is visible (on the camera's side of its surface)."""
    for (fam, seed), room in rooms.items():
        sc = room.scene
        eng = _engine(sc)
        p, nrm, _ = _camera_los(sc, eng)
        reg = sc.hidden_region
        rng = np.random.default_rng(seed)
        q = np.concatenate([rng.uniform(reg.min, reg.max, (30, 2)), rng.uniform(0.3, 1.7, (30, 1))], 1)
        qq, pp, nn = np.repeat(q, len(p), 0), np.tile(p, (len(q), 1)), np.tile(nrm, (len(q), 1))
        side = ((qq - pp) * nn).sum(1) > 0
        vis = side.copy()
        vis[side] = ~eng.occluded(pp[side], qq[side], nn[side], None)
        frac = vis.reshape(len(q), len(p)).mean(1)
        assert frac.mean() >= 0.05, (fam, seed, frac.mean())
        assert (frac > 0).mean() >= 0.6, (fam, seed, (frac > 0).mean())
        # the aim point (center of the relay area) is lit by the projector and seen by the camera
        a = room.aim_point
        for src in (sc.camera.position, sc.projector.position):
            assert not eng.occluded(src[None], a[None] + 0.01 * (src - a)[None] / np.linalg.norm(src - a))[0]


# ------------------------------------------------------------------------------ materials
def test_materials_follow_shapes(rooms):
    seen = set()
    for (fam, seed), room in rooms.items():
        sc = room.scene
        for shape, kind in zip(sc.shapes, room.kinds):
            m = sc.materials[shape.material]
            cls = class_of(shape.material)
            assert cls in KIND_CLASSES[kind], (kind, cls)
            assert in_class(m, cls), (kind, cls, m)
            seen.add(kind)
            if kind == "fridge":
                assert m.specular.min() >= 0.5 and m.diffuse.max() <= 0.1 and 0.1 <= m.roughness <= 0.3
            if kind in ("glass", "mirror", "window"):
                assert m.roughness <= 0.08 and m.specular.min() >= 0.3 and m.diffuse.max() <= 0.05
            if kind == "whiteboard":
                assert 0.75 <= m.diffuse.min() and m.diffuse.max() <= 0.85
                assert 0.05 <= m.specular.min() <= m.specular.max() <= 0.15 and 0.05 <= m.roughness <= 0.15
            if kind == "wall":
                assert 0.5 <= m.diffuse.max() <= 0.85 and m.specular.max() == 0 and m.emission.max() == 0
                assert m.diffuse.max() - m.diffuse.min() <= 0.12 * m.diffuse.max() + 1e-9  # a slight tint
            if kind in ("cabinet", "shelf") or cls == "wood":
                assert m.diffuse[0] > m.diffuse[1] > m.diffuse[2]  # brown
                assert 0.02 <= m.specular.min() <= m.specular.max() <= 0.06 and 0.3 <= m.roughness <= 0.5
            if kind in EMISSIVE_KINDS:
                assert m.emission.max() > 0
            elif kind != "glass":
                assert m.emission.max() == 0, kind
    # the checks above are not vacuous: every special material occurs in this set of rooms
    assert {"fridge", "whiteboard", "monitor", "lamp", "window", "cabinet", "shelf"} <= seen, seen
    assert seen & {"glass", "mirror"}
    assert set(CLASSES) >= {c for k in KIND_CLASSES.values() for c in k}


def test_some_shapes_are_textured(rooms):
    n = sum(s.mesh.vertex_colors is not None for r in rooms.values() for s in r.scene.shapes)
    assert n >= 3 * len(rooms)


# ------------------------------------------------------------------------------ person positions
def test_person_positions(rooms):
    for (fam, seed), room in list(rooms.items())[::2]:
        sc = room.scene
        rng = np.random.default_rng(seed)
        xy = person_positions(sc, rng, 40)
        assert xy.shape == (40, 2)
        reg = sc.hidden_region
        assert np.all((xy >= reg.min) & (xy <= reg.max))
        assert np.array_equal(xy, person_positions(sc, np.random.default_rng(seed), 40))
        eng = _engine(sc)
        p, nrm, _ = _camera_los(sc, eng, 128)
        # distance from the body axis (0..1.9 m) to camera-visible points on the person's side
        z = np.clip(p[None, :, 2], reg.floor_z, reg.floor_z + 1.9)
        d = np.stack([xy[:, None, 0] - p[None, :, 0], xy[:, None, 1] - p[None, :, 1],
                      np.broadcast_to(z - p[None, :, 2], (len(xy), len(p)))], -1)
        facing = (d * nrm[None]).sum(-1) > 0
        dist = np.where(facing, np.linalg.norm(d, axis=-1), np.inf).min(1)
        # a 128 x 128 grid, finer than the generator's 96 x 96: allow a few centimeters
        assert np.all(dist >= 0.6 - 0.08) and np.all(dist <= 2.4 + 0.08), (fam, seed, dist.min(), dist.max())
        # no static geometry (except the floor) within 0.3 m of the body axis: dense surface samples
        mesh, _ = sc.static_mesh()
        import trimesh

        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        s, _ = trimesh.sample.sample_surface_even(tm, 60000, seed=0)
        s = s[(s[:, 2] > reg.floor_z + 0.05) & (s[:, 2] < reg.floor_z + 1.9)]
        horiz = np.linalg.norm(xy[:, None, :] - s[None, :, :2], axis=-1).min(1)
        assert np.all(horiz > 0.27), (fam, seed, horiz.min())
        # every position sees some camera-visible surface (its light reaches the image)
        q = np.concatenate([np.repeat(xy, 3, 0), np.tile([0.5, 1.0, 1.5], len(xy))[:, None] + reg.floor_z], 1)
        sub = slice(None, None, 7)
        pp, nn = p[sub], nrm[sub]
        qq, ppp, nnn = np.repeat(q, len(pp), 0), np.tile(pp, (len(q), 1)), np.tile(nn, (len(q), 1))
        side = ((qq - ppp) * nnn).sum(1) > 0
        vis = side.copy()
        vis[side] = ~eng.occluded(ppp[side], qq[side], nnn[side], None)
        assert np.all(vis.reshape(len(xy), -1).any(1)), (fam, seed)


def test_person_positions_need_a_region(rooms):
    import copy

    sc = copy.copy(rooms["l_corner", 0].scene)
    sc.hidden_region = None
    with pytest.raises(NlosError, match="hidden_region"):
        person_positions(sc, np.random.default_rng(0), 3)


# ------------------------------------------------------------------------------ rendering
def test_render_with_a_person(rooms):
    room = generate_room(2, RoomConfig(families=["partitioned_room"], resolution=16))
    sc = room.scene
    settings = RenderSettings(pixel_samples=2, transport_pixel_samples=1, spot_samples=16, person_samples=64,
                              device="cpu")
    # a camera-visible relay face near the hidden region: the aim face, best seen from the region
    mesh, _ = sc.static_mesh()
    aim = mesh.centroids()[room.aim_face]
    assert room.aim_face in set(room.relay_faces.tolist())
    r = Renderer(sc, settings, aim_points=aim[None])
    xy = person_positions(sc, np.random.default_rng(0), 8)
    totals = []
    for p in xy:
        body = Person.from_mesh(mannequin([0.0, 0.0, 0.0], 1.75), np.array([0.6, 0.5, 0.4]), settings.person_samples)
        out = r.render(r.spot_vector(0), body, translation=np.array([p[0], p[1], sc.hidden_region.floor_z]))
        for k in ("direct", "ambient", "nlos", "nlos_ambient"):
            assert torch.isfinite(out[k]).all()
        totals.append(float(out["nlos"].sum()))
        assert float(out["nlos"].min()) >= 0
    assert max(totals) > 0
    direct = out["direct"].sum(-1).numpy()
    assert direct.max() > 0
    row, col = np.unravel_index(np.argmax(direct), direct.shape)
    exp = project(sc.camera, aim[None])[0]
    assert abs(row + 0.5 - exp[0]) <= 3 and abs(col + 0.5 - exp[1]) <= 3  # the spot is where it was aimed
    assert max(totals) > 1e-7 * float(out["direct"].sum())
