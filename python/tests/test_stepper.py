"""amctl.stepper_simulate against `amctl stepper simulate --json` (docs/closedloop.md)."""

import pytest

import amctl


def test_stepper_simulate_scenario_equals_the_cli(cli, tmp_path):
    out = tmp_path / "trace.csv"
    r = amctl.stepper_simulate(machine="ender3", controller="best", scenario="seed003",
                               speed_mm_s=30.0, load=False, csv=str(out))
    ref = cli.json("stepper", "simulate", "--scenario", "seed003", "--speed-mm-s", "30",
                   "--no-load", "--machine", "ender3", "--controller", "best", "--json")
    assert r == ref
    for axis in ("x", "y"):
        a = r["axes"][axis]
        assert a["lost_steps"] == 0
        assert 0.0 < a["rms_tracking_error_mm"] <= a["max_tracking_error_mm"]
    assert out.read_text().splitlines()[0].startswith("time_s,x_ref_mm,x_mm,x_error_mm")


def test_stepper_simulate_file_equals_the_cli(cli, source_dir):
    g = str(source_dir / "tests/reference/klipper/syn_square.gcode")
    r = amctl.stepper_simulate(g, machine="ender3", controller="pid")
    ref = cli.json("stepper", "simulate", g, "--machine", "ender3", "--controller", "pid", "--json")
    assert r == ref


def test_stepper_simulate_rejects_an_unstable_gain_and_a_bad_controller():
    with pytest.raises(amctl.Error, match="kp = 20.*unstable"):
        amctl.stepper_simulate(machine="ender3", controller="pid", scenario="seed003", kp=20.0)
    with pytest.raises(amctl.Error, match="--controller"):
        amctl.stepper_simulate(machine="ender3", controller="fuzzy", scenario="seed003")
