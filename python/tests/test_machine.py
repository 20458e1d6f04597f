"""amctl.Machine: loading, overrides and the JSON of `amctl machine show --json`."""

import pathlib

import pytest

import amctl
from conftest import SIMPLE


def test_version_is_the_projects(source_dir):
    import re
    text = (source_dir / "CMakeLists.txt").read_text()
    assert amctl.__version__ == re.search(r"project\(amctl VERSION ([0-9.]+)", text).group(1)


def test_presets_are_listed_and_load():
    names = amctl.Machine.presets()
    assert "voron24" in names and "default" in names
    m = amctl.Machine.load("voron24")
    assert m.name == "voron24"
    assert m.firmware == "klipper"


def test_default_machine_is_the_default_preset():
    assert amctl.Machine.load() == amctl.Machine.load("default")
    assert amctl.Machine.load("") == amctl.Machine.load("default")


def test_set_applies_overrides_in_their_units():
    m = amctl.Machine.load("default", set=SIMPLE)
    assert m.max_accel_mm_s2 == 5000.0
    assert m.max_velocity_mm_s == 300.0
    assert m.square_corner_velocity_mm_s == 0.0
    assert m.minimum_cruise_ratio == 0.0
    m2 = m.with_set({"printer.max_accel": 1234.5, "printer.firmware": "marlin",
                     "marlin.jerk": [10, 10, 0.4, 5]})
    assert m2.max_accel_mm_s2 == 1234.5
    assert m2.firmware == "marlin"
    assert m2.jerk_mm_s == (10.0, 10.0, 0.4, 5.0)
    assert m.max_accel_mm_s2 == 5000.0  # values are immutable


def test_klipper_cfg_is_read(source_dir):
    m = amctl.Machine.load(source_dir / "examples" / "30_belt_corner_printer.cfg")  # a PathLike
    assert m.max_accel_mm_s2 == 5000.0
    assert m.square_corner_velocity_mm_s == 0.0
    assert m.max_velocity_mm_s == 300.0


@pytest.mark.parametrize("spec", ["voron24", "prusa-mk3s", "configs/klipper-voron-v0.cfg"])
def test_to_dict_is_machine_show_json(cli, source_dir, spec):
    path = spec if "/" not in spec else str(source_dir / spec)
    assert amctl.Machine.load(path).to_dict() == cli.json("machine", "show", path, "--json")


def test_to_dict_with_overrides_is_machine_show_json_with_set(cli):
    m = amctl.Machine.load("ender3", set={"printer.max_accel": 700, "printer.profile": "scurve7"})
    assert m.to_dict() == cli.json("machine", "show", "ender3", "--set", "printer.max_accel=700",
                                   "--set", "printer.profile=scurve7", "--json")


def test_toml_round_trip(tmp_path):
    m = amctl.Machine.load("prusa-mk3s", set={"printer.max_accel": 1500})
    p = tmp_path / "m.toml"
    p.write_text(m.to_toml())
    assert amctl.Machine.load(str(p)) == m


def test_unknown_key_and_bad_value_raise_amctl_error():
    with pytest.raises(amctl.Error, match="max_acel"):
        amctl.Machine.load("default", set={"printer.max_acel": 5000})
    with pytest.raises(amctl.Error, match="printer.max_accel"):
        amctl.Machine.load("default", set={"printer.max_accel": -1})
    with pytest.raises(amctl.Error, match="vorn24|voron24"):
        amctl.Machine.load("vorn24")


def test_bad_cfg_names_file_and_line(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("[printer]\nmax_accel = \"fast\"\n")
    with pytest.raises(amctl.Error) as e:
        amctl.Machine.load(str(p))
    assert e.value.file == str(p)
    assert e.value.line == 2


def test_wrong_types_are_type_errors_naming_the_parameter():
    with pytest.raises(TypeError, match="spec"):
        amctl.Machine.load(42)
    with pytest.raises(TypeError, match="set"):
        amctl.Machine.load("default", set="printer.max_accel=5")
    with pytest.raises(TypeError, match=r"set\['printer.max_accel'\]"):
        amctl.Machine.load("default", set={"printer.max_accel": {"a": 1}})


def test_machines_pickle_to_an_equal_machine():
    # (worker processes, e.g. fleet runs, receive machines pickled)
    import copy
    import pickle
    m = amctl.Machine.load("prusa-mk3s", set={"printer.max_accel": 1500, "printer.profile": "bezier5"})
    back = pickle.loads(pickle.dumps(m))
    assert back == m
    assert back.to_dict() == m.to_dict()
    assert copy.deepcopy(m) == m


def test_bed_mesh_lists_the_saved_profiles(source_dir):
    # tests/reference/klipper/bedmesh_corexy.cfg: a 7x7 bicubic 'default' and a 5x5 lagrange
    # 'alt', upsampled with 2 and 3 points between probes: 19 and 17 per axis.
    m = amctl.Machine.load(str(source_dir / "tests/reference/klipper/bedmesh_corexy.cfg"))
    mesh = m.bed_mesh
    assert [p["name"] for p in mesh["profiles"]] == ["default", "alt"]
    assert mesh["profiles"][0]["mesh_count"] == [19, 19]
    assert mesh["profiles"][1]["mesh_count"] == [17, 17]
    assert mesh["split_delta_z_mm"] == 0.025 and mesh["fade_enabled"] is False
    lo, hi = mesh["profiles"][0]["probed_z_range_mm"]
    assert lo == -0.0678 and hi == 0.122824
    assert amctl.Machine.load("voron24").bed_mesh is None
