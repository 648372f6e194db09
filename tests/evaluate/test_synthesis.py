"""Analysis by synthesis: the affine albedo split against direct renders, the albedo fit against a
brute-force search, and the search recovering a rendered person's posture and place."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from nlos_spotlight.evaluate.crb import PERSON
from nlos_spotlight.evaluate.synthesis import (Bank, Synthesizer, albedo_fit, albedo_fit_many, floor_cells,
                                               fused_log_posterior, mean_body, read_photograph, refine)
from nlos_spotlight.render.person import Person
from nlos_spotlight.render.transport import RenderSettings
from nlos_spotlight.scene.builders import mannequin
from nlos_spotlight.scene.examples import SPOT_TARGET
from nlos_spotlight.scene.format import Ambient
from nlos_spotlight.world.body import HEIGHT_RANGE_M

SETTINGS = RenderSettings(pixel_samples=1, transport_pixel_samples=1, spot_samples=8, person_samples=400,
                          dtype="float64", device="cpu")
SHAPE = {"standing": (1.0, 0.0), "hands_90": (1.0, 90.0), "sitting": (0.72, 0.0), "crouching": (0.6, 0.0)}
"""Stand-in postures of the capsule mannequin: (height factor, arms raised, degrees)."""


def pose(params, faces: int):
    """A mannequin in place of the body model (fast, no library): soles at the origin."""
    scale, arms = SHAPE[params.posture]
    return mannequin([0.0, 0.0, 0.0], params.height_m * scale, facing_deg=params.facing_deg, arms_deg=arms)


@pytest.fixture
def synth(small_corner):
    scene = small_corner
    scene.human = None
    scene.ambient = Ambient(np.full(3, 0.02), np.full(3, 0.05))  # Q: the light the body hides
    return Synthesizer(scene, SPOT_TARGET, SETTINGS, body_faces=0, quadrature="mc", pose=pose)


def photo(syn: Synthesizer, params, xy) -> torch.Tensor:
    """The person's light as the renderer makes it (nlos + nlos_ambient) at its own albedo."""
    body = syn.pose(params, 0)
    person = Person.from_mesh(body, params.albedo, SETTINGS.person_samples, "mc")
    out = syn.r.render(syn.r.spot_vector(0), person, translation=np.array([*xy, syn.floor_z]), components=PERSON)
    return out.image.double()


def noisy(clean: torch.Tensor, snr: float, gen: torch.Generator) -> tuple[torch.Tensor, torch.Tensor]:
    """(photograph, weights): ``clean`` plus white noise at a whole-image SNR of ``snr``, and the
    inverse noise variance."""
    sigma = float(clean.norm()) / snr / np.sqrt(clean.numel())
    d = clean + sigma * torch.randn(clean.shape, generator=gen, dtype=torch.float64)
    return d, torch.full_like(d, sigma ** -2)


def test_light_is_affine_in_the_albedo(synth):
    """a N + (1 - a) Q from one render at albedo 1/2 equals a render at albedo a."""
    albedo = np.array([0.15, 0.4, 0.8])
    params = dataclasses.replace(mean_body("hands_90", 40.0, 1.8), albedo=albedo)
    n, q = synth.light(params, (1.2, 1.8))
    want = photo(synth, params, (1.2, 1.8))
    assert float(want.abs().max()) > 0 and float(q.abs().max()) > 0
    got = torch.as_tensor(albedo) * n + (1 - torch.as_tensor(albedo)) * q
    assert float((got - want).norm() / want.norm()) < 1e-10


def test_one_body_at_many_places_is_each_place_rendered_alone(synth):
    """``lights`` (the bank's path: the body posed once, rendered at K places in one call) gives
    what ``light`` gives at each place."""
    params = mean_body("sitting", 90.0)
    xys = np.array([[1.2, 1.8], [1.5, 2.4], [0.9, 2.1]])
    n, q = synth.lights(params, xys)
    assert n.shape == q.shape == (3, *synth.r.render(synth.r.spot_vector(0), components=("direct",)).image.shape)
    for k, xy in enumerate(xys):
        n1, q1 = synth.light(params, xy)
        assert float(n1.abs().max()) > 0
        assert torch.equal(n[k], n1) and torch.equal(q[k], q1)
    assert not torch.equal(n[0], n[1])


