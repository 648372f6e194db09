"""Train a room model: the seen-rooms recipe (``train.recipe``) on the fit's one room."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import torch

from ..train.recipe import RoomSplit, SeenResult, run_seen, seen_config, split_room
from ..train.config import TrainConfig
from .config import FitConfig


def capture_overrides(out: Path | None, cfg: FitConfig) -> dict:
    """The sensor settings of the fit's photographs: the room scene's ``sensor`` block (a scene
    directory may carry one), then the fit's burst."""
    sensor = {}
    if out is not None and (Path(out) / "room" / "scene.json").exists():
        import json

        sensor = json.loads((Path(out) / "room" / "scene.json").read_text()).get("sensor") or {}
    return {**sensor, "burst_frames": cfg.burst_frames}


def fit_train_config(cfg: FitConfig, out: Path | None = None) -> TrainConfig:
    """``seen_config`` for one room with the fit's capture (``capture_overrides``), its capture
    variation (projected out of the photographs unless 'ideal') and spot policy."""
    from ..evaluate.methods import fit_method

    tc = seen_config(1, seed=cfg.seed, noise=True, policy=cfg.policy, arch=fit_method(cfg.method).arch)
    drift = cfg.capture_preset != "ideal" and cfg.project_nuisance
    redress = cfg.clothing != "dataset"  # redressed in real clothing's range; 'dataset': as rendered, no augmentation
    return dataclasses.replace(tc, name="room-model", sensor=capture_overrides(out, cfg), variation=cfg.capture_preset,
                               net=dataclasses.replace(tc.net, project_nuisance=drift), albedo_augment=redress,
                               clothing=cfg.clothing)


def room_layers(out: Path, aim):
    """The room's static layers under the spot aimed at ``aim`` (``render.layers``), rendered once
    and kept as ``ROOM_MODEL/layers.npz``."""
    from ..render.layers import static_layers
    from ..render.variation import load_layers, save_layers
    from ..scene.io import load_scene

    path = Path(out) / "layers.npz"
    if path.exists():
        return load_layers(path)
    import numpy as np

    layers = static_layers(load_scene(Path(out) / "room"), np.asarray(aim, np.float64))
    save_layers(path, layers)
    return layers


def with_layers(room: RoomSplit, layers) -> RoomSplit:
    """``room`` with the static layers on its pool, validation and test people."""
    put = lambda s: dataclasses.replace(s, layers=layers)
    return RoomSplit(put(room.pool), put(room.val), put(room.test))


def room_split(out: Path, cfg: FitConfig, features: list[str], shadow_spot: int | None = None) -> RoomSplit:
    """The room's image samples split into training pool, validation and test (``split_room``):
    ``heldout`` test and as many validation people, spread over the generation order;
    ``shadow_spot``: with the people's shadow term under that spot (``fit/shadow.py``)."""
    from ..data.tensors import load_split

    s, = load_split(Path(out) / "data", "train", features, samples="images")
    if shadow_spot is not None:
        s = with_shadow(s, out, cfg, shadow_spot)
    return split_room(s, period=split_period(s.num_samples, cfg.heldout), max_eval=cfg.heldout)


def with_shadow(s, out: Path, cfg: FitConfig, spot: int):
    """The room's image samples ``s`` with their stored shadow term under ``spot``; under a world
    variation their whole light under ``spot`` is the one rendered in their drawn worlds
    (``fit/shadow.py``): one column of ``u`` / ``v`` holds it, the other spots none."""

    from ..errors import NlosError
    from .shadow import load_block_light

    got = {k: torch.as_tensor(v, dtype=s.v.dtype) for k, v in load_block_light(out, cfg).items()}
    shadow = got["nlos_shadow"]
    if shadow.shape[0] != s.num_samples or shadow.shape[1:] != s.nlos_ambient.shape[1:]:
        raise NlosError(f"{out}/shadow: {shadow.shape[0]} people's shadow for {s.num_samples} people; "
                        "rerun nlos fit with --resume")
    bounce = got.get("nlos_bounce")
    if bounce is not None and cfg.bounce_scale != 1:  # the fifth bounce standing in for every later one
        bounce = bounce * cfg.bounce_scale
    if "nlos" not in got:
        return dataclasses.replace(s, shadow=shadow, shadow_spot=int(spot), bounce=bounce)
    u = torch.zeros(s.num_samples, s.u.shape[1], 1, dtype=s.u.dtype)
    u[:, spot, 0] = 1
    return dataclasses.replace(s, u=u, v=got["nlos"][:, None], nlos_ambient=got["nlos_ambient"].to(s.nlos_ambient.dtype),
                               shadow=shadow, shadow_spot=int(spot), bounce=bounce)


