"""amctl.shaper_show and amctl.resonance_calibrate: closed forms and the CLI's JSON."""

import math

import pytest

import amctl


def test_zv_closed_form_and_the_cli(cli):
    # ZV: A = [1, K], K = exp(-zeta pi / sqrt(1 - zeta^2)), at t = [0, 1 / (2 f_d)],
    # f_d = f sqrt(1 - zeta^2).
    f, z = 40.0, 0.1
    r = amctl.shaper_show("zv", f, z, residual_at_hz=[30, 40, 60])
    k = math.exp(-z * math.pi / math.sqrt(1 - z * z))
    assert r["amplitudes"] == pytest.approx([1.0, k], rel=1e-15)
    assert r["times_s"] == pytest.approx([0.0, 0.5 / (f * math.sqrt(1 - z * z))], rel=1e-15)
    assert r["residual_vibration"][1] == pytest.approx(0.0, abs=1e-12)  # at the design frequency
    ref = cli.json("shaper", "show", "--type", "zv", "--freq-hz", "40", "--damping-ratio", "0.1",
                   "--residual-at-hz", "30,40,60", "--json")
    assert r == ref


def test_shaper_errors():
    with pytest.raises(amctl.Error, match="freq"):
        amctl.shaper_show("mzv", 0.0)
    with pytest.raises(amctl.Error, match="foo"):
        amctl.shaper_show("foo", 40.0)
    with pytest.raises(TypeError, match="freq_hz"):
        amctl.shaper_show("mzv", "40")


def test_resonance_calibration_equals_the_cli(cli, source_dir, tmp_path):
    # A synthetic record made here: a 42 Hz mode rung by white noise would need a random
    # generator; a Klipper PSD CSV with a single resonance peak is enough to check that Python
    # and the CLI run the same calibration.
    psd = tmp_path / "psd.csv"
    lines = ["freq,psd_x,psd_y,psd_z,psd_xyz"]
    f0, z = 42.0, 0.08
    f = 5.0
    while f <= 200.0 + 1e-9:
        h = 1.0 / ((1 - (f / f0) ** 2) ** 2 + (2 * z * f / f0) ** 2)
        lines.append(f"{f:.3f},{h:.6e},{h * 0.01:.6e},{h * 0.01:.6e},{h * 1.02:.6e}")
        f += 0.390625
    psd.write_text("\n".join(lines) + "\n")
    r = amctl.resonance_calibrate(str(psd), axis="x")
    ref = cli.json("resonance", "calibrate", str(psd), "--axis", "x", "--json")
    assert r == ref
    # The recommended shaper sits near the mode (Klipper's rule with a PSD normalised as given).
    assert 20.0 < r["klipper"]["recommended"]["freq_hz"] < 80.0
    with pytest.raises(amctl.Error):
        amctl.resonance_calibrate(str(psd), axis="z")
    with pytest.raises(TypeError):
        amctl.resonance_calibrate(str(psd), sweep=(5, 80, 1))
    # Several records in one fit, and no axis, as calibrate_shaper.py A B.
    both = amctl.resonance_calibrate([psd, psd], axis=None)
    assert both == cli.json("resonance", "calibrate", str(psd), str(psd), "--json")
    assert both["sources"] == [str(psd), str(psd)] and both["axis"] is None
    assert both["klipper"]["recommended"] == r["klipper"]["recommended"]  # the same record twice


def test_report_equals_the_cli_and_writes_one_self_contained_page(cli, source_dir, tmp_path):
    g = str(source_dir / "examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode")
    mine = tmp_path / "py.html"
    r = amctl.report(g, machine="voron24", output=str(mine))
    ref = cli.json("report", g, "--machine", "voron24", "-o", str(tmp_path / "cli.html"), "--json")
    for k in ref:
        if k not in ("compute_time_s", "output", "bytes"):  # the page embeds its wall-clock time
            assert r[k] == ref[k], k
    assert r["moves"] == amctl.estimate(g, machine="voron24")["moves"]
    import re
    clock = re.compile(r'"compute_time_s":[-+0-9.eE]+')
    page = mine.read_text()
    # The same bytes, but for the wall-clock times embedded in the page's data.
    assert clock.sub("", page) == clock.sub("", (tmp_path / "cli.html").read_text())
    assert "Content-Security-Policy" in page and "https://" not in page
    with pytest.raises(amctl.Error):
        amctl.report(str(tmp_path / "missing.gcode"), output=str(tmp_path / "x.html"))
    assert not (tmp_path / "x.html").exists()


