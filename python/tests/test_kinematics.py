"""Kinematics beyond cartesian/CoreXY through the Python package: the delta's estimate and
steps equal `amctl estimate/steps --json`, and the estimate is Klipper's batch-mode time
(tests/reference/klipper/klipper_times_kinematics.json)."""

import json

import pytest

import amctl


def test_delta_estimate_is_klippers_time_and_the_cli(cli, source_dir):
    ref_dir = source_dir / "tests/reference/klipper"
    g, cfg = str(ref_dir / "syn_delta.gcode"), str(ref_dir / "delta.cfg")
    klipper = json.loads((ref_dir / "klipper_times_kinematics.json").read_text())
    r = amctl.estimate(g, machine=cfg)
    assert r["total_time_s"] == pytest.approx(klipper["delta/syn_delta"]["motion_stock_s"], abs=1e-6)
    ref = cli.json("estimate", g, "--machine", cfg, "--json")
    assert r["total_time_s"] == ref["total_time_s"]


def test_delta_steps_equal_the_cli(cli, source_dir):
    ref_dir = source_dir / "tests/reference/klipper"
    g, cfg = str(ref_dir / "syn_delta.gcode"), str(ref_dir / "delta.cfg")
    r = amctl.steps(g, machine=cfg)
    ref = cli.json("steps", g, "--machine", cfg, "--json")
    drop = lambda d: {k: v for k, v in d.items() if k not in ("compute_time_s", "csv")}
    assert drop(r) == drop(ref)
    assert [s["name"] for s in r["steppers"]] == ["stepper_a", "stepper_b", "stepper_c", "extruder"]


def test_delta_machine_shows_its_geometry(cli, source_dir):
    cfg = str(source_dir / "tests/reference/klipper/delta.cfg")
    d = amctl.Machine.load(cfg).to_dict()
    assert d["printer"]["kinematics"] == "delta"
    # Klipper's own log for this cfg: "Delta max build radius 157.11mm (moves slowed past
    # 141.17mm and 153.73mm)".
    assert d["delta"]["build_radius"] == pytest.approx(157.11, abs=0.005)
    assert d["delta"]["slow_radius"] == pytest.approx(141.17, abs=0.005)
    assert d == cli.json("machine", "show", cfg, "--json")


@pytest.mark.parametrize("kin", ["generic_cartesian", "polar", "rotary_delta"])
def test_linkage_kinematics_estimate_is_klippers_time(cli, source_dir, kin):
    ref_dir = source_dir / "tests/reference/klipper"
    g, cfg = str(ref_dir / f"syn_{kin}.gcode"), str(ref_dir / f"{kin}.cfg")
    klipper = json.loads((ref_dir / "klipper_times_kinematics.json").read_text())
    r = amctl.estimate(g, machine=cfg)
    assert r["total_time_s"] == pytest.approx(klipper[f"{kin}/syn_{kin}"]["motion_stock_s"], abs=1e-6)
    assert amctl.Machine.load(cfg).to_dict() == cli.json("machine", "show", cfg, "--json")


def test_polar_and_generic_steppers_are_named_as_klipper_names_them(source_dir):
    ref_dir = source_dir / "tests/reference/klipper"
    polar = amctl.steps(str(ref_dir / "syn_polar.gcode"), machine=str(ref_dir / "polar.cfg"))
    assert [s["name"] for s in polar["steppers"]] == ["stepper_bed", "stepper_arm", "stepper_z", "extruder"]
    generic = amctl.steps(str(ref_dir / "syn_generic_cartesian.gcode"),
                          machine=str(ref_dir / "generic_cartesian.cfg"))
    assert [s["name"] for s in generic["steppers"]][:2] == ["stepper my_stepper_u", "stepper my_stepper_x"]