def heldout_positions(s, cfg: FitConfig):
    """(heldout,) int64 positions among the image samples ``s`` of the held-out test people: the one
    rule (``room_split``'s test people, in order)."""

    from ..train.recipe import split_masks

    return torch.nonzero(split_masks(s, split_period(s.num_samples, cfg.heldout), cfg.heldout)[2]).flatten()


def heldout_indices(out: Path, cfg: FitConfig) -> list[int]:
    """Dataset sample indices of a room model's held-out test people (image samples follow the
    ``transport_people`` full-transport ones)."""
    from ..data.tensors import load_split

    s, = load_split(Path(out) / "data", "train", ["normals"], samples="images")
    return (heldout_positions(s, cfg) + cfg.transport_people).tolist()


def split_period(samples: int, heldout: int) -> int:
    """Every how many image samples one is a test (and one a validation) person (``split_masks``)."""
    return 10 if samples >= 10 * heldout else max(3, samples // heldout)


def train_room(cfg: FitConfig, out: Path, progress: bool, split: RoomSplit | None = None,
               layers=None) -> SeenResult:
    """Step 4 of ``nlos fit``: train (resumable, ``ROOM_MODEL/train/``), keep ``final.pt``, score.
    ``split``: the room already loaded with the default IEN features (else it is read here);
    ``layers``: the room's static layers (the capture variation moves them)."""
    ien_state, features = None, ["normals"]
    if cfg.policy == "ien":
        from ..train.checkpoint import load_trained

        models = load_trained(cfg.checkpoint)
        ien_state, features, ien_cfg = models.ien.state_dict(), list(models.config.ien_features), models.config.ien
    shadow = split.pool.shadow_spot if split is not None and split.pool.shadow is not None else None
    room = split if split is not None and cfg.policy != "ien" else room_split(out, cfg, features, shadow)
    if layers is not None:
        room = with_layers(room, layers)
    tc, spots = fit_train_config(cfg, out), None
    if cfg.policy == "ien":
        from ..data.config import read_dataset_config

        tc = dataclasses.replace(tc, ien_features=features, ien=ien_cfg)
        spots = read_dataset_config(Path(out) / "data").extra_spots[:1]
    result = run_seen(tc, [room], cfg.people, Path(out) / "train", cfg.epochs, progress=progress,
                      min_steps=cfg.min_steps, keep_model=Path(out) / "final.pt", ien_state=ien_state, spots=spots)
    if layers is not None and result.spots[0] is not None and result.spots[0] >= 0:
        train = room.pool.subset(torch.arange(min(cfg.people, room.pool.num_samples)))
        keep_person_light(Path(out) / "final.pt", train, int(result.spots[0]), layers)
    return result


def keep_person_light(model: Path, people, spot: int, layers) -> bool:
    """Give the room model ``model``'s drift fit the light directions of its training ``people``
    under ``spot`` (``models.nuisance.person_light_basis``), unless it has them or projects no
    nuisance; True when written. A room model fitted before them gains them on ``nlos fit --resume``."""
    import os

    from ..lighting.base import Illumination
    from ..models.nuisance import person_light_basis
    from ..train.checkpoint import read_checkpoint
    from ..train.imaging import form_parts

    st = read_checkpoint(model)
    key = next((k for k in st.get("net", {}) if k.endswith("nuisance.fraction")), None)
    if key is None or st["net"][key].numel() == 0:
        return False
    person = key[:-len("fraction")] + "person"
    if st["net"].get(person, torch.zeros(0)).numel() > 0:
        return False
    y = Illumination("spot", spot).spot_vector(people.u.shape[1])
    lit, ambient, _ = form_parts(people, torch.arange(people.num_samples), y)
    p, a = layers.nominal()
    st["net"][person] = person_light_basis(lit + ambient, p + a)
    tmp = model.with_name(f".{model.name}.tmp")
    torch.save(st, tmp)
    os.replace(tmp, model)
    return True
