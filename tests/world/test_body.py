"""The hidden person: Anny bodies posed, decimated and cached (nlos_spotlight.world.body).

One module-scoped cache in a temporary folder; the Anny model is loaded once for the whole
file (the first load ever also builds Anny's own asset cache, 15-55 s on 2 cores).
"""

from __future__ import annotations

import math
import os
import time

import numpy as np
import pytest
import trimesh

from nlos_spotlight.errors import NlosError
from nlos_spotlight.world import body as B
from nlos_spotlight.world.body import (
    POSTURES,
    BodyCache,
    BodyParams,
    joint_directions,
    pose_distance_deg,
    posed_body,
    posed_joints,
    posture_directions,
    sample_body_params,
)

BUILD = dict(gender=0.0, weight=0.5, muscle=0.3, proportions=0.2)   # one build bucket per stature


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    B.anny_model()   # load once, before any timing below
    return BodyCache(tmp_path_factory.mktemp("bodies"), variants_per_posture=3)


def person(posture: str, height: float = 1.75, facing: float = 0.0, seed: int = 0, **build) -> BodyParams:
    return BodyParams(posture, height, facing_deg=facing, pose_seed=seed, **{**BUILD, **build})


def height_of(mesh) -> float:
    return float(np.ptp(mesh.vertices[:, 2]))


def horizontal_reach(joints: dict, name: str) -> float:
    """Horizontal distance of a joint from the vertical axis through the pelvis."""
    return float(np.linalg.norm((joints[name] - joints["root"])[:2]))


def test_posture_classes_are_in_network_order():
    assert POSTURES == ("standing", "sitting", "crouching", "hands_90", "hands_45", "unknown")


@pytest.mark.parametrize("height", [1.52, 1.63, 1.76, 1.89])
def test_standing_height_feet_and_pelvis(cache, height):
    for build in (BUILD, dict(gender=1.0, weight=0.9, muscle=0.8, proportions=0.9)):
        params = BodyParams("standing", height, pose_seed=1, **build)
        mesh = posed_body(params, cache=cache)
        joints = posed_joints(params, cache=cache)
        assert abs(height_of(mesh) - height) < 0.01
        assert abs(mesh.vertices[:, 2].min()) < 1e-9            # soles on the floor
        assert np.allclose(joints["root"][:2], 0.0, atol=1e-9)   # pelvis above the origin
        assert 0.47 * height < joints["root"][2] < 0.6 * height  # and at pelvis height


@pytest.mark.parametrize("height", [1.55, 1.85])
def test_sitting_and_crouching_fold_the_same_person(cache, height):
    standing = height_of(posed_body(person("standing", height), cache=cache))
    sitting = person("sitting", height)
    crouching = person("crouching", height)
    # seated on a chair: popliteal + sitting height, about 0.78 of the stature
    assert 0.65 < height_of(posed_body(sitting, cache=cache)) / standing < 0.82
    assert 0.45 < height_of(posed_body(crouching, cache=cache)) / standing < 0.7
    for arms in ("hands_90", "hands_45"):   # raised arms stay below the crown
        assert abs(height_of(posed_body(person(arms, height), cache=cache)) - height) < 0.01
    s = posed_joints(sitting, cache=cache)
    for side in "LR":   # thighs level, knees well in front of the hips, shins vertical
        hip, knee, ankle = s[f"upperleg01.{side}"], s[f"lowerleg01.{side}"], s[f"foot.{side}"]
        assert abs(knee[2] - hip[2]) < 0.05 * height
        assert knee[0] - hip[0] > 0.15 * height
        assert abs(knee[0] - ankle[0]) < 0.06 * height
    c = posed_joints(crouching, cache=cache)
    for side in "LR":   # deep knee bend: hips at about knee height, low
        assert c[f"upperleg01.{side}"][2] < 0.3 * height
        assert c[f"lowerleg01.{side}"][2] > c[f"upperleg01.{side}"][2] - 0.05 * height


