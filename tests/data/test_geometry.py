"""The geometry channels of a stored room, and the geometry-aware network that reads them."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.data.geometry import GEOMETRY_CHANNELS, geometry_input, room_geometry
from nlos_spotlight.errors import NlosError
from nlos_spotlight.models.nlos_net import NLOSNetConfig
from nlos_spotlight.models.registry import build_network
from nlos_spotlight.render.camera import project
from nlos_spotlight.render.sensor import SensorConfig
from nlos_spotlight.scene import load_scene
from nlos_spotlight.train.imaging import capture


def test_room_geometry_maps_back_onto_its_own_pixels(micro_scene):
    """Region-frame positions turned back into the world (hidden region's center, the stored
    camera's floor direction, the hidden floor's height) project onto their pixel centers; normals
    are unit and face the camera; albedo matches the scene's materials' range."""
    scene_dir, s = micro_scene
    g = room_geometry(s).double().numpy()
    sc = load_scene(scene_dir)
    pose = np.load(scene_dir / "static.npz")["camera_to_world"]
    fwd = -pose[:2, 2] / np.linalg.norm(pose[:2, 2])
    left = np.array([-fwd[1], fwd[0]])
    origin = (sc.hidden_region.min + sc.hidden_region.max) / 2
    hit = np.abs(g[3:6]).sum(0) > 0
    assert hit.mean() > 0.9
    along, side, height = g[0][hit], g[1][hit], g[2][hit]
    world = np.column_stack([origin + along[:, None] * fwd + side[:, None] * left,
                             height + sc.hidden_region.floor_z])
    rows, cols = np.nonzero(hit)
    np.testing.assert_allclose(project(sc.camera, world), np.stack([rows, cols], 1) + 0.5, atol=1e-3)
    nrm = g[3:6][:, hit]
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=0), 1.0, atol=1e-5)
    n_world = np.column_stack([nrm[0, :, None] * fwd + nrm[1, :, None] * left, nrm[2]])
    assert ((sc.camera.position - world) * n_world).sum(1).min() > 0  # every normal faces the camera
    assert 0 <= g[6:9].min() and g[6:9].max() <= 1


def test_geometry_input_lights_where_the_spot_lands(micro_scene):
    """The lit channel is the spot's person-free image over its brightest pixel: 1 at that pixel,
    0 with the projector off; the network reads 10 channels more than the photograph."""
    _, s = micro_scene
    t = int(torch.nonzero(s.landed)[0])
    y = torch.zeros(len(s.faces))
    y[t] = 1.0
    cfg = NLOSNetConfig(geometry=True, background_subtract=True, backbone="resnet10-narrow", stem="half")
    idx = torch.arange(2)
    ph = capture(s, idx, y, "spot", SensorConfig.at(s.ambient.shape[:2]), torch.Generator().manual_seed(0), True, cfg)
    assert ph.geometry.shape == (2, GEOMETRY_CHANNELS, *s.ambient.shape[:2])
    lit = ph.geometry[0, 9]
    lum = s.direct[t].mean(-1)
    assert float(lit.max()) == pytest.approx(1.0) and int(lit.argmax()) == int(lum.argmax())
    torch.testing.assert_close(lit, lum / lum.max())
    off = geometry_input(s, s.ambient * 0, 1, projector_on=False)
    assert float(off[0, 9].abs().max()) == 0.0
    net = build_network("resnet18", cfg).eval()
    with torch.no_grad():
        pos, logits = net(ph.images, ph.background, ph.clipped, ph.geometry)
        pos2, _ = net(ph.images, ph.background, ph.clipped, ph.geometry + 1.0)
    assert pos.shape == (2, 2) and logits.shape == (2, 6)
    assert not torch.allclose(pos, pos2)  # the geometry channels reach the output
    with pytest.raises(ValueError, match="geometry"):
        net(ph.images, ph.background, ph.clipped)
    with pytest.raises(NlosError, match="only resnet18"):
        build_network("chandran", cfg)


def test_spot_augment_draws_stored_landed_spots_uniformly(micro_scene, tmp_path):
    """Training under ``spot_augment``: every step lights the room by a stored, landed candidate,
    each about equally often (chi-square); validation and tests keep the policy's spot."""
    import dataclasses

    from scipy.stats import chisquare

    from nlos_spotlight.lighting import POLICIES, policy_rng
    from nlos_spotlight.train.config import TrainConfig
    from nlos_spotlight.train.loop import Trainer

    _, s = micro_scene
    stored = torch.zeros_like(s.landed)
    stored[torch.nonzero(s.landed).flatten()[::3]] = True
    landed = s.landed.clone()
    landed[int(torch.nonzero(stored)[0])] = False  # stored but not landed: never drawn
    s = dataclasses.replace(s, stored=stored, landed=landed)
    cfg = TrainConfig(policy="center", spot_augment=True, batch_size=2, steps=1,
                      net=NLOSNetConfig(geometry=True, backbone="resnet10-narrow", stem="half"))
    tr = Trainer(cfg, [s], tmp_path)
    s = tr.scenes[0]
    draws = [int(tr.illuminations([s], train=True)[0][0].argmax()) for _ in range(600)]
    ok = torch.nonzero(s.landed & stored).flatten().tolist()
    assert set(draws) <= set(ok) and len(set(draws)) == len(ok) > 1
    assert chisquare([draws.count(t) for t in ok]).pvalue > 1e-3
    (y, mode, _), = tr.illuminations([s], train=False)
    assert int(y.argmax()) == POLICIES["center"](s, s.scene_dir, policy_rng(0, 0)).face
    tr.train_step()  # the geometry-aware network trains under the drawn spots
    assert tr.step == 1