def test_albedo_fit_matches_a_brute_force_search():
    g = torch.Generator().manual_seed(1)
    n, q, d = (torch.rand(4, 5, 3, generator=g, dtype=torch.float64) for _ in range(3))
    w = torch.rand(4, 5, 3, generator=g, dtype=torch.float64) + 0.1
    n[..., 2] = q[..., 2] + 0.5  # N > Q in blue, and d far above both: the optimum lies past 1,
    d[..., 2] += 5.0  # where the clip must hold it
    chi, a = albedo_fit(d, w, n, q)
    grid = torch.linspace(0, 1, 2001, dtype=torch.float64)
    brute = [((w[..., c, None] * (d[..., c, None] - grid * n[..., c, None] - (1 - grid) * q[..., c, None]) ** 2)
              .sum((0, 1))) for c in range(3)]
    assert chi == pytest.approx(sum(float(b.min()) for b in brute), rel=1e-6)
    assert a == pytest.approx([float(grid[b.argmin()]) for b in brute], abs=1e-3)
    assert a[2] == 1.0
    many = albedo_fit_many(d, w, torch.stack([n, q]), torch.stack([q, n]))
    assert float(many[0]) == pytest.approx(chi, rel=1e-12)
    assert float(many[1]) == pytest.approx(albedo_fit(d, w, q, n)[0], rel=1e-12)


def test_albedo_fit_recovers_a_noise_free_albedo(synth):
    albedo = np.array([0.3, 0.5, 0.7])
    params = dataclasses.replace(mean_body("standing", 10.0), albedo=albedo)
    d = photo(synth, params, (1.0, 1.6))
    chi, a = albedo_fit(d, torch.ones_like(d), *synth.light(params, (1.0, 1.6)))
    assert a == pytest.approx(albedo, abs=1e-9)
    assert chi < 1e-20 * float((d ** 2).sum()) + 1e-30


def test_refine_moves_to_the_person(synth):
    """From 2.5-3 cm and 8 degrees off, the fit lowers chi^2 at least tenfold and stays within 5 cm
    (not at the truth: the albedo fit trades brightness for range, and an 8 x 8 image has bumps)."""
    truth = dataclasses.replace(mean_body("standing", 30.0, 1.8), albedo=np.array([0.4, 0.4, 0.4]))
    xy = np.array([1.3, 1.9])
    d = photo(synth, truth, xy)
    w = torch.full_like(d, 1.0 / float(d.abs().max()) ** 2)
    for off, facing in (([0.02, -0.015], 38.0), ([-0.03, 0.0], 30.0)):
        start = albedo_fit(d, w, *synth.light(mean_body("standing", facing), xy + off))[0]
        theta, chi = refine(synth, d, w, "standing", xy + off, facing, evaluations=30)
        assert chi < 0.1 * start
        assert np.linalg.norm(theta[:2] - xy) < 0.05
        assert HEIGHT_RANGE_M[0] <= theta[3] <= HEIGHT_RANGE_M[1]


def test_read_photograph_names_the_posture_and_place(synth):
    """Noise at a person SNR of about 100: the search (a coarse bank on a 0.3 m grid and a coarse
    body, the facing scan, the refinement) names the posture and finds the place within the bank's
    reach (a cell's diagonal)."""
    fast = Synthesizer(synth.scene, SPOT_TARGET, dataclasses.replace(SETTINGS, person_samples=96), body_faces=0,
                       quadrature="mc", pose=pose)
    cells = floor_cells(synth.scene, 0.3, floor=False)
    assert len(cells) > 4
    bank = Bank(fast, cells, 4)
    gen = torch.Generator().manual_seed(0)
    for posture, xy in (("hands_90", np.array([1.4, 1.7])), ("sitting", np.array([1.0, 2.3]))):
        truth = dataclasses.replace(mean_body(posture, 200.0, 1.75), albedo=np.full(3, 0.5))
        d, w = noisy(photo(synth, truth, xy), 100, gen)
        reading = read_photograph(fast, synth, bank, d, w,
                                  ("standing", "hands_90", "sitting"), facings=4, evaluations=8)
        assert reading.posture == posture, reading.chi2
        assert np.linalg.norm(reading.xy - xy) < 0.3 * np.sqrt(2)