def test_hands_90_hands_at_shoulder_height_far_out(cache):
    params = person("hands_90", 1.75, seed=2)
    j = posed_joints(params, cache=cache)
    for side in "LR":
        assert abs(j[f"finger3-1.{side}"][2] - j[f"upperarm01.{side}"][2]) < 0.08
        assert horizontal_reach(j, f"finger3-1.{side}") > 0.65
    # the mesh agrees: its points farthest from the body axis are hands at shoulder height
    mesh = posed_body(params, cache=cache)
    reach = np.linalg.norm(mesh.vertices[:, :2], axis=1)
    far = mesh.vertices[reach > np.quantile(reach, 0.99)]
    assert abs(far[:, 2].mean() - j["upperarm01.L"][2]) < 0.1


def test_hands_45_between_hip_and_shoulder_away_from_body(cache):
    j = posed_joints(person("hands_45", 1.75, seed=1), cache=cache)
    for side in "LR":
        hand = j[f"finger3-1.{side}"]
        assert j[f"upperleg01.{side}"][2] + 0.05 < hand[2] < j[f"upperarm01.{side}"][2] - 0.2
        assert horizontal_reach(j, f"finger3-1.{side}") > 0.45


def test_standing_hands_hang_below_hips(cache):
    j = posed_joints(person("standing", 1.75, seed=2), cache=cache)
    for side in "LR":
        assert j[f"finger3-1.{side}"][2] < j[f"upperleg01.{side}"][2] - 0.05
        assert horizontal_reach(j, f"finger3-1.{side}") < 0.35


@pytest.mark.parametrize("facing", [0.0, 90.0, 215.0, -60.0])
def test_facing_turns_toes_and_sides(cache, facing):
    params = person("standing", 1.75, facing=facing)
    mesh, j = posed_body(params, cache=cache), posed_joints(params, cache=cache)
    front = np.array([math.cos(math.radians(facing)), math.sin(math.radians(facing))])
    # toes point forward: the soles' centroid lies in front of the ankles
    sole = mesh.vertices[mesh.vertices[:, 2] < 0.04][:, :2].mean(axis=0)
    toes = sole - 0.5 * (j["foot.L"][:2] + j["foot.R"][:2])
    angle = math.degrees(math.atan2(front[0] * toes[1] - front[1] * toes[0], front @ toes))
    assert abs(angle) < 15.0 and front @ toes > 0.03
    # the body's left hand is on the left of the facing direction
    left = j["wrist.L"][:2] - j["root"][:2]
    assert front[0] * left[1] - front[1] * left[0] > 0.15
    # and the turn is exactly a rotation of the unturned body
    base = posed_body(person("standing", 1.75, facing=0.0), cache=cache)
    c, s = front
    assert np.allclose(base.vertices @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T, mesh.vertices, atol=1e-12)


def test_named_postures_match_their_definition_unknown_is_far(cache):
    named = {p: posture_directions(p) for p in POSTURES[:5]}
    for seed in range(3):
        for posture in POSTURES[:5]:   # measured on the posed skeleton: only the jitter remains
            d = joint_directions(posed_joints(person(posture, 1.7, seed=seed), cache=cache))
            assert 0.5 < pose_distance_deg(d, named[posture]) < 10.0
        for height in (1.6, 1.85):
            d = joint_directions(posed_joints(person("unknown", height, seed=seed), cache=cache))
            assert min(pose_distance_deg(d, n) for n in named.values()) >= B.UNKNOWN_MIN_DISTANCE_DEG - 0.5


@pytest.mark.parametrize("target", [1000, 2000])
def test_decimated_skin_is_closed_and_on_target(cache, target):
    for posture in POSTURES:
        mesh = posed_body(person(posture, 1.75, seed=1), target_faces=target, cache=cache)
        assert abs(len(mesh.faces) - target) <= 0.1 * target
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        assert tm.is_watertight and tm.is_winding_consistent and tm.body_count == 1
        assert 0.04 < tm.volume < 0.12   # m^3, outward normals (a 1.75 m adult, 40-120 kg)


def test_same_params_same_mesh_even_from_a_new_cache(cache, tmp_path):
    params = person("unknown", 1.81, facing=33.0, seed=4)
    a, b = posed_body(params, cache=cache), posed_body(params, cache=cache)
    c = posed_body(params, cache=BodyCache(tmp_path, variants_per_posture=3))   # generated again
    for other in (b, c):
        assert np.array_equal(a.vertices, other.vertices) and np.array_equal(a.faces, other.faces)