def test_auxiliary_nuisance_loss_is_the_facing_and_height_mse(micro_scene, tmp_path):
    """The loss with ``aux_weight`` w is the loss without it plus w x MSE(aux head, (cos, sin facing,
    height)); the nuisances are the stored labels turned into the region frame."""
    import dataclasses

    import numpy as np

    from nlos_spotlight.train.config import TrainConfig
    from nlos_spotlight.train.loop import Trainer

    scene_dir, s = micro_scene
    static = torch.nonzero(s.trajectory[:, 0] < 0).flatten()
    z = np.load(sorted((scene_dir / "samples").glob("*.npz"))[0])
    fwd = s.forward_xy.numpy()
    a = np.radians(float(z["facing_deg"])) - np.arctan2(fwd[1], fwd[0])
    torch.testing.assert_close(s.nuisance[0], torch.tensor([np.cos(a), np.sin(a), float(z["height_m"])],
                                                           dtype=torch.float32))
    net = NLOSNetConfig(aux_head=True, backbone="resnet10-narrow", stem="half")
    cfg = TrainConfig(policy="center", sensor_noise=False, batch_size=len(static), net=net)
    tr = Trainer(cfg, [s], tmp_path)
    s = tr.scenes[0]
    base = tr.loss_on(s, static)["loss"]
    tr.cfg = dataclasses.replace(cfg, aux_weight=2.0)
    with_aux = tr.loss_on(s, static)["loss"]
    (y, mode, _), = tr.illuminations([s], train=True)
    ph = capture(s, static, y, mode, tr.sensor, None, False, net)
    _, _, aux = tr.net(ph.images, ph.background, ph.clipped, ph.geometry, with_aux=True)
    torch.testing.assert_close(with_aux - base, 2.0 * torch.nn.functional.mse_loss(aux, s.nuisance[static]))


def test_finished_scene_dirs_of_a_dataset_finished_or_still_being_generated(micro_scene, tmp_path):
    """Finished: the manifest's rooms of the split; unfinished (no manifest): the rooms with
    done.json, in index order; a room still being written is left out."""
    import shutil

    from nlos_spotlight.data.tensors import finished_scene_dirs, split_ids

    data = micro_scene[0].parent.parent
    assert [d.name for d in finished_scene_dirs(data, "train")] == split_ids(data, "train")
    assert finished_scene_dirs(data, "val") == []
    copy = tmp_path / "d"
    shutil.copytree(data, copy)
    (copy / "manifest.json").unlink()
    first = sorted((copy / "scenes").glob("train-*"))[0]
    (first / "done.json").unlink()
    assert [d.name for d in finished_scene_dirs(copy, "train")] == split_ids(data, "train")[1:]
