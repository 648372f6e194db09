"""Shared fixtures: small scenes built in code, the toy training world, the micro dataset config,
one torch thread for tiny networks."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import torch

from nlos_spotlight.scene.builders import quad
from nlos_spotlight.scene.format import Ambient, Camera, Human, Material, Projector, Scene, Shape

SLOW = ("tests/fit/test_fit.py", "tests/train/test_train.py::test_two_process_torchrun_gloo",
        "tests/train/test_train.py::test_resume_equals_uninterrupted",
        "tests/train/test_train.py::test_same_seed_same_checkpoint_bytes",
        "tests/train/test_train.py::test_training_moves_the_spot_to_the_informative_face",
        "tests/data/test_image_samples.py::test_resume_after_kill_during_images",
        "tests/data/test_generate.py::test_resume_after_kill", "tests/test_cli_render.py::test_render_hand_written_scene",
        "tests/evaluate/test_evaluate.py",  # end-to-end evaluation runs
        "tests/data/test_image_samples.py::test_demo_seen_room_trains_on_the_pool_and_scores_the_test_people",
        "tests/evaluate/test_synthesis.py::test_read_photograph_names_the_posture_and_place",
        "tests/models/test_inference.py::test_int8_stays_close", "tests/render/test_fused.py::test_fused_transport_equals_eager",
        "tests/train/test_floor_net_training.py",  # a dataset generated and FloorNet trained
        "tests/render/test_bounce.py::test_bounce_loops_equal_the_torch_leg_and_scale_with_albedo")
"""Tests left out of ``make test-fast`` besides the Mitsuba cross-checks: end-to-end fits, processes
killed and resumed, torchrun, training runs of tens of steps, end-to-end evaluation, int8
calibration, compiled kernels, a subprocess render: each over 5 s (``make test`` runs everything;
``make test-fast``: 2.3 min on 2 free cores)."""


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.get_closest_marker("mitsuba") or any(item.nodeid.startswith(s) for s in SLOW):
            item.add_marker(pytest.mark.slow)


TOY_BEST = 5
"""The toy world's best candidate spot."""
MICRO = dict(name="micro", seed=3, train_scenes=2, val_scenes=0, test_scenes=1, samples_per_scene=3,
             trajectories_per_test_scene=1, trajectory_frames=3, resolution=12, los_vertices=40,
             transport_rank=8, body_faces=600,
             render=dict(pixel_samples=1, transport_pixel_samples=1, spot_samples=4, person_samples=48,
                         person_quadrature="mc"))
"""The micro dataset (seconds to generate) of the generation and policy tests."""


def _plate_scene(res: int = 3, fov: float = 2.0, plate_albedo=0.0, hidden=1.0, kd=0.8) -> Scene:
    """A diffuse wall (y = 0, facing +y), a camera looking at (0, 0, 1) from the side, and a
    1 m x 1 m 'person' plate parallel to the wall at distance 1, centered in front of (0, 0, 1)."""
    wall = quad([-3, 0, -1], [6, 0, 0], [0, 0, 4], 6, 4)
    plate = quad([-0.5, 1.0, 0.5], [1, 0, 0], [0, 0, 1], 8, 8)
    cam = Camera(np.array([2.5, 1.2, 1.0]), np.array([0.0, 0.0, 1.0]), np.array([0, 0, 1.0]), fov, res, res)
    proj = Projector(np.array([1.0, 3.0, 1.0]), np.full(3, 10.0), 20.0, 30.0)
    sc = Scene([Shape("wall.ply", "paint", wall)], {"paint": Material(np.full(3, kd))}, cam, proj,
               ambient=Ambient(np.zeros(3), np.full(3, hidden)))
    sc.human = Human("plate.ply", np.full(3, plate_albedo), plate)
    return sc


@pytest.fixture
def small_corner():
    from nlos_spotlight.scene.examples import corner_scene

    return corner_scene("furniture", resolution=8)


@pytest.fixture(autouse=True)
def _seed():
    torch.manual_seed(0)
    np.random.seed(0)


def _expected_layout(page) -> dict:
    """What a report page holds, read from its source with the standard library's HTML parser (the
    independent count the browser must agree with): rows per table, figures, PNG sizes, headings."""
    import base64
    import html.parser
    import struct

    class Count(html.parser.HTMLParser):
        def __init__(self):
            super().__init__()
            self.r = {"tables": [], "figures": 0, "images": [], "headings": []}
            self.heading = None

        def handle_starttag(self, tag, attrs):
            if tag == "table":
                self.r["tables"].append(0)
            elif tag == "tr":
                self.r["tables"][-1] += 1
            elif tag == "figure":
                self.r["figures"] += 1
            elif tag == "img":
                png = base64.b64decode(dict(attrs)["src"].split(",", 1)[1])
                self.r["images"].append([True, *struct.unpack(">II", png[16:24])])  # the IHDR width, height
            elif tag in ("h1", "h2"):
                self.heading = ""

        def handle_data(self, data):
            if self.heading is not None:
                self.heading += data

        def handle_endtag(self, tag):
            if tag in ("h1", "h2"):
                self.r["headings"].append(self.heading)
                self.heading = None

    c = Count()
    c.feed(page.read_text())
    return c.r


@pytest.fixture
def check_in_browser():
    """``check(report.html)``: load the page in headless Chromium and assert that it laid out every
    table (with all its rows), every figure and heading, and decoded every image at its PNG size.
    Skipped where no Chromium is installed (``apt-get install chromium``)."""
    from nlos_spotlight.evaluate.browser import find_browser, inspect

    if find_browser() is None:
        pytest.skip("no Chromium on this machine (apt-get install chromium)")

    def check(page):
        want, got = _expected_layout(page), inspect(page)
        assert want["tables"] and want["images"]
        assert got == want
        return got

    return check


