"""amctl.simulate: seed 000's corner against its closed forms and scipy reference, the
samples arrays, and agreement with `amctl simulate --json` / `--csv`."""

import math
import threading
import time

import numpy as np
import pytest

import amctl

CORNER = "examples/30_belt_corner.gcode"
SEED_CFG = "examples/30_belt_corner_printer.cfg"
BOXBOSS = "examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode"
F_SEED = 100.0 / (2 * math.pi)  # seed 000: w = 100 rad/s, zeta = 0.5


@pytest.fixture
def corner(source_dir):
    return str(source_dir / CORNER), str(source_dir / SEED_CFG)


def _without_compute_time(d):
    return {k: v for k, v in d.items() if k != "compute_time_s"}


def test_seed_corner_matches_the_closed_form_and_the_scipy_reference(corner):
    path, cfg = corner
    r = amctl.simulate(path, machine=cfg, natural_frequency_hz=F_SEED, damping_ratio=0.5)
    assert r["motion_time_s"] == pytest.approx(0.24, abs=1e-12)  # two 10 mm moves, rest to rest
    # tests/reference/dynamics_reference.py (scipy): 0.463612915 mm past the corner; sampled
    # at 1 kHz the maximum is found within 1e-3 mm.
    assert r["max_corner_overshoot_mm"] == pytest.approx(0.463612915, abs=1e-3)
    assert r["max_contour_error_mm"] == pytest.approx(0.463612915, abs=1e-3)
    assert 0 < r["rms_contour_error_mm"] < r["max_contour_error_mm"]
    assert r["corners"] == 1


def test_a_rigid_axis_follows_the_command_exactly(corner):
    path, cfg = corner
    rigid = amctl.AxisModel.rigid()
    r = amctl.simulate(path, machine=cfg, model_x=rigid, model_y=rigid, samples=True)
    s = r["trace"]
    assert r["max_contour_error_mm"] == pytest.approx(0.0, abs=1e-12)  # distance rounding only
    assert np.array_equal(s["sim_x_mm"], s["cmd_x_mm"])
    assert np.array_equal(s["sim_y_mm"], s["cmd_y_mm"])


def test_samples_are_the_measured_samples(corner):
    path, cfg = corner
    r = amctl.simulate(path, machine=cfg, natural_frequency_hz=40, damping_ratio=0.1, samples=True)
    s = r["trace"]
    assert set(s) == {"t_s", "cmd_x_mm", "cmd_y_mm", "cmd_z_mm", "sim_x_mm", "sim_y_mm",
                      "contour_error_mm", "vibration_mm", "line"}
    n = s["t_s"].size
    assert all(a.shape == (n,) for a in s.values())
    assert n == r["samples"]  # every measured sample (the metrics' count)
    plain = amctl.simulate(path, machine=cfg, natural_frequency_hz=40, damping_ratio=0.1)
    assert "trace" not in plain
    assert _without_compute_time(plain) == {k: v for k, v in _without_compute_time(r).items() if k != "trace"}
    assert np.allclose(np.diff(s["t_s"]), 1e-3, rtol=0, atol=1e-12)  # 1 kHz
    assert s["contour_error_mm"].max() == r["max_contour_error_mm"]
    assert math.sqrt(np.mean(s["contour_error_mm"] ** 2)) == pytest.approx(r["rms_contour_error_mm"], rel=1e-9)
    # the command ends where the G-code does: (10, 10)
    assert (s["cmd_x_mm"][-1], s["cmd_y_mm"][-1]) == pytest.approx((10.0, 10.0), abs=1e-12)
    assert set(np.unique(s["line"])) <= {2, 3, 4, 5}
    # the arrays own their memory through the binding's buffer: no copy was made
    assert not s["t_s"].flags["OWNDATA"] and s["t_s"].base is not None

    ten = amctl.simulate(path, machine=cfg, natural_frequency_hz=40, samples=True, samples_rate_hz=100)
    assert np.array_equal(ten["trace"]["t_s"], s["t_s"][::10])


def test_samples_agree_with_the_cli_csv(cli, corner, tmp_path):
    path, cfg = corner
    csv = tmp_path / "sim.csv"
    cli("simulate", path, "--machine", cfg, "--natural-frequency-hz", 40, "--csv", csv)
    want = np.genfromtxt(csv, delimiter=",", names=True)
    s = amctl.simulate(path, machine=cfg, natural_frequency_hz=40, samples=True)["trace"]
    assert len(want) == len(s["t_s"])
    for name in ("t_s", "cmd_x_mm", "cmd_y_mm", "sim_x_mm", "sim_y_mm"):  # written as %.6f
        assert np.allclose(s[name], want[name], rtol=0, atol=5.1e-7), name
    assert np.allclose(s["contour_error_mm"], want["contour_error_mm"], rtol=1e-5, atol=1e-12)
    assert np.array_equal(s["line"], want["line"].astype(np.uint64))


