"""The command-line jobs offered in Python (amctl._jobs): each gives what the command prints
with --json (and writes the same files), checked against the built CLI."""

import pytest

import amctl

BOXBOSS = "examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode"
V0 = "configs/klipper-voron-v0.cfg"


def _nan_to_none(v):
    if isinstance(v, float) and v != v:
        return None
    if isinstance(v, dict):
        return {k: _nan_to_none(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_nan_to_none(x) for x in v]
    return v


def test_write_m73_writes_the_same_file_as_the_cli(cli, source_dir, tmp_path):
    g, m = str(source_dir / BOXBOSS), str(source_dir / V0)
    r = amctl.write_m73(g, tmp_path / "py.gcode", machine=m, interval_s=30)
    cli("estimate", g, "--machine", m, "--write-m73", tmp_path / "cli.gcode", "--m73-interval", "30")
    assert (tmp_path / "py.gcode").read_text() == (tmp_path / "cli.gcode").read_text()
    text = (tmp_path / "py.gcode").read_text()
    assert r["lines"] == text.count("\nM73 P") + text.startswith("M73 P") and r["lines"] > 20
    assert r["total_time_s"] == pytest.approx(amctl.estimate(g, machine=m)["total_time_s"], abs=0)


def test_compare_profiles_equals_the_cli(cli, source_dir):
    g = str(source_dir / "examples/30_belt_corner.gcode")
    want = cli.json("estimate", g, "--machine", "voron24", "--compare-profiles", "--json")
    assert amctl.compare_profiles(g, machine="voron24") == want


def test_calibrate_time_equals_the_cli_and_saves_the_machine(cli, tmp_path):
    # Two zig-zag files timed on a machine with max_accel 2200: the fit finds it back.
    for name, n in (("a.gcode", 10), ("b.gcode", 40)):
        lines = ["G90", "G1 X0 Y0 F6000"] + [f"G1 X{(i % 2) * 40} Y{i} F6000" for i in range(n)]
        (tmp_path / name).write_text("\n".join(lines) + "\n")
    truth = {"printer.max_accel": 2200, "printer.square_corner_velocity": 5}
    rows = [f"{n},{amctl.estimate(str(tmp_path / n), set=truth)['total_time_s']!r}" for n in ("a.gcode", "b.gcode")]
    (tmp_path / "t.csv").write_text("gcode,duration_s\n" + "\n".join(rows) + "\n")
    want = cli.json("calibrate-time", tmp_path / "t.csv", "--fit", "accel", "--json")
    got = amctl.calibrate_time(tmp_path / "t.csv", fit="accel", save=tmp_path / "fit.toml")
    # nan in Python is null in the CLI's JSON (a correlation of one parameter with itself)
    assert _nan_to_none(got) == want
    assert got["parameters"][0]["value"] == pytest.approx(2200.0, rel=1e-4)
    assert got["file_limits"]["policy"] == "keep"
    assert "max_accel" in (tmp_path / "fit.toml").read_text()


def test_shrink_slicing_and_apply_equal_the_cli(cli, source_dir, tmp_path):
    csv = str(source_dir / "examples/04_shrink_geometry4.csv")
    assert amctl.shrink_slicing(csv) == cli.json("shrink", "slicing", csv, "--json")
    g = str(source_dir / BOXBOSS)
    got = amctl.shrink_apply(tmp_path / "py.gcode", gcode=g, factors="x=1.01,y=1.02,z=1.005")
    want = cli.json("shrink", "apply", "--gcode", g, "--factors", "x=1.01,y=1.02,z=1.005",
                    "-o", tmp_path / "cli.gcode", "--json")
    assert {k: v for k, v in got.items() if k != "output"} == {k: v for k, v in want.items() if k != "output"}
    assert (tmp_path / "py.gcode").read_bytes() == (tmp_path / "cli.gcode").read_bytes()
    with pytest.raises(amctl.Error, match="exactly one"):
        amctl.shrink_apply(tmp_path / "x.gcode", factors="x=1.01")


def test_resonance_test_gcode_equals_the_cli(cli, source_dir, tmp_path):
    m = str(source_dir / V0)
    text = amctl.resonance_test_gcode("y", machine=m, freq_end_hz=20, output=tmp_path / "t.gcode")
    assert text == cli("resonance", "test-gcode", "--machine", m, "--axis", "y", "--freq-end", "20")
    assert (tmp_path / "t.gcode").read_text() == text
    assert text.count("ACCELEROMETER_MEASURE CHIP=adxl345 NAME=resonances_y_1\n") == 2
    assert amctl.resonance_test_gcode("x", machine=m, freq_end_hz=10, point_mm=(30, 40, 10), home=False) == \
        cli("resonance", "test-gcode", "--machine", m, "--axis", "x", "--freq-end", "10",
            "--point", "30,40,10", "--no-home")
    with pytest.raises(amctl.Error, match="axis"):
        amctl.resonance_test_gcode("z", machine=m)


def test_resonance_recommend_equals_the_cli(cli):
    got = amctl.resonance_recommend(42.9, 0.24, machine="ender3")
    want = cli.json("resonance", "recommend", "--natural-frequency-hz", "42.9", "--damping-ratio", "0.24",
                    "--machine", "ender3", "--json")
    drop = lambda d: {k: v for k, v in d.items() if k != "search"}  # search holds the wall-clock time
    assert drop(got) == drop(want)


def test_sweep_equals_the_cli(cli):
    want = cli.json("sweep", "--json")
    got = amctl.sweep()
    for d in (want, got):  # the wall-clock time of each case is the only thing that differs
        for c in d["cases"]:
            c.pop("compute_time_s")
    assert got == want
    assert want["study"].startswith("feedforward study") and want["seed"] == "000"
