"""Cross-checks against Mitsuba 3, the independent reference renderer (DESIGN section 5)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import torch

mi_ref = pytest.importorskip("nlos_spotlight.render.mitsuba_ref")
pytest.importorskip("mitsuba")

from nlos_spotlight.render.brdf import brdf  # noqa: E402
from nlos_spotlight.render.person import Person  # noqa: E402
from nlos_spotlight.render.transport import Renderer, RenderSettings  # noqa: E402
from nlos_spotlight.scene.examples import CROSSCHECK, SPOT_TARGET, corner_scene  # noqa: E402

pytestmark = pytest.mark.mitsuba
RES = 32
SPP = 32768
PT_SPP = 4096
"""Samples a pixel of Mitsuba's particle tracer: the spot lights a small patch, so tracing from it
converges far faster on these difference images than the camera-side path tracer (``SPP``)."""
SETTINGS = RenderSettings(pixel_samples=4, transport_pixel_samples=4, spot_samples=256, person_samples=1024)


def block_means(img: np.ndarray, k: int = 4) -> np.ndarray:
    h, w = img.shape[:2]
    return img.sum(-1).reshape(h // k, k, w // k, k).mean((1, 3)).ravel()


def test_brdf_equals_mitsuba_bsdf_eval():
    mi = mi_ref.use_mitsuba()
    import drjit as dr

    rng = np.random.default_rng(0)
    for alpha in (0.1, 0.3, 0.7):
        bsdf = mi.load_dict({"type": "roughconductor", "material": "none", "distribution": "ggx", "alpha": alpha})
        th_i, th_o = rng.uniform(0, 1.4, 20), rng.uniform(0, 1.4, 20)
        ph = rng.uniform(0, 2 * math.pi, 20)
        wi = np.stack([np.sin(th_i), np.zeros(20), np.cos(th_i)], 1)
        wo = np.stack([np.sin(th_o) * np.cos(ph), np.sin(th_o) * np.sin(ph), np.cos(th_o)], 1)
        si = dr.zeros(mi.SurfaceInteraction3f, 20)
        si.n = mi.Normal3f(0, 0, 1)
        si.sh_frame = mi.Frame3f(si.n)
        si.wi = mi.Vector3f(wi.T)
        ref = np.array(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(wo.T)))[0] / np.cos(th_o)  # eval has cos_o
        t = lambda x: torch.as_tensor(x, dtype=torch.float64)
        ours = brdf(t([[0, 0, 1.0]]), t(wi), t(wo), t(np.zeros((1, 3))), t(np.ones((1, 3))),
                    t([alpha]))[:, 0].numpy()
        assert np.allclose(ours, ref, rtol=2e-4), (alpha, ours, ref)


def test_direct_matches_mitsuba_pixel_by_pixel():
    """Spot irradiance, glossy and textured BRDFs, projector shadows and image orientation."""
    sc = corner_scene("example", RES)
    cab = sc.shapes[3].mesh  # per-face colors on the cabinet, per-vertex colors on the wall
    cab.face_colors = np.random.default_rng(0).uniform(0.3, 1.0, (len(cab.faces), 3))
    r = Renderer(sc, SETTINGS, aim_points=SPOT_TARGET[None] + [[-0.6, 0.2, -0.3]])
    ours = r.render(r.spot_vector(0), components=("direct",))["direct"].numpy()
    ref = mi_ref.mitsuba_direct(sc, r.aim_points[0], spp=1024)
    assert ours.sum() == pytest.approx(ref.sum(), rel=1e-2)
    assert np.corrcoef(ours.ravel(), ref.ravel())[0, 1] > 0.999
    bright = ref.sum(-1) > 0.05 * ref.sum(-1).max()
    assert np.allclose(ours[bright], ref[bright], rtol=0.1)


@pytest.mark.parametrize("kind", CROSSCHECK)
def test_nlos_matches_mitsuba(kind):
    """``nlos`` against Mitsuba (max_depth 4) of the person minus a black person at the same seeds.

    That difference is exactly the light scattered by the body; the literal with-minus-without
    difference also carries the body's shadow on LOS-LOS-LOS paths (see benchmarks/crosscheck_mitsuba.py).
    Mitsuba's particle tracer: at 4,096 samples a pixel its totals move by 0.1-1.5% between seeds 11
    and 12 (docs/results/mitsuba-scatter-ptracer.txt; the camera-side path tracer needed 32,768
    samples for about 1%, at 5x the time).
    """
    sc = corner_scene(kind, RES)
    r = Renderer(sc, SETTINGS, aim_points=SPOT_TARGET[None])
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, SETTINGS.person_samples)
    ours = r.render(r.spot_vector(0), person, components=("nlos",))["nlos"].numpy()
    ref = mi_ref.mitsuba_nlos(sc, SPOT_TARGET, PT_SPP, seed=11, protocol="scatter", integrator="ptracer")
    rel = ours.sum() / ref.sum() - 1
    corr = np.corrcoef(block_means(ours), block_means(ref))[0, 1]
    print(f"{kind}: total ours {ours.sum():.5g} mitsuba {ref.sum():.5g} rel {rel:+.4f} corr {corr:.4f}")
    # here rel -1.6% to 0.0% over the five scenes, corr >= 0.998; at the benchmark's finer settings, seeds 11
    # and 12: -1.2% to +0.5% (docs/results/mitsuba-scatter-ptracer.txt)
    assert abs(rel) <= 0.03 and corr >= 0.99


@pytest.mark.parametrize("kind", ["diffuse_corner", "glossy_wall"])
def test_nlos_shadow_matches_mitsuba(kind):
    """``nlos_shadow`` against Mitsuba's particle tracing of a black person minus no person at the same seeds.

    Paths that never meet the body are the same in both renders and cancel, so the difference is
    the light the body stops with little noise: about 4% of ``nlos`` in these scenes. Mitsuba's
    particle tracer: at 8,192 samples a pixel its blocked light moves by 1-3% between seeds 5, 6 and
    7, the camera-side path tracer's by 20-40% (its paths must find the small spot from the hidden
    floor: rare, heavy weights), its block correlation with ours 0.99 against 0.80-0.89
    (docs/results/mitsuba-blocked-integrators.txt).
    """
    sc = corner_scene(kind, RES)
    # 2 x 2 camera sub-samples: the shadow is smooth (4 x 4 moves the totals by under 1%, at 4x the time)
    r = Renderer(sc, dataclasses.replace(SETTINGS, transport_pixel_samples=2), aim_points=SPOT_TARGET[None])
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, SETTINGS.person_samples)
    with torch.no_grad():
        out = r.render(r.spot_vector(0), person, components=("nlos", "nlos_shadow"))
    ours, nlos = out["nlos_shadow"].numpy(), out["nlos"].numpy()
    ref = mi_ref.mitsuba_nlos(sc, SPOT_TARGET, 2 * PT_SPP, seed=5, protocol="blocked", integrator="ptracer")
    rel = ours.sum() / ref.sum() - 1
    print(f"{kind}: shadow ours {ours.sum():.4g} mitsuba {ref.sum():.4g} rel {rel:+.3f}; "
          f"shadow / nlos {ours.sum() / nlos.sum():+.4f}")
    assert ref.sum() < 0 and ours.sum() < 0
    # rel -1.0% to -5.2% over the two scenes and three seeds (docs/results/mitsuba-blocked-integrators.txt)
    assert abs(rel) <= 0.10
    assert np.corrcoef(block_means(ours, 8), block_means(ref, 8))[0, 1] >= 0.95


def test_shadow_to_depth_ten_matches_mitsuba():
    """``nlos_shadow`` with the room's later relays (``shadow_depth`` 10, ``render/tail.py``) against
    the light Mitsuba's particle tracer finds the body stopping to ``max_depth`` 10 (a black person
    minus none, same seeds): the first relay alone falls short of it by about a tenth here (a third
    in the scanned copy room, experiments/bounce-tail)."""
    sc = corner_scene("diffuse_corner", 16)
    settings = RenderSettings(pixel_samples=2, transport_pixel_samples=2, spot_samples=128, person_samples=1024,
                              shadow_samples=4096, dtype="float64")
    person = Person.from_mesh(sc.human.mesh, sc.human.albedo, settings.person_samples)
    ours = {}
    for depth in (4, 10):
        r = Renderer(sc, dataclasses.replace(settings, shadow_depth=depth), aim_points=SPOT_TARGET[None])
        with torch.no_grad():
            ours[depth] = r.render(r.spot_vector(0), person, components=("nlos_shadow",))["nlos_shadow"].numpy()
    ref = mi_ref.mitsuba_nlos(sc, SPOT_TARGET, 16384, seed=3, max_depth=10, protocol="blocked", integrator="ptracer")
    gain = {d: float((o * ref).sum() / (o * o).sum()) for d, o in ours.items()}
    assert gain[10] == pytest.approx(1.0, abs=0.06)
    assert gain[4] > gain[10] + 0.05  # the first relay alone is short of it