def test_steps_equal_the_cli(cli, source_dir, tmp_path):
    g = str(source_dir / "tests/reference/klipper/syn_square.gcode")
    cfg = str(source_dir / "tests/reference/klipper/v0_corexy.cfg")
    out = tmp_path / "steps.csv"
    r = amctl.steps(g, machine=cfg, csv=str(out))
    ref = cli.json("steps", g, "--machine", cfg, "--csv", str(tmp_path / "cli.csv"), "--json")
    drop = lambda d: {k: v for k, v in d.items() if k not in ("compute_time_s", "csv")}
    assert drop(r) == drop(ref)
    assert out.read_text() == (tmp_path / "cli.csv").read_text()
    lines = out.read_text().splitlines()
    assert lines[0] == "stepper,time_s,direction"
    # Every step is +1 or -1 and the times never go back.
    times = [float(l.split(",")[1]) for l in lines[1:]]
    assert all(l.split(",")[2] in ("1", "-1") for l in lines[1:])
    assert times == sorted(times)
    with pytest.raises(amctl.Error):
        amctl.steps(g)  # the default preset has no [stepper_*] sections


def test_steps_with_klippers_filter_equal_the_cli(cli, source_dir, tmp_path):
    # A one-step reversal at 100 000 mm/s^2 (the gtest StepDirFilter case): Klipper's filter
    # drops the step back and the step forward 0.56 ms later.
    g = tmp_path / "rev.gcode"
    g.write_text("G90\nG1 X10 F6000\nG1 X9.99\nG1 X10\n")
    cfg = str(source_dir / "tests/reference/klipper/steps_cartesian.cfg")
    raw = amctl.steps(str(g), machine=cfg, set=["printer.max_accel=100000"])
    kl = amctl.steps(str(g), machine=cfg, set=["printer.max_accel=100000"], step_filter="klipper")
    assert kl == cli.json("steps", str(g), "--machine", cfg, "--set", "printer.max_accel=100000",
                          "--step-filter", "klipper", "--json")
    x = lambda r: next(s for s in r["steppers"] if s["name"] == "stepper_x")
    assert (raw["step_filter"], kl["step_filter"]) == ("none", "klipper")
    assert (x(raw)["steps"], x(raw)["filtered_pairs"]) == (802, 0)
    assert (x(kl)["steps"], x(kl)["steps_negative"], x(kl)["filtered_pairs"]) == (800, 0, 1)
    with pytest.raises(amctl.Error, match="step_filter"):
        amctl.steps(str(g), machine=cfg, step_filter="marlin")


def test_compensate_equals_the_cli_and_tracks_the_path(cli, source_dir, tmp_path):
    # The seed's base case (w = 100 rad/s, zeta 0.5): FBF brings the tracking error under
    # 10 % of the uncompensated one (issue 10), and Python gives the CLI's numbers.
    g = str(source_dir / "examples/30_belt_corner.gcode")
    cfg = str(source_dir / "examples/30_belt_corner_printer.cfg")
    f = 100.0 / (2 * math.pi)
    r = amctl.compensate(g, machine=cfg, method="fbf", natural_frequency_hz=f, damping_ratio=0.5,
                         csv=str(tmp_path / "py.csv"))
    ref = cli.json("compensate", g, "--machine", cfg, "--method", "fbf", "--natural-frequency-hz",
                   repr(f), "--damping-ratio", "0.5", "--csv", str(tmp_path / "cli.csv"), "--json")
    for k in ref:
        if k not in ("compute_time_s", "real_time_factor"):
            assert r[k] == ref[k], k
    assert r["max_tracking_error_mm"] <= 0.1 * r["uncompensated_max_tracking_error_mm"]
    t = r["trace"]
    assert len(t["t_s"]) == r["samples"]
    # The reported error is the simulated plant against the planned path, sample by sample.
    import numpy as np
    err = np.hypot(t["x_sim_mm"] - t["x_des_mm"], t["y_sim_mm"] - t["y_des_mm"]).max()
    assert err == pytest.approx(r["max_tracking_error_mm"], rel=1e-9)
    assert (tmp_path / "py.csv").read_text() == (tmp_path / "cli.csv").read_text()
    # Judged against the seed printer's own max_accel (5000 mm/s^2): the command needs more.
    limit = r["machine_accel_limit"]
    assert limit["key"] == "printer.max_accel" and limit["mm_s2"] == 5000.0
    assert limit["ratio"] == pytest.approx(r["peak_command_accel_mm_s2"] / 5000.0, rel=1e-12)
    assert r["status"] == "machine_accel_limit_exceeded" and "5000" in r["message"]
    free = amctl.compensate(g, machine=cfg, method="fbf", natural_frequency_hz=f, damping_ratio=0.5,
                            ignore_machine_limits=True)
    assert free["status"] == "ok" and "machine_accel_limit" not in free
    with pytest.raises(amctl.Error, match="method"):
        amctl.compensate(g, machine=cfg, method="magic", natural_frequency_hz=f)