def test_second_cache_loads_from_disk_in_milliseconds(cache):
    params = person("sitting", 1.66, facing=120.0, seed=5)
    posed_body(params, cache=cache)
    path = cache.path(cache.key(params), 2000)
    mtime = path.stat().st_mtime_ns
    fresh = BodyCache(cache.root, variants_per_posture=3)
    start = time.perf_counter()
    mesh = posed_body(params, cache=fresh)
    disk_s = time.perf_counter() - start
    assert fresh.stats == {"generated": 0, "disk_loads": 1, "memory_hits": 0}
    assert path.stat().st_mtime_ns == mtime
    assert not list(cache.root.rglob("*.tmp"))
    assert len(mesh.faces) > 0 and disk_s < 0.05
    start = time.perf_counter()
    for _ in range(100):
        posed_body(params, cache=fresh)
    assert (time.perf_counter() - start) / 100 < 0.005
    assert fresh.stats["memory_hits"] == 100


def test_failed_write_leaves_no_file(tmp_path, monkeypatch):
    small = BodyCache(tmp_path, variants_per_posture=3)
    params = person("standing", 1.7, seed=0)

    def fail(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError, match="disk full"):
        posed_body(params, cache=small)
    monkeypatch.undo()
    assert not small.path(small.key(params), 2000).exists()
    assert not list(tmp_path.rglob("*.tmp"))


def test_warm_fills_the_library_once(tmp_path):
    small = BodyCache(tmp_path, variants_per_posture=2)
    bucket = B.build_bucket(person("standing", 1.7))
    assert small.warm(("standing", "hands_45"), 2, buckets=[bucket]) == 4
    assert small.warm(("standing", "hands_45"), 2, buckets=[bucket]) == 0
    assert len(list(tmp_path.rglob("*.npz"))) == 4


@pytest.mark.parametrize("change, word", [
    (dict(posture="lying"), "posture"),
    (dict(height_m=1.40), "height_m"),
    (dict(height_m=float("nan")), "height_m"),
    (dict(weight=1.5), "weight"),
    (dict(albedo=np.array([0.2, 1.3, 0.2])), "albedo"),
    (dict(facing_deg=float("inf")), "facing_deg"),
])
def test_bad_parameters_raise_one_line_errors(cache, change, word):
    params = person("standing", 1.7)
    for k, v in change.items():
        setattr(params, k, v)
    with pytest.raises(NlosError, match=word) as info:
        posed_body(params, cache=cache)
    assert "\n" not in str(info.value)
    with pytest.raises(NlosError, match="target_faces"):
        posed_body(person("standing"), target_faces=10, cache=cache)


def test_sampled_people_cover_the_ranges():
    rng = np.random.default_rng(7)
    people = [sample_body_params(rng) for _ in range(600)]
    heights = np.array([p.height_m for p in people])
    assert heights.min() >= 1.52 and heights.max() <= 1.89
    assert heights.min() < 1.54 and heights.max() > 1.87 and abs(heights.mean() - 1.705) < 0.02
    counts = {p: sum(q.posture == p for q in people) for p in POSTURES}
    assert all(60 < c < 140 for c in counts.values()), counts       # 100 expected each
    albedo = np.stack([p.albedo for p in people])
    assert albedo.min() >= 0.05 and albedo.max() <= 0.8
    assert np.corrcoef(albedo.T)[0, 1] > 0.6 and np.corrcoef(albedo.T)[1, 2] > 0.6
    facing = np.array([p.facing_deg for p in people])
    assert facing.min() < 10 and facing.max() > 350
    assert len({B.build_bucket(p) for p in people}) > 80             # most of the 108 builds
    again = sample_body_params(np.random.default_rng(7))
    assert again.height_m == people[0].height_m and again.pose_seed == people[0].pose_seed
    assert {sample_body_params(rng, "crouching").posture for _ in range(5)} == {"crouching"}
    with pytest.raises(NlosError, match="posture"):
        sample_body_params(rng, "jumping")


def test_cache_folder_follows_nlos_cache(monkeypatch, tmp_path):
    monkeypatch.setenv("NLOS_CACHE", str(tmp_path))
    assert B.default_cache_dir() == tmp_path / "bodies"
    assert BodyCache().root == tmp_path / "bodies"