def _toy_scene(n: int = 64, seed: int = 0, res: int = 8, best: int = TOY_BEST):
    """8 candidate faces; only under spot ``best`` does the image carry the person's position and posture."""
    from nlos_spotlight.scene.graph import mesh_to_graph, normalize_positions
    from nlos_spotlight.data.tensors import SceneTensors

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


@pytest.fixture(scope="session")
def toy_scene():
    """``toy_scene(n, seed, res, best) -> SceneTensors``: 8 candidate faces; only under spot ``best``
    (``TOY_BEST``) does the image carry the person's position and posture (the training tests' world)."""
    return _toy_scene


@pytest.fixture(scope="session")
def micro_config():
    """The micro dataset's ``DatasetConfig`` fields (read-only)."""
    import types

    return types.MappingProxyType(MICRO)


@pytest.fixture(scope="session")
def micro_scene(micro_config, tmp_path_factory):
    """The test scene of the micro dataset (generated once a session): its directory and its tensors."""
    from nlos_spotlight.data.config import DatasetConfig
    from nlos_spotlight.data.generate import generate
    from nlos_spotlight.data.tensors import load_scene_tensors

    out = tmp_path_factory.mktemp("micro")
    generate(DatasetConfig(**micro_config), out, progress=False)
    scene_dir = next((out / "scenes").glob("test-*"))
    return scene_dir, load_scene_tensors(scene_dir, [])


def _box_mesh(lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """A closed axis-aligned box as 12 triangles: (8, 3) vertices, (12, 3) faces."""
    v = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])], float)
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return v, f


def _unit_box_crossings(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(clear, crosses) of segments a -> b (N, 3) against the box [-1, 1]^3 by the slab test:
    ``clear`` the segments between points outside the box that do not graze an edge, ``crosses``
    whether each meets the box (the closed form a ray engine must agree with on the clear ones)."""
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (-1 - a) / d, (1 - a) / d
    near = np.nanmax(np.minimum(t0, t1), 1).clip(min=0)
    far = np.nanmin(np.maximum(t0, t1), 1).clip(max=1)
    outside = (np.abs(a) > 1).any(1) & (np.abs(b) > 1).any(1)
    return outside & (np.abs(far - near) > 1e-3), near < far


@pytest.fixture(scope="session")
def box():
    """``box.mesh(lo, hi)``: a closed box's (vertices, faces); ``box.crossings(a, b)``: the slab test's
    (clear, crosses) of segments against the box [-1, 1]^3 (the ray engines' closed form)."""
    import types

    return types.SimpleNamespace(mesh=_box_mesh, crossings=_unit_box_crossings)


@pytest.fixture(scope="module")
def one_thread():
    """Tiny images and graphs: on a shared 2-core machine, OpenMP threads that wait for each other
    cost far more than they parallelize (measured 1.1 s vs 0.04 s per forward under load)."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def _glossy_corner_pair(person_samples: int, dtype: str, **variant):
    """A 12x12 glossy furniture corner with ambient light and three candidate spots: its renderer
    with the torch pair kernels, one with the settings overrides ``variant``, and a body of about
    ``person_samples`` samples. The paint is glossy so that the GGX branches of the kernels run too."""
    import dataclasses

    from nlos_spotlight.render.person import Person
    from nlos_spotlight.render.transport import Renderer, RenderSettings
    from nlos_spotlight.scene.examples import SPOT_TARGET, corner_scene

    settings = RenderSettings(pixel_samples=2, transport_pixel_samples=2, spot_samples=16,
                              person_samples=person_samples, dtype=dtype, device="cpu", pair_loops=False,
                              rays="embree")  # the reference engine: the loops and kernels cast the same rays
    sc = corner_scene("furniture", resolution=12)
    sc.materials["paint"].specular[:] = 0.3
    sc.ambient = Ambient(np.zeros(3), np.full(3, 0.05))
    aims = np.stack([SPOT_TARGET, SPOT_TARGET + [0.25, 0, 0.1], SPOT_TARGET + [-0.3, 0, -0.2]])
    base = Renderer(sc, settings, aim_points=aims)
    other = Renderer(sc, dataclasses.replace(settings, **variant), aim_points=aims)
    return base, other, Person.from_mesh(sc.human.mesh, sc.human.albedo, person_samples, "faces")


@pytest.fixture(scope="session")
def plate_scene():
    """The factory :func:`_plate_scene` (a wall, a side camera and a plate 'person')."""
    return _plate_scene


@pytest.fixture(scope="session")
def glossy_corner_pair():
    """The factory :func:`_glossy_corner_pair` (a glossy corner's renderers and a body)."""
    return _glossy_corner_pair


SCANS_DIR = Path(__file__).resolve().parents[2] / "shared" / "data" / "real-scans"
SCANS = ("copyroom.ply", "icl_livingroom2.obj", "icl_office2.obj")
"""The real scans of ``../shared/data/real-scans`` the tests read."""


def _real_scan(name: str) -> Path:
    path = SCANS_DIR / name
    if not path.is_file():
        msg = f"real scan {path} is missing (expected ../shared/data/real-scans beside the repo)"
        if os.environ.get("CI") == "true":  # CI has ../shared: a missing scan is a failure there
            pytest.fail(msg)
        pytest.skip(msg)
    return path


@pytest.fixture(scope="session")
def real_scan():
    """name -> path of a real scan of :data:`SCANS_DIR` (skips the test where it is missing, fails in CI)."""
    return _real_scan