def test_collocation_with_a_base_accel_bound_equals_the_cli(cli, source_dir, tmp_path):
    # Issue 10: collocation with the 10 000 mm/s^2 bound on the seed base case, <= 5 um, the
    # bound respected; second differences of the command checked here, independently.
    import numpy as np
    g = str(source_dir / "examples/30_belt_corner.gcode")
    cfg = str(source_dir / "examples/30_belt_corner_printer.cfg")
    f = 100.0 / (2 * math.pi)
    r = amctl.compensate(g, machine=cfg, method="collocation", natural_frequency_hz=f,
                         damping_ratio=0.5, max_base_accel_mm_s2=10000.0, csv=str(tmp_path / "py.csv"))
    ref = cli.json("compensate", g, "--machine", cfg, "--method", "collocation", "--natural-frequency-hz",
                   repr(f), "--damping-ratio", "0.5", "--max-base-accel-mm-s2", "10000",
                   "--csv", str(tmp_path / "cli.csv"), "--json")
    for k in ref:
        if k not in ("compute_time_s", "real_time_factor"):
            assert r[k] == ref[k], k
    assert r["status"] == "ok" and r["max_tracking_error_mm"] <= 5e-3
    t = r["trace"]
    h = 1.0 / r["sample_rate_hz"]
    ax = np.diff(t["x_cmd_mm"], 2) / h**2
    ay = np.diff(t["y_cmd_mm"], 2) / h**2
    assert np.hypot(ax, ay).max() <= 10000.0 * (1 + 1e-5)
    amctl.compensate(g, machine=cfg, method="collocation", natural_frequency_hz=f, damping_ratio=0.5,
                     max_base_accel_mm_s2=10000.0, gcode=str(tmp_path / "py.gcode"))
    cli("compensate", g, "--machine", cfg, "--method", "collocation", "--natural-frequency-hz", repr(f),
            "--damping-ratio", "0.5", "--max-base-accel-mm-s2", "10000", "--csv", str(tmp_path / "c2.csv"),
            "--gcode", str(tmp_path / "cli.gcode"))
    py_g = [l for l in (tmp_path / "py.gcode").read_text().splitlines() if not l.startswith(";")]
    cli_g = [l for l in (tmp_path / "cli.gcode").read_text().splitlines() if not l.startswith(";")]
    assert py_g == cli_g and py_g[:3] == ["G90", "M83", "M204 S10100"]
    bad = amctl.compensate(g, machine=cfg, method="collocation", natural_frequency_hz=f,
                           damping_ratio=0.5, max_base_accel_mm_s2=100.0, csv=str(tmp_path / "bad.csv"))
    assert bad["status"] == "infeasible" and "320.683" in bad["message"]
    assert len(bad["trace"]["t_s"]) == 0 and not (tmp_path / "bad.csv").exists()


def test_lpfbf_equals_the_streaming_cli(cli, source_dir, tmp_path):
    g = str(source_dir / "examples/30_belt_corner.gcode")
    cfg = str(source_dir / "examples/30_belt_corner_printer.cfg")
    f = 100.0 / (2 * math.pi)
    r = amctl.compensate(g, machine=cfg, method="lpfbf", natural_frequency_hz=f, damping_ratio=0.5,
                         window_s=0.1, overlap_s=0.05)
    ref = cli.json("compensate", g, "--machine", cfg, "--method", "lpfbf", "--natural-frequency-hz",
                   repr(f), "--damping-ratio", "0.5", "--window-s", "0.1", "--overlap-s", "0.05",
                   "--csv", str(tmp_path / "cli.csv"), "--json")
    # The CLI streams (windows checked as they end), Python keeps the run in memory: the same
    # command and tracking error.
    assert r["max_tracking_error_mm"] == pytest.approx(ref["max_tracking_error_mm"], rel=1e-9)
    assert r["max_tracking_error_mm"] <= 0.1 * ref["uncompensated_max_tracking_error_mm"]