def test_read_photograph_from_a_given_start(synth):
    """Started 14 cm off (a network's answer) with no bank, the search names the posture and moves
    towards the person; with neither a bank nor a point it refuses."""
    fast = Synthesizer(synth.scene, SPOT_TARGET, dataclasses.replace(SETTINGS, person_samples=96), body_faces=0,
                       quadrature="mc", pose=pose)
    xy = np.array([1.2, 2.0])
    truth = dataclasses.replace(mean_body("sitting", 120.0, 1.7), albedo=np.full(3, 0.5))
    d, w = noisy(photo(synth, truth, xy), 100, torch.Generator().manual_seed(1))
    start = xy + np.array([0.1, -0.1])
    reading = read_photograph(fast, synth, None, d, w, ("standing", "sitting", "crouching"), facings=4,
                              evaluations=10, start=start)
    assert reading.posture == "sitting", reading.chi2
    assert np.linalg.norm(reading.xy - xy) < 0.5 * np.linalg.norm(start - xy)
    with pytest.raises(ValueError, match="bank"):
        read_photograph(fast, synth, None, d, w, ("standing",))


def test_read_photograph_scores_the_best_pose_variant(synth):
    """A body whose arms depend on its pose variant: the photograph of variant 1 is fitted to the
    noise (chi^2 about its pixel count) only when the search may try two variants."""
    def pose2(params, faces):
        scale, arms = SHAPE[params.posture]
        return mannequin([0.0, 0.0, 0.0], params.height_m * scale, facing_deg=params.facing_deg,
                         arms_deg=arms + 60.0 * params.pose_seed)

    syn = Synthesizer(synth.scene, SPOT_TARGET, SETTINGS, body_faces=0, quadrature="mc", pose=pose2)
    xy = np.array([1.2, 2.0])
    truth = dataclasses.replace(mean_body("standing", 0.0, 1.7), albedo=np.full(3, 0.5), pose_seed=1)
    d, w = noisy(photo(syn, truth, xy), 300, torch.Generator().manual_seed(2))
    one, two = (read_photograph(syn, syn, None, d, w, ("standing",), facings=1, evaluations=1, xy=xy, variants=v)
                for v in (1, 2))
    assert two.chi2["standing"] < 1.5 * d.numel() < 10 * d.numel() < one.chi2["standing"]


def test_fused_posterior_limits_and_value():
    """T -> infinity leaves the network's answer, T -> 0 the synthesis', and at T = 1 the log
    posterior is log p - (chi^2 - min chi^2) / 2 exactly."""
    prob = np.array([[0.7, 0.2, 0.1], [0.1, 0.1, 0.8]])
    chi2 = np.array([[130.0, 100.0, 160.0], [300.0, 320.0, 330.0]])
    assert (fused_log_posterior(chi2, prob, 1e9).argmax(1) == prob.argmax(1)).all()
    assert (fused_log_posterior(chi2, prob, 1e-3).argmax(1) == chi2.argmin(1)).all()
    want = np.log(prob) - (chi2 - chi2.min(1, keepdims=True)) / 2
    np.testing.assert_allclose(fused_log_posterior(chi2, prob, 1.0), want, rtol=1e-12)
    # between: the network's 0.7 / 0.2 is worth 30 units of chi^2 at T = 30 / (2 ln 3.5) = 11.97
    assert fused_log_posterior(chi2, prob, 12.5)[0].argmax() == 0
    assert fused_log_posterior(chi2, prob, 11.5)[0].argmax() == 1
