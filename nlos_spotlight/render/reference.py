"""Slow, obviously correct reference of the ``nlos`` and ``nlos_ambient`` terms.

It reuses the fast renderer's sample sets (camera sub-samples, landed spot
samples, body samples) so that both evaluate the same discrete sum, but
computes every term of DESIGN section 5 literally, one (body sample, spot
sample) pair at a time, with its own BRDF and its own shadow rays. Tests
compare the two in values and gradients.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from .person import Person, as_translation
from .rays import SceneRays


def _f(n, wi, wo, kd, ks, alpha):
    """BRDF written from the formulas: kd/pi + ks D G1 G1 / (4 |cos i| |cos o|), D, G1 in tan form."""
    ci, co = (n * wi).sum(-1), (n * wo).sum(-1)
    h = (wi + wo) / (wi + wo).norm(dim=-1, keepdim=True)
    ch = (n * h).sum(-1).abs()
    tan2_h = (1 - ch**2) / ch**2
    d = alpha**2 / (math.pi * ch**4 * (alpha**2 + tan2_h) ** 2)

    def g1(c):
        return 2 / (1 + torch.sqrt(1 + alpha**2 * (1 - c**2) / c**2))

    spec = d * g1(ci) * g1(co) / (4 * ci.abs() * co.abs())
    return (kd / math.pi + ks * spec.unsqueeze(-1)) * (ci * co > 0).unsqueeze(-1)


def reference_person_terms(renderer, y: torch.Tensor, person: Person, translation) -> dict[str, torch.Tensor]:
    """{'nlos', 'nlos_ambient'}: (H, W, 3) for one body translation, by explicit double sums."""
    dev, dt = renderer.device, renderer.dtype
    t = as_translation(translation, 1, dev, dt)[0]
    t_np = t.detach().cpu().numpy()
    rays = SceneRays(renderer.static.engine, person.translated_mesh(t_np))
    rec = renderer.recv_t
    xp, nx = rec.pts["pos"], rec.pts["normal"]
    to_cam = rec.to_cam
    o_all = torch.as_tensor(person.pos, device=dev, dtype=dt) + t
    hidden = renderer.scene.ambient.hidden_radiance if renderer.scene.ambient is not None else np.zeros(3)
    hidden = torch.as_tensor(hidden, device=dev, dtype=dt)
    sp = renderer.spot_pts
    nlos = torch.zeros(len(xp), 3, device=dev, dtype=dt)
    amb = torch.zeros_like(nlos)
    for j in range(len(person)):
        o = o_all[j]
        no = torch.as_tensor(person.normal[j], device=dev, dtype=dt)
        rho = torch.as_tensor(person.albedo[j], device=dev, dtype=dt)
        # radiance leaving o toward each camera sub-sample, by the side it leaves from
        side_p = ((xp - o) @ no) > 0
        rad = torch.zeros(len(xp), 3, device=dev, dtype=dt)
        for k in range(len(renderer.spot_owner)):
            w = y[renderer.spot_owner[k]]
            if w == 0 and not y.requires_grad:
                continue
            xs, ns = sp["pos"][k], sp["normal"][k]
            if rays.occluded(xs[None].detach().cpu().numpy(), o[None].detach().cpu().numpy(),
                             ns[None].cpu().numpy(), no[None].cpu().numpy())[0]:
                continue
            d = o - xs
            r2 = (d * d).sum()
            wo = d / r2.sqrt()
            f_s = _f(ns, renderer.spot_to_proj[k], wo, sp["kd"][k], sp["ks"][k], sp["alpha"][k])
            g = (ns @ wo).abs() * (no @ wo).abs() / r2
            e_o = f_s * renderer.spot_flux[k] * w * g  # irradiance at o from this spot sample
            same = side_p == bool((xs - o) @ no > 0)
            rad = rad + (rho / math.pi * e_o) * same.unsqueeze(-1)
        vis = ~rays.occluded(np.repeat(o[None].detach().cpu().numpy(), len(xp), 0), xp.cpu().numpy(),
                             np.repeat(no[None].cpu().numpy(), len(xp), 0), nx.cpu().numpy())
        vis = torch.as_tensor(vis, device=dev, dtype=dt)
        d = o - xp
        r2 = (d * d).sum(-1)
        wi = d / r2.sqrt().unsqueeze(-1)
        f_p = _f(nx, wi, to_cam, rec.pts["kd"], rec.pts["ks"], rec.pts["alpha"])
        g = (nx * wi).sum(-1).abs() * (wi @ no).abs() / r2 * vis * person.area[j]
        nlos = nlos + f_p * rad * g.unsqueeze(-1)
        amb = amb + f_p * ((rho - 1) * hidden) * g.unsqueeze(-1)
    return {"nlos": renderer._pixels(nlos, rec), "nlos_ambient": renderer._pixels(amb, rec)}