def test_compare_equals_the_cli(cli, source_dir):
    g = str(source_dir / "examples/30_belt_corner.gcode")
    cfg = str(source_dir / "examples/30_belt_corner_printer.cfg")
    r = amctl.compare(g, machine=cfg, natural_frequency_hz=15.915, damping_ratio=0.5,
                      methods=["fbf", "mzv"], plant_offsets_pct=[0, 10])
    ref = cli.json("compare", g, "--machine", cfg, "--natural-frequency-hz", "15.915",
                   "--damping-ratio", "0.5", "--methods", "fbf,mzv", "--plant-offsets", "0,10", "--json")
    key = lambda row: (row["method"], row["plant_offset_pct"])
    mine = {key(x): x for x in r["rows"]}
    assert len(mine) == len(ref["rows"]) == 6  # (2 methods + uncompensated) x 2 offsets
    for row in ref["rows"]:
        assert mine[key(row)]["max_contour_error_mm"] == row["max_contour_error_mm"]
    with pytest.raises(amctl.Error, match="method"):
        amctl.compare(g, machine=cfg, natural_frequency_hz=15.915, methods=["magic"])


def test_marlin_mzv_against_its_closed_form_and_the_cli(cli):
    # Marlin's FT_MOTION MZV: A = [1, sqrt2 K, K^2] at [0, 3/8, 3/4] t_d, where Klipper's decays
    # by K^(3/4). At its own frequency it leaves
    # K^1.5 (1 - K^0.25) sqrt(1 + K^0.5) / (1 + sqrt2 K + K^2).
    f, z = 40.0, 0.1
    r = amctl.shaper_show("mzv", f, z, firmware="marlin", marlin_sample_rate_hz=0)
    k = math.exp(-z * math.pi / math.sqrt(1 - z * z))
    t_d = 1.0 / (f * math.sqrt(1 - z * z))
    assert r["firmware"] == "marlin"
    assert r["amplitudes"] == pytest.approx([1.0, math.sqrt(2) * k, k * k], rel=1e-15)
    assert r["times_s"] == pytest.approx([0.0, 0.375 * t_d, 0.75 * t_d], rel=1e-15)
    closed = k ** 1.5 * (1 - k ** 0.25) * math.sqrt(1 + k ** 0.5) / (1 + math.sqrt(2) * k + k * k)
    assert r["residual_at_design"] == pytest.approx(closed, rel=1e-12)
    assert r["compared_with"]["firmware"] == "klipper"
    assert r["compared_with"]["residual_at_design"] == pytest.approx(0.0, abs=1e-14)
    assert not r["compared_with"]["same"]
    ref = cli.json("shaper", "show", "--type", "mzv", "--freq-hz", "40", "--damping-ratio", "0.1",
                   "--firmware", "marlin", "--marlin-sample-rate-hz", "0", "--json")
    assert r == ref
    # On Marlin's 1 kHz grid (its default) the echoes are whole milliseconds.
    g = amctl.shaper_show("mzv", f, z, firmware="marlin")
    assert g["times_s"] == pytest.approx([0.0, 0.009, 0.018], abs=1e-15)
    assert g["sample_rate_hz"] == 1000.0


def test_firmware_that_lacks_the_type_is_refused():
    with pytest.raises(amctl.Error, match="marlin offers zv, zvd, zvdd"):
        amctl.shaper_show("zvdd", 40.0, 0.1, firmware="klipper")
    with pytest.raises(amctl.Error, match="found 'prusa', expected klipper or marlin"):
        amctl.shaper_show("zv", 40.0, 0.1, firmware="prusa")


def test_simulate_applies_the_firmware_asked_for(source_dir):
    # The corner file with an M593 (Marlin's stepper ZV); shaper_firmware='marlin' puts its
    # impulse times on FT_MOTION's 1 kHz grid, and the same with the CLI flag.
    g = str(source_dir / "tests/simulation/m593_corner.gcode")
    plain = amctl.simulate(g, natural_frequency_hz=40.0, damping_ratio=0.05)
    assert plain["shaper"]["x"]["firmware"] == "marlin"
    assert plain["shaper"]["x"]["marlin_sample_rate_hz"] is None
    grid = amctl.simulate(g, natural_frequency_hz=40.0, damping_ratio=0.05, shaper_firmware="marlin")
    assert grid["shaper"]["x"]["marlin_sample_rate_hz"] == 1000.0
    d = grid["shaper"]["x"]["duration_s"]
    assert abs(d * 1000.0 - round(d * 1000.0)) < 1e-9  # whole milliseconds
    with pytest.raises(amctl.Error, match="shaper_firmware: found 'rrf'"):
        amctl.simulate(g, natural_frequency_hz=40.0, shaper_firmware="rrf")
