"""amctl.stepper_simulate against `amctl stepper simulate --json` (docs/closedloop.md)."""

import pytest

import amctl


def test_stepper_simulate_scenario_equals_the_cli(cli, tmp_path):
    out = tmp_path / "trace.csv"
    r = amctl.stepper_simulate(machine="ender3", controller="feedforward",
                               scenario="reversing-strokes", speed_mm_s=30.0, load=False,
                               csv=str(out))
    ref = cli.json("stepper", "simulate", "--scenario", "reversing-strokes", "--speed-mm-s", "30",
                   "--no-load", "--machine", "ender3", "--controller", "feedforward", "--json")
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
    with pytest.raises(amctl.Error, match="kp 20.*unstable"):
        amctl.stepper_simulate(machine="ender3", controller="pid", scenario="reversing-strokes",
                               kp=20.0)
    with pytest.raises(amctl.Error, match="--controller"):
        amctl.stepper_simulate(machine="ender3", controller="fuzzy", scenario="reversing-strokes")


def test_stepper_simulate_old_names_run_with_a_note(cli):
    r = amctl.stepper_simulate(machine="ender3", controller="best", scenario="seed003",
                               speed_mm_s=30.0, load=False)
    assert r["controller"] == "feedforward"
    assert any("'best' is now 'feedforward'" in n or "best is now 'feedforward'" in n
               for n in r["notes"])
    assert any("seed003 is now 'reversing-strokes'" in n for n in r["notes"])


def test_stepper_simulate_encoder_keywords_equal_the_cli_flags(cli):
    r = amctl.stepper_simulate(machine="ender3", controller="pid", scenario="reversing-strokes",
                               speed_mm_s=30.0, load=False, encoder_rate_hz=20000.0,
                               encoder_resolution_um=1.0, governor=False)
    ref = cli.json("stepper", "simulate", "--scenario", "reversing-strokes", "--speed-mm-s", "30",
                   "--no-load", "--machine", "ender3", "--controller", "pid",
                   "--encoder-rate-hz", "20000", "--encoder-resolution-um", "1",
                   "--no-governor", "--json")
    assert r == ref


def test_stepper_simulate_load_keywords_equal_the_cli_flags(cli):
    # The scenario's load, backlash and currents by keyword are the command's flags.
    kw = dict(drag_n=10.0, drag_n_s_per_m=120.0, backlash_mm=0.1, run_current_a=0.9,
              max_current_a=1.5, drag_gain=10.0, load_angle_deg=50.0)
    r = amctl.stepper_simulate(machine="ender3", controller="feedforward",
                               scenario="reversing-strokes", **kw)
    ref = cli.json("stepper", "simulate", "--scenario", "reversing-strokes", "--machine", "ender3",
                   "--controller", "feedforward", "--drag-n", "10", "--drag-n-s-per-m", "120",
                   "--backlash-mm", "0.1", "--run-current-a", "0.9", "--max-current-a", "1.5",
                   "--drag-gain", "10", "--load-angle-deg", "50", "--json")
    assert r == ref
    for axis in ("x", "y"):
        a = r["axes"][axis]
        # Kt I at the run current: 0.40 N m / (sqrt 2 x 1.7 A) x sqrt 2 x 0.9 A.
        assert a["pull_out_torque_n_m"] == pytest.approx(0.40 / 1.7 * 0.9, rel=1e-12)
        assert 0.9 * 2 ** 0.5 - 1e-12 <= a["mean_current_a"] <= a["peak_current_a"] <= 1.5 + 1e-12


def test_stepper_simulate_names_a_negative_load():
    with pytest.raises(amctl.Error, match="--drag-n: must be"):
        amctl.stepper_simulate(machine="ender3", scenario="reversing-strokes", drag_n=-5.0)


def test_stepper_sweep_equals_the_cli_and_draws_its_chart(cli, tmp_path):
    import xml.etree.ElementTree as ET
    svg, csv = tmp_path / "sweep.svg", tmp_path / "sweep.csv"
    rows = amctl.stepper_sweep(machine="ender3", load=False, csv=str(csv), svg=str(svg))
    assert rows == cli.json("stepper", "sweep", "--machine", "ender3", "--no-load", "--json")
    assert [(r["controller"], r["speed_mm_s"]) for r in rows] == [
        (c, v) for c in ("open", "encoder-sequenced", "speed-tracking", "pid", "feedforward")
        for v in (30, 60, 90, 120, 150)]
    # The CSV has the same numbers; the chart is well-formed SVG with one line per controller
    # and axis, five points each, named by controller.
    lines = csv.read_text().splitlines()
    assert lines[0].startswith("controller,speed_mm_s,x_max_error_mm")
    first = lines[1].split(",")
    assert float(first[2]) == pytest.approx(rows[0]["x"]["max_tracking_error_mm"], abs=1e-6)
    ns = {"s": "http://www.w3.org/2000/svg"}
    lines_drawn = ET.parse(svg).getroot().findall(".//s:polyline", ns)
    assert [p.get("data-name") for p in lines_drawn] == [
        "open", "encoder-sequenced", "speed-tracking", "pid", "feedforward"] * 2
    assert all(len(p.get("points").split()) == 5 for p in lines_drawn)
