"""The per-room fits' shared module: the variant grammar, the registry's methods it names, its rows."""

import csv
import time

import pytest
from scipy import stats

from nlos_spotlight.errors import NlosError
from nlos_spotlight.data.store import atomic_csv
from nlos_spotlight.evaluate.room_fits import (first_seconds, parse_variant, read_fit_rows, room_interval,
                                               room_range, run_dir)


def test_variant_fields_from_the_documented_examples():
    v = parse_variant("16+e120+x2+s1")
    assert (v.frames, v.epochs, v.renders, v.train_seed, v.light, v.arch) == (16, 120.0, 2, 1, "fit", "resnet18")
    v = parse_variant("16+e120+ambient+lux0.01")
    assert (v.light, v.hidden_lux, v.albedo, v.init) == ("ambient", 0.01, False, False)
    v = parse_variant("16+albedo+p1396+wd1e-3+init")
    assert (v.albedo, v.people, v.weight_decay, v.init) == (True, 1396, 1e-3, True)
    assert parse_variant("16+e120+lux0").hidden_lux == 0.0  # no hidden light at all is allowed


@pytest.mark.parametrize("spec", ["", "0", "x16", "16+e0", "16+e120+e60", "16+adaptive+center", "16+chandran+init",
                                  "16+wd-1", "16+bogus", "16+p1.5"])
def test_malformed_variants_are_one_line_errors(spec):
    with pytest.raises(NlosError) as e:
        parse_variant(spec)
    assert "\n" not in str(e.value) and repr(spec) in str(e.value)


@pytest.mark.parametrize("spec, method", [("16+e120", "oracle_resnet"), ("16+adaptive", "al_resnet"),
                                          ("16+adaptive+chandran", "chandran"), ("16+flash+tancik", "tancik"),
                                          ("16+ambient+dlnlos", "dlnlos"), ("16+center", "center_resnet"),
                                          ("16+ambient", None), ("16+rank2", None)])
def test_a_variants_light_and_network_name_the_registrys_method(spec, method):
    m = parse_variant(spec).method()
    assert (m.name if m else None) == method


def test_room_interval_is_students_t_on_the_rooms():
    a = [60.0, 62.0, 64.0]  # mean 62, sample sd 2
    half = stats.t.ppf(0.975, 2) * 2 / 3 ** 0.5  # 4.968
    assert room_interval(a) == f"{62 - half:.1f}-{62 + half:.1f}%" == "57.0-67.0%"
    assert room_interval([50.0, 70.0]) == "0.0-100.0%"  # t(1) = 12.7: clipped to the possible range
    assert room_interval([55.0]) == ""


def test_room_ranges():
    assert room_range("0-5") == [0, 1, 2, 3, 4, 5] and room_range("0,3,7") == [0, 3, 7] and room_range("4") == [4]
    for bad in ("5-1", "a-b", "1,,2", "1-2-3"):
        with pytest.raises(NlosError):
            room_range(bad)


def test_rows_round_trip_and_the_first_fits_read_as_variant_1(tmp_path):
    path = tmp_path / "sub" / "fit.csv"
    rows = [{"room": "test-00000", "variant": "16+e120", "error_cm": "15.5"}]
    atomic_csv(path, ["room", "variant", "error_cm"], rows)
    assert read_fit_rows(path) == rows and not list(path.parent.glob("*.tmp"))
    old = tmp_path / "old.csv"  # written before variants: no column
    with old.open("w", newline="") as f:
        csv.writer(f).writerows([["room", "error_cm"], ["test-00001", "20"]])
    assert read_fit_rows(old) == [{"variant": "1", "room": "test-00001", "error_cm": "20"}]
    assert run_dir(tmp_path, "1").name == "run" and run_dir(tmp_path, "16+e120").name == "run-16-e120"


def test_first_seconds_keeps_the_first_finish(tmp_path):
    t0 = time.perf_counter() - 5.0
    first = first_seconds(tmp_path / "s.json", t0)
    assert 5.0 <= first < 60.0
    assert first_seconds(tmp_path / "s.json", time.perf_counter()) == first  # a rerun reports the first time


@pytest.mark.parametrize("spec, flags, left", [
    ("16+e120", ["--burst", "16", "--epochs", "120"], []),
    ("16+e120+adaptive+chandran", ["--burst", "16", "--epochs", "120", "--method", "chandran"], []),
    ("1+p1396+ambient+dlnlos", ["--burst", "1", "--people", "1396", "--method", "dlnlos"], []),
    ("16+e120+x2+s1", ["--burst", "16", "--epochs", "120"], ["+x2", "+s1"]),
    ("16+ambient+lux0.01", ["--burst", "16"], ["+ambient", "+lux0.01"]),
    ("16+rank2+chandran", ["--burst", "16"], ["+rank2", "+chandran"]),
])
def test_a_variant_is_nlos_fit_flags_where_nlos_fit_has_them(spec, flags, left):
    from nlos_spotlight.cli import build_parser

    got, rest = parse_variant(spec).fit_flags()
    assert (got, rest) == (flags, left)
    build_parser().parse_args(["fit", "room.ply", "--out", "o", *got])  # flags nlos fit takes
