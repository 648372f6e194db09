"""Spot policies and the flash: center, oracle, adaptive lighting, flash, and the SNR they rank by."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from nlos_spotlight.data.flash import effective_solid_angle, flash_projector, half_diagonal_fov_deg, total_flux
from nlos_spotlight.errors import NlosError
from nlos_spotlight.lighting import POLICIES, Illumination
from nlos_spotlight.lighting.adaptive import AdaptiveConfig, adaptive_scores
from nlos_spotlight.lighting.center import center_candidate
from nlos_spotlight.lighting.oracle import ranked_oracle
from nlos_spotlight.lighting.snr import candidate_snr, scene_snr, snr
from nlos_spotlight.render.sensor import SensorConfig
from nlos_spotlight.render.camera import pixel_rays
from nlos_spotlight.render.rays import RayEngine
from nlos_spotlight.render.sensor import auto_exposure
from nlos_spotlight.render.spot import cone_directions, spot_profile
from nlos_spotlight.scene import load_scene
from nlos_spotlight.scene.builders import quad
from nlos_spotlight.scene.format import Camera, HiddenRegion, Material, Projector, Scene, Shape
from nlos_spotlight.train.imaging import form_images



# ----------------------------------------------------------------------------------------- SNR
def test_scene_snr_equals_the_per_candidate_formula(micro_config, micro_scene):
    """The batched SNR equals SNR_t = sqrt(sum_p s_p^2 / var_p) evaluated one candidate at a time."""
    scene_dir, _ = micro_scene
    st = np.load(scene_dir / "static.npz")
    cfg = SensorConfig.for_scene(load_scene(scene_dir))
    direct, ambient = torch.as_tensor(st["direct"]).double(), torch.as_tensor(st["ambient"]).double()
    landed = st["spot_landed"]
    rows = []
    for path in sorted((scene_dir / "samples").glob("*.npz")):
        z = np.load(path)
        if int(z["trajectory"]) >= 0:
            continue
        f = torch.einsum("tr,rhwc->thwc", torch.as_tensor(z["transport_u"]).double(),
                         torch.as_tensor(z["transport_v"]).double())
        na = torch.as_tensor(z["nlos_ambient"]).double()
        rows.append([snr(f[t], direct[t] + ambient + f[t] + na, auto_exposure(direct[t] + ambient, cfg), cfg)
                     if landed[t] else 0.0 for t in range(len(landed))])
    assert len(rows) == micro_config["samples_per_scene"]  # the walk's frames are left out
    got = scene_snr(scene_dir)
    np.testing.assert_allclose(got.candidates, np.mean(rows, axis=0), rtol=1e-10)
    assert got.samples == len(rows) and got.flash is not None and got.flash > 0 and got.ambient > 0


# -------------------------------------------------------------------------------------- center
def test_center_policy_picks_the_candidate_nearest_the_image_center(micro_scene):
    scene_dir, s = micro_scene
    st = np.load(scene_dir / "static.npz")
    cam = load_scene(scene_dir).camera
    # brute force: camera frame from the stored pose (columns right, up, backward, position)
    pose = st["camera_to_world"]
    rel = (st["aim_points"] - pose[:3, 3]) @ pose[:3, :3]  # (T, 3) in camera coordinates
    depth = -rel[:, 2]
    tan_x = math.tan(math.radians(cam.fov_deg) / 2)
    tan_y = tan_x * cam.height / cam.width
    col = (rel[:, 0] / (depth * tan_x) + 1) / 2 * cam.width
    row = (1 - rel[:, 1] / (depth * tan_y)) / 2 * cam.height
    best, best_d = -1, np.inf
    for t in range(len(depth)):
        d = math.hypot(row[t] - cam.height / 2, col[t] - cam.width / 2)
        if st["spot_landed"][t] and depth[t] > 0 and d < best_d:
            best, best_d = t, d
    ill = POLICIES["center"](s, scene_dir, np.random.default_rng(0))
    assert ill == Illumination("spot", best)


def test_center_candidate_skips_unlanded_and_behind_camera():
    cam = Camera(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 0, 1.0]), 60.0, 10, 10)
    aims = np.array([[-5.0, 0, 0], [5.0, 0, 0], [5.0, 0.3, 0.1], [5.0, 2.0, 0]])  # behind, dead center, ...
    assert center_candidate(cam, aims, np.array([True, True, True, True])) == 1
    assert center_candidate(cam, aims, np.array([True, False, True, True])) == 2
    with pytest.raises(NlosError):
        center_candidate(cam, aims, np.array([True, False, False, False]))


# -------------------------------------------------------------------------------------- oracle
def test_oracle_has_the_highest_snr_and_matches_the_training_images(micro_scene):
    scene_dir, s = micro_scene
    values = candidate_snr(scene_dir)
    ill = POLICIES["oracle"](s, scene_dir, np.random.default_rng(0))
    assert ill.mode == "spot" and bool(s.landed[ill.face])
    landed = s.landed.numpy()
    assert np.all(values[ill.face] >= values[landed]) and values[ill.face] > values[landed].mean()
    assert np.all(values[~landed] == 0)
    # the same SNR from the images the trainer forms (float32 tensors, y one-hot)
    cfg = SensorConfig.for_scene(load_scene(scene_dir))
    static_idx = torch.nonzero(s.trajectory[:, 0] < 0).flatten()
    for t in {ill.face, int(np.flatnonzero(landed)[0])}:
        images, free = form_images(s, static_idx, Illumination("spot", t).spot_vector(len(s.faces)))
        signal = images - free - s.nlos_ambient[static_idx]
        e = auto_exposure(free.double(), cfg)
        mine = np.mean([snr(signal[i].double(), images[i].double(), e, cfg) for i in range(len(static_idx))])
        assert mine == pytest.approx(values[t], rel=1e-4)


def test_ranked_oracles_are_the_runners_up_by_snr(micro_scene):
    scene_dir, s = micro_scene
    values, landed = candidate_snr(scene_dir), s.landed.numpy()
    faces = [POLICIES["oracle"](s, scene_dir, None).face] + [
        POLICIES[f"oracle-{k}"](s, scene_dir, None).face for k in range(2, min(7, int(landed.sum()) + 1))]
    assert len(faces) >= 3 and len(set(faces)) == len(faces) and all(landed[faces])
    snr = values[faces]
    assert np.all(np.diff(snr) <= 0)  # each rank no brighter than the one above it
    # and no landed spot outside the first k is brighter than rank k
    rest = np.delete(values, faces)[np.delete(landed, faces)]
    assert rest.size == 0 or rest.max() <= snr[-1]
    with pytest.raises(NlosError, match="rank"):
        ranked_oracle(int(landed.sum()) + 1)(s, scene_dir, None)


# --------------------------------------------------------------------------------------- flash
def test_flash_has_the_projector_flux_and_covers_the_view():
    proj = Projector(np.zeros(3), np.array([50.0, 40.0, 30.0]), 3.0, 5.0)
    for fov, w, h in [(50.0, 64, 64), (40.0, 48, 32), (60.0, 12, 12)]:
        cam = Camera(np.array([1.0, 2.0, 1.5]), np.array([4.0, 0.0, 1.0]), np.array([0, 0, 1.0]), fov, w, h)
        fl = flash_projector(cam, proj)
        np.testing.assert_allclose(total_flux(fl), total_flux(proj), rtol=1e-12)
        np.testing.assert_array_equal(fl.position, cam.position)
        # full intensity out to the image corners: every pixel ray (4 x 4 sub-samples) lies inside
        # the beam, and the corner-most ones come within a pixel's angle of its edge
        dirs, _ = pixel_rays(cam, 4)
        axis = (cam.look_at - cam.position) / np.linalg.norm(cam.look_at - cam.position)
        widest = np.degrees(np.arccos((dirs.reshape(-1, 3) @ axis).min()))
        pixel_deg = fov / w
        assert widest < fl.beam_width_deg < widest + pixel_deg and fl.cutoff_deg == fl.beam_width_deg + 5.0
        assert fl.beam_width_deg == pytest.approx(half_diagonal_fov_deg(cam))
        # Omega(b, c) in closed form equals the renderer's cone quadrature of the profile
        for b, c in [(proj.beam_width_deg, proj.cutoff_deg), (fl.beam_width_deg, fl.cutoff_deg)]:
            _, theta, domega = cone_directions(np.array([0, 0, 1.0]), c, 200_000)
            assert (spot_profile(theta, b, c) * domega).sum() == pytest.approx(effective_solid_angle(b, c), rel=1e-6)
    # as the ramp vanishes, Omega tends to the cone's solid angle 2 pi (1 - cos b)
    assert effective_solid_angle(10.0, 10.0001) == pytest.approx(2 * math.pi * (1 - math.cos(math.radians(10))),
                                                                 rel=1e-5)


def test_flash_policy_and_stored_flash_images(micro_scene):
    scene_dir, s = micro_scene
    assert POLICIES["flash"](s, scene_dir, np.random.default_rng(0)) == Illumination("flash")
    # the flash lights nearly the whole view; the best spot lights a small part of it
    lit = (s.flash_direct.sum(-1) > 0).float().mean()
    best = int(s.direct.sum(dim=(1, 2, 3)).argmax())
    assert lit > 0.9 and (s.direct[best].sum(-1) > 0).float().mean() < 0.5 * lit
    assert s.flash_nlos.shape == s.nlos_ambient.shape and float(s.flash_nlos.abs().sum()) > 0
    images, free = form_images(s, torch.arange(2), None, "flash")
    torch.testing.assert_close(images - free, s.flash_nlos[:2] + s.nlos_ambient[:2])
    s.flash_direct = None
    with pytest.raises(NlosError, match="no flash"):
        POLICIES["flash"](s, scene_dir, np.random.default_rng(0))


# ------------------------------------------------------------------------------------ adaptive
def two_wall_scene() -> Scene:
    """Wall A (x = 0, facing -x) beside the hidden region, panel B turned to face +y (away from it).

    Camera and projector stand at x = -3 looking +x; the hidden region lies at y < -2.5, on
    A's lit side and behind B's.
    """
    a = quad([0, -2.5, 0], [0, 0, 2.5], [0, 2.5, 0], 4, 8)  # normal (0, 0, 2.5) x (0, 2.5, 0) -> -x
    u = np.array([1.0, 0.3, 0.0]) / np.linalg.norm([1.0, 0.3, 0.0])
    b = quad([0, 0.4, 0], 1.2 * u, [0, 0, 2.5], 3, 6)  # normal along u x z = (0.3, -1, 0): two-sided
    cam = Camera(np.array([-3.0, 0.0, 1.2]), np.array([0.0, 0.0, 1.2]), np.array([0, 0, 1.0]), 70.0, 16, 16)
    proj = Projector(np.array([-3.0, 0.3, 1.2]), np.full(3, 50.0), 3.0, 5.0)
    mats = {"a": Material(np.full(3, 0.7)), "b": Material(np.full(3, 0.7))}
    return Scene([Shape("a.ply", "a", a), Shape("b.ply", "b", b)], mats, cam, proj,
                 hidden_region=HiddenRegion(np.array([-2.5, -4.0]), np.array([-1.0, -2.7]), 0.0))


def slow_adaptive(scene: Scene, aims: np.ndarray, cfg: AdaptiveConfig) -> np.ndarray:
    """score_t = (rho/pi)^3 a / P sum_j Phi_j sum_{m,k} sum_p G+(x_j, o_mk) V G+(o_mk, x_p) V, term by term."""
    mesh, _ = scene.static_mesh()
    eng = RayEngine(mesh.vertices, mesh.faces)

    def hit(origin, d):
        h = eng.first_hit(origin[None].copy(), d[None])
        if not h.hit[0]:
            return None
        p = origin + d * h.t[0]
        tri = mesh.vertices[mesh.faces[h.face[0]]]
        n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
        n /= np.linalg.norm(n)
        return p, (n if n @ (origin - p) > 0 else -n)

    def g_plus(p, n_p, o, n_o):  # surface point p -> body element o: one-sided at both ends
        w = (o - p) / np.linalg.norm(o - p)
        return max(0.0, n_p @ w) * max(0.0, -(n_o @ w)) / np.sum((o - p) ** 2)

    def visible(p, n_p, o):
        return not eng.occluded(p[None], o[None], n_p[None], None)[0]

    reg = scene.hidden_region
    body = []
    for i in range(cfg.grid):
        for j in range(cfg.grid):
            for z in cfg.heights:
                x = reg.min[0] + (i + 0.5) / cfg.grid * (reg.max[0] - reg.min[0])
                y = reg.min[1] + (j + 0.5) / cfg.grid * (reg.max[1] - reg.min[1])
                body.append(np.array([x, y, reg.floor_z + z]))
    normals = [np.array([math.cos(2 * math.pi * k / cfg.normals), math.sin(2 * math.pi * k / cfg.normals), 0.0])
               for k in range(cfg.normals)]
    probe = Camera(scene.camera.position, scene.camera.look_at, scene.camera.up, scene.camera.fov_deg,
                   cfg.receivers, cfg.receivers)
    dirs, origin = pixel_rays(probe, 1)
    recv = [r for r in (hit(origin, d) for d in dirs.reshape(-1, 3)) if r is not None]
    pr = scene.projector
    out = np.zeros(len(aims))
    for t, aim in enumerate(aims):
        d, theta, domega = cone_directions(aim - pr.position, pr.cutoff_deg, cfg.spot_rays)
        for dj, th in zip(d, theta):
            src = hit(pr.position, dj)
            if src is None:
                continue
            phi = spot_profile(th, pr.beam_width_deg, pr.cutoff_deg) * domega
            for o in body:
                if not visible(src[0], src[1], o):
                    continue
                for n_o in normals:
                    g_in = g_plus(src[0], src[1], o, n_o)
                    if g_in == 0:
                        continue
                    g_out = sum(g_plus(p, n_p, o, n_o) for p, n_p in recv if visible(p, n_p, o))
                    out[t] += phi * g_in * g_out
    area = 1.0 / (len(body) * len(normals))
    return (cfg.albedo / math.pi) ** 3 * area / len(recv) * out


def test_adaptive_ranks_the_patch_facing_the_hidden_region_first_and_matches_the_slow_sum():
    scene = two_wall_scene()
    aims = np.array([[0.0, -2.2, 1.2],   # A, next to the hidden region
                     [0.0, -0.3, 1.2],   # A, farther from it
                     [0.5, 0.55, 1.2]])  # B, facing away from it
    cfg = AdaptiveConfig(grid=2, heights=(0.5, 1.4), normals=4, spot_rays=4, receivers=8)
    fast = adaptive_scores(scene, aims, cfg)
    assert fast[0] > fast[1] > 0 and fast[2] == 0
    np.testing.assert_allclose(fast, slow_adaptive(scene, aims, cfg), rtol=1e-9)
    assert list(np.argsort(-adaptive_scores(scene, aims))) == [0, 1, 2]  # same ranking at the default resolution


def test_adaptive_policy_ignores_materials(micro_scene):
    scene_dir, s = micro_scene
    ill = POLICIES["adaptive"](s, scene_dir, np.random.default_rng(0))
    assert ill.mode == "spot" and bool(s.landed[ill.face])
    scene, aims = load_scene(scene_dir), np.load(scene_dir / "static.npz")["aim_points"]
    scores = adaptive_scores(scene, aims)
    assert ill.face == int(np.argmax(np.where(s.landed.numpy(), scores, -np.inf))) and scores.max() > 0
    for m in scene.materials.values():  # black, glossy, glowing: the policy must not see any of it
        m.diffuse, m.specular, m.emission = np.zeros(3), np.full(3, 0.9), np.ones(3)
    np.testing.assert_array_equal(adaptive_scores(scene, aims), scores)
