"""Dataset and training configs read through one loader (``config_file``): the same checks, the
same one-line errors, nested training fields merged."""

from __future__ import annotations

import pytest

from nlos_spotlight.data.config import PRESETS as DATA_PRESETS
from nlos_spotlight.data.config import load_config
from nlos_spotlight.errors import NlosError
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
                        ("net: 3\n", "net must be a mapping"), ("sensor_noise: 1\n", "sensor_noise must be bool")):
        f.write_text(text)
        with pytest.raises(NlosError, match=match):
            load_train_config(str(f))
    f.write_text("base: demo\nsamples_per_scene: 40\nfamilies: [doorway]\n")
    d = load_config(str(f))
    assert (d.samples_per_scene, d.families, d.resolution) == (40, ["doorway"], DATA_PRESETS["demo"].resolution)
    f.write_text("samples_per_scene: 0\n")  # the dataset's own validation still runs
    with pytest.raises(NlosError, match="samples_per_scene must be at least 1"):
        load_config(str(f))