@pytest.mark.parametrize("case", [
    (CORNER, SEED_CFG, ["--natural-frequency-hz", "15.915494309189533", "--damping-ratio", "0.5"],
     dict(natural_frequency_hz=15.915494309189533, damping_ratio=0.5)),
    (CORNER, SEED_CFG, ["--mode", "40,0.05", "--mode", "95,0.1,0.3", "--profile", "scurve7", "--jerk", "1e6"],
     dict(modes=[(40, 0.05), (95, 0.1, 0.3)], profile="scurve7", jerk_mm_s3=1e6)),
    (CORNER, SEED_CFG, ["--natural-frequency-hz", "40", "--profile", "scurve7", "--jerk", "2e5"],
     dict(natural_frequency_hz=40, profile="scurve7", jerk=2e5)),
    (BOXBOSS, "voron24", ["--natural-frequency-hz", "40", "--natural-frequency-y-hz", "55",
                          "--layer-begin", "2", "--layer-end", "4", "--worst", "3"],
     dict(natural_frequency_hz=40, natural_frequency_y_hz=55, layer_begin=2, layer_end=4, worst=3)),
    (BOXBOSS, "voron24", ["--mass-kg", "0.5", "--stiffness-n-per-m", "40000", "--motor-space",
                          "--sample-rate-hz", "2000", "--t-begin", "10", "--t-end", "60"],
     dict(mass_kg=0.5, stiffness_n_per_m=40000, motor_space=True, sample_rate_hz=2000,
          t_begin=10, t_end=60)),
])
def test_python_and_cli_agree_on_every_key(cli, source_dir, case):
    file, spec, flags, kw = case
    path = str(source_dir / file)
    spec = str(source_dir / spec) if "/" in spec else spec
    want = cli.json("simulate", path, "--machine", spec, *flags, "--json")
    got = amctl.simulate(path, machine=spec, **kw)
    assert set(got) == set(want)
    assert _without_compute_time(got) == _without_compute_time(want)


def test_bad_values_and_types(corner):
    path, cfg = corner
    with pytest.raises(amctl.Error, match="damping_ratio must be"):
        amctl.simulate(path, machine=cfg, natural_frequency_hz=40, damping_ratio=-0.1)
    with pytest.raises(amctl.Error, match="Nyquist"):
        amctl.simulate(path, machine=cfg, natural_frequency_hz=100, sample_rate_hz=150)
    with pytest.raises(amctl.Error, match="empty range"):
        amctl.simulate(path, machine=cfg, natural_frequency_hz=40, layer_begin=5, layer_end=2)
    with pytest.raises(amctl.Error, match="natural_frequency_hz"):
        amctl.simulate(path, machine=cfg)
    with pytest.raises(amctl.Error, match="divide"):
        amctl.simulate(path, machine=cfg, natural_frequency_hz=40, samples=True, samples_rate_hz=300)
    with pytest.raises(TypeError, match="natural_frequency_hz"):
        amctl.simulate(path, machine=cfg, natural_frequency_hz="40")
    with pytest.raises(TypeError, match="samples"):
        amctl.simulate(path, machine=cfg, natural_frequency_hz=40, samples=1)
    with pytest.raises(TypeError, match="model_y"):
        amctl.simulate(path, machine=cfg, model_x=amctl.AxisModel.rigid())


def test_the_gil_is_released_while_simulating(source_dir):
    # A second Python thread keeps running while the C++ simulates: with the GIL held for
    # the whole call it could not take a single timestamp inside the call.
    path = str(source_dir / BOXBOSS)
    stamps, stop = [], threading.Event()

    def ticker():
        while not stop.is_set():
            stamps.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=ticker)
    t.start()
    time.sleep(0.01)
    t0 = time.perf_counter()
    amctl.simulate(path, machine="voron24", natural_frequency_hz=40, sample_rate_hz=4000)
    t1 = time.perf_counter()
    stop.set()
    t.join()
    inside = [s for s in stamps if t0 < s < t1]
    assert len(inside) >= 2, (len(inside), t1 - t0)  # a loaded CI machine may schedule it rarely


def test_shaped_simulation_equals_the_cli_and_follows_the_machine_config(source_dir, cli):
    # The bundled Voron config has [input_shaper] (mzv 90/75 Hz): without shaper arguments
    # Python applies it, as the CLI does; no_shaper=True is the plain run.
    g = str(source_dir / "examples/30_belt_corner.gcode")
    cfg = str(source_dir / "configs/klipper-voron-v0.cfg")
    def drop(d):  # every wall-clock time, at any depth
        if isinstance(d, dict):
            return {k: drop(v) for k, v in d.items() if k != "compute_time_s"}
        return [drop(v) for v in d] if isinstance(d, list) else d
    r = amctl.simulate(g, machine=cfg, natural_frequency_hz=40, damping_ratio=0.05)
    ref = cli.json("simulate", g, "--machine", cfg, "--natural-frequency-hz", "40",
                   "--damping-ratio", "0.05", "--json")
    assert "shaper" in r and r["shaper"]["x"]["freq_hz"] == 90.0
    assert drop(r) == drop(ref)
    plain = amctl.simulate(g, machine=cfg, natural_frequency_hz=40, damping_ratio=0.05, no_shaper=True)
    assert "shaper" not in plain
    assert plain["max_contour_error_mm"] == r["without_shaper"]["max_contour_error_mm"]
    # ZV at the belt's frequency removes the residual vibration (docs/dynamics.md section 7).
    zv = amctl.simulate(g, machine=cfg, natural_frequency_hz=40, damping_ratio=0.05,
                        shaper="zv", shaper_freq_hz=40, shaper_damping_ratio=0.05, samples=True)
    assert zv["final_residual_vibration_mm"] < 1e-9 < plain["final_residual_vibration_mm"]
    assert len(zv["trace"]["t_s"]) == zv["samples"]
    with pytest.raises(amctl.Error, match="shaper_freq_hz"):
        amctl.simulate(g, machine=cfg, natural_frequency_hz=40, shaper="mzv")
    with pytest.raises(amctl.Error, match="no_shaper"):
        amctl.simulate(g, machine=cfg, natural_frequency_hz=40, shaper="mzv", shaper_freq_hz=40,
                       no_shaper=True)
