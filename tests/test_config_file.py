"""Dataset and training configs read through one loader (``config_file``): the same checks, the
same one-line errors, nested training fields merged."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from nlos_spotlight.data.config import PRESETS as DATA_PRESETS
from nlos_spotlight.data.config import load_config
from nlos_spotlight.errors import NlosError
from nlos_spotlight.fit.config import PRESETS as PRESETS_FIT
from nlos_spotlight.train.config import PRESETS as TRAIN_PRESETS
from nlos_spotlight.train.config import load_train_config

BAD = {"a list": ("- a\n- b\n", "expected a mapping"),
       "a bad base": ("base: nope\n", "base 'nope' is not a preset"),
       "broken YAML": ("a: [1,\n", "invalid YAML"),
       "an unknown key": ("colour: 3\n", "unknown key 'colour'"),
       "an alias bomb": ("a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
           f"{chr(98 + i)}: &{chr(98 + i)} [*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, "
           f"*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}]\n" for i in range(8))
           + "families: *i\n", "aliases")}


@pytest.mark.parametrize("loader", [load_config, load_train_config])
@pytest.mark.parametrize("case", list(BAD))
def test_both_loaders_refuse_the_same_files(tmp_path, loader, case):
    text, match = BAD[case]
    f = tmp_path / "c.yaml"
    f.write_text(text)
    with pytest.raises(NlosError, match=match) as e:
        loader(str(f))
    assert "\n" not in str(e.value) and str(f) in str(e.value)


def test_fields_on_a_base_preset(tmp_path):
    f = tmp_path / "mine.yaml"
    f.write_text("base: demo\nsteps: 50\nlr: 1\nnet:\n  backbone: resnet10-narrow\nsensor:\n  burst_frames: 4\n")
    c = load_train_config(str(f))
    demo = TRAIN_PRESETS["demo"]
    assert (c.name, c.steps, c.lr, c.net.backbone, c.sensor) == ("mine", 50, 1.0, "resnet10-narrow", {"burst_frames": 4})
    assert c.net.background_subtract == demo.net.background_subtract and c.batch_size == demo.batch_size
    for text, match in (("steps: ten\n", "steps must be int"), ("net:\n  nope: 1\n", "unknown key 'net.nope'"),
                        ("net: 3\n", "net must be a mapping"), ("sensor_noise: 1\n", "sensor_noise must be bool"),
                        ("backbone: resnet10-narrow\n", "unknown key 'backbone'")):  # net's fields go under net
        f.write_text(text)
        with pytest.raises(NlosError, match=match):
            load_train_config(str(f))
    f.write_text("base: demo\nsamples_per_scene: 40\nfamilies: [doorway]\n")
    d = load_config(str(f))
    assert (d.samples_per_scene, d.families, d.resolution) == (40, ["doorway"], DATA_PRESETS["demo"].resolution)
    f.write_text("samples_per_scene: 0\n")  # the dataset's own validation still runs
    with pytest.raises(NlosError, match="samples_per_scene must be at least 1"):
        load_config(str(f))


def test_fit_config_file_is_the_flags(tmp_path, monkeypatch, capsys):
    """``nlos fit --config ROOM.yaml``: the room (relative to the file), its setup and its fit
    settings reach the fit exactly as the same flags do; a flag given beside the file wins; a bad
    file is one line."""
    import nlos_spotlight.fit.run as run
    from nlos_spotlight.cli import main

    seen = []
    monkeypatch.setattr(run, "fit_room", lambda room, out, cfg, flags, **kw: seen.append((room, cfg, flags)))
    scan = tmp_path / "scans" / "room.ply"
    scan.parent.mkdir()
    scan.write_text("ply")
    (tmp_path / "cfg").mkdir()
    (tmp_path / "cfg" / "room.yaml").write_text(
        "room: ../scans/room.ply\ncamera_position: [0.35, -0.3, 0.09]\ncamera_look_at: [0.9, -2, -0.3]\n"
        "hidden_region: [-1, 0, 1, 2]\nup: z\nfit: {people: 30, epochs: 2.5}\n")
    assert main(["fit", "--config", str(tmp_path / "cfg" / "room.yaml"), "--out", str(tmp_path / "a"),
                 "--preset", "tiny", "--quiet"]) == 0
    assert main(["fit", str(scan), "--out", str(tmp_path / "b"), "--preset", "tiny", "--quiet", "--people", "30",
                 "--camera-position", "0.35,-0.3,0.09", "--camera-look-at", "0.9,-2,-0.3",
                 "--hidden-region", "-1,0,1,2", "--up", "z"]) == 0
    (ra, ca, fa), (rb, cb, fb) = seen
    assert Path(ra).resolve() == scan.resolve() and fa == fb
    assert dataclasses.replace(ca, epochs=cb.epochs) == cb and ca.epochs == 2.5
    assert main(["fit", "--config", str(tmp_path / "cfg" / "room.yaml"), "--out", str(tmp_path / "c"),
                 "--preset", "tiny", "--quiet", "--people", "12"]) == 0
    assert seen[-1][1].people == 12
    capsys.readouterr()
    assert main(["fit", "--config", str(tmp_path / "cfg" / "room.yaml"), "--out", str(tmp_path / "e"),
                 "--preset", "tiny", "--quiet", "--bounce", "off", "--bounce-scale", "2"]) == 2
    assert "which this fit leaves out (--bounce off)" in capsys.readouterr().err
    assert main(["fit", "--config", str(tmp_path / "cfg" / "room.yaml"), "--out", str(tmp_path / "g"),
                 "--preset", "tiny", "--quiet", "--shadow-samples", "0"]) == 0
    assert not seen[-1][1].bounce  # no relay points, no bounce
    (tmp_path / "cfg" / "flash.yaml").write_text(  # the file's method and the flags checked together
        "room: ../scans/room.ply\ncamera_position: [0.35, -0.3, 0.09]\ncamera_look_at: [0.9, -2, -0.3]\n"
        "hidden_region: [-1, 0, 1, 2]\nup: z\nfit: {method: tancik}\n")
    for extra in ([], ["--bounce", "off"], ["--shadow-samples", "0"], ["--policy", "flash"], ["--capture-preset", "ideal"]):
        assert main(["fit", "--config", str(tmp_path / "cfg" / "flash.yaml"), "--out", str(tmp_path / "h"),
                     "--preset", "tiny", "--quiet", *extra]) == 0, extra
        got = seen[-1][1]
        assert (got.method, got.policy, got.bounce, got.shadow.shadow_samples, got.capture_preset) == \
            ("tancik", "flash", False, 0, "ideal")
    assert main(["fit", "--config", str(tmp_path / "cfg" / "room.yaml"), "--out", str(tmp_path / "f"),
                 "--preset", "tiny", "--quiet", "--bounce-body-samples", "0"]) == 0
    assert seen[-1][1].shadow.bounce_body_samples == 0 and seen[-1][1].bounce
    for i, block in enumerate(("{shadow: {shadow_samples: 256}, render: {person_samples: 80}}",
                               "{shadow_samples: 256, person_samples: 80}")):  # nested, or as the flags name them
        (tmp_path / "cfg" / "knobs.yaml").write_text("room: ../scans/room.ply\nfit: " + block + "\n")
        assert main(["fit", "--config", str(tmp_path / "cfg" / "knobs.yaml"), "--out", str(tmp_path / f"k{i}"),
                     "--preset", "tiny", "--quiet", "--pixel-footprint", "3"]) == 0
        got, tiny = seen[-1][1], PRESETS_FIT["tiny"]
        assert (got.shadow.shadow_samples, got.render.person_samples, got.render.pixel_footprint) == (256, 80, 3)
        assert (got.shadow.shadow_depth, got.render.person_quadrature) == (tiny.shadow.shadow_depth,
                                                                           tiny.render.person_quadrature)
    for text, flag, match in (("fit: {render: 5}\n", ["--pixel-footprint", "2"], "fit.render must be a mapping"),
                              ("fit: {render: }\n", ["--pixel-footprint", "2"], "fit.render must be a mapping"),
                              ("fit: {bounce: false, bounce_scale: 3.0}\n", [], "--bounce-scale 3 sets the bounce"),
                              ("fit: {shadow_depth: 6}\n", ["--shadow-samples", "0", "--bounce", "off"],
                               "--shadow-depth 6 sets the shadow")):
        (tmp_path / "bad.yaml").write_text("room: x.ply\n" + text)  # the file's settings checked as the flags
        capsys.readouterr()
        assert main(["fit", "--config", str(tmp_path / "bad.yaml"), "--out", str(tmp_path / "d"), "--quiet",
                     *flag]) == 2, text
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1 and match in err, err
    for text, match in (("camera_position: [1, 2]\n", "list of 3 numbers"), ("fit: {peeple: 3}\n", "unknown key"),
                        ("color: red\n", "unknown key 'color'"), ("fit: 3\n", "fit must be a mapping"),
                        ("fit: {shadow_samples: 1, shadow: {shadow_samples: 2}}\n", "fit.shadow_samples given twice"),
                        ("fit: {render: {people: 7}}\n", "unknown key 'fit.render.people'"),
                        ("fit: {render: {colour: 1}}\n", "unknown key 'fit.render.colour'")):
        (tmp_path / "bad.yaml").write_text("room: x.ply\n" + text)
        capsys.readouterr()
        assert main(["fit", "--config", str(tmp_path / "bad.yaml"), "--out", str(tmp_path / "d"), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1 and match in err, err


def test_render_knobs_are_one_nested_block(tmp_path):
    """The render knobs are declared once (``render.settings.ImageSampling``, ``ShadowSampling``)
    and nested as ``render`` (and a fit's ``shadow``) in the dataset and fit configs: a YAML block
    merges over the preset's; the flat names (the flags', and every record written before the
    blocks) read as the same config; a field given both ways is refused; the renderer's settings
    carry the block."""
    import json

    from nlos_spotlight.config_file import apply_assignments, flatten, with_fields
    from nlos_spotlight.data.config import DatasetConfig, read_dataset_config
    from nlos_spotlight.fit.config import FitConfig

    f = tmp_path / "d.yaml"
    f.write_text("base: small\nrender:\n  person_samples: 900\n")
    nested = load_config(str(f))
    small = DATA_PRESETS["small"].render
    assert nested.render.person_samples == 900 and nested.render.spot_samples == small.spot_samples == 16
    f.write_text("base: small\nperson_samples: 900\n")
    assert load_config(str(f)) == nested
    assert apply_assignments(dataclasses.replace(DATA_PRESETS["small"], name="d"), ["person_samples=900"]) == nested
    for text, match in (("person_samples: 9\nrender:\n  person_samples: 8\n", "person_samples given twice"),
                        ("render:\n  person_samples: many\n", "render.person_samples must be int"),
                        ("render:\n  colour: 1\n", "unknown key 'render.colour'"),
                        ("render: 3\n", "render must be a mapping"),
                        ("render:\n  person_samples: 0\n", "render.person_samples must be at least 1")):
        f.write_text(text)
        with pytest.raises(NlosError, match=match) as e:
            load_config(str(f))
        assert "\n" not in str(e.value)
    with pytest.raises(NlosError, match="expected FIELD=VALUE"):
        apply_assignments(nested, ["person_samples"])
    # a dataset's config.json: flat (before the block) and nested read as the same config
    data = tmp_path / "data"
    data.mkdir()
    flat = flatten(DatasetConfig, nested.to_dict())
    assert "render" not in flat and flat["person_samples"] == 900
    for record in (flat, nested.to_dict()):
        (data / "config.json").write_text(json.dumps(record))
        assert read_dataset_config(data) == nested
    old = {k: v for k, v in flat.items() if k not in ("footprint_jitter", "person_quadrature")}  # older still
    (data / "config.json").write_text(json.dumps(old))
    assert read_dataset_config(data) == nested
    for text in ("{", json.dumps({**flat, "render": {"colour": 1}})):
        (data / "config.json").write_text(text)
        with pytest.raises(NlosError, match="unreadable dataset config"):
            read_dataset_config(data)
    rs = nested.render_settings()
    assert rs.device == "cpu" and all(getattr(rs, k) == v for k, v in dataclasses.asdict(nested.render).items())
    # a fit: the flags' flat names set the blocks' fields, the rest of each block kept; its record
    # (nested) and a record before the blocks (flat) give the same config
    fit = with_fields(FitConfig(), person_samples=700, shadow_samples=1024, people=50)
    default = FitConfig()
    assert (fit.render.person_samples, fit.shadow.shadow_samples, fit.people) == (700, 1024, 50)
    assert (fit.render.pixel_footprint, fit.shadow.shadow_depth) == (default.render.pixel_footprint,
                                                                     default.shadow.shadow_depth)
    assert FitConfig.from_record(fit.to_dict()) == fit == FitConfig.from_record(flatten(FitConfig, fit.to_dict()))
    assert FitConfig(render={"person_samples": 700}).render == fit.render  # a mapping: over the fit's defaults
    with pytest.raises(NlosError, match="fit: shadow:") as e:
        FitConfig(shadow={"shadow_sample": 3})
    assert "\n" not in str(e.value)
