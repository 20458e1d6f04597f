"""The Python API under bad input (docs/architecture.md, "Inputs and outputs"; docs/macros.md,
"Limits"; docs/machine.md, "Physical ranges"): every case raises amctl.Error naming where,
never crashes the interpreter, never hangs, never writes over an input or leaves a partial
file. The same rules as the command line (tests/cli/bad_inputs.py), through the same code."""

import json
import os
import stat
import subprocess
import sys
import threading

import pytest

import amctl
from amctl import fleet

GOOD = "G28\nG90\nM82\nG1 X10 Y10 F6000\nG1 X20 E1\nG1 Y20 E2\n"
CFG = "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
TINY = "0." + "0" * 310 + "1"


@pytest.fixture
def gfile(tmp_path):
    p = tmp_path / "f.gcode"
    p.write_text(GOOD)
    return p


def macro_machine(tmp_path, body):
    p = tmp_path / "p.cfg"
    p.write_text(CFG + "[gcode_macro FOO]\ngcode:\n  G4 P0\n  " + body + "\n")
    return amctl.Machine.load(p)


@pytest.mark.parametrize("body", [
    "{ 1" + "|abs" * 5000 + " }",
    "{ printer" + ".a" * 5000 + " }",
    "{ 1" + " + 1" * 5000 + " }",
    "{ " + "(" * 5000 + "1" + ")" * 5000 + " }",
], ids=["filters", "attributes", "plus", "parentheses"])
def test_a_long_chain_in_a_macro_is_an_error_not_a_crash(tmp_path, body):
    # In the same interpreter: a stack overflow would take pytest down with it.
    g = tmp_path / "f.gcode"
    g.write_text("G28\n")
    with pytest.raises(amctl.Error) as e:
        amctl.estimate(g, macro_machine(tmp_path, body))
    assert e.value.file.endswith("p.cfg") and e.value.line == 8
    assert "nesting limit" in str(e.value)


@pytest.mark.parametrize("body,words", [
    ("{% set ns = namespace(s='x') %}{% for i in range(64) %}{% set ns.s = ns.s ~ ns.s %}{% endfor %}",
     "string limit"),
    ("{% set ns = namespace(l=[1]) %}{% for i in range(90) %}{% set ns.l = [ns.l, ns.l] %}{% endfor %}{ ns.l }",
     "value limit"),
    ("{ range(-9223372036854775807, 9223372036854775807)|length }", "range limit"),
], ids=["string", "shared_list", "range"])
def test_macro_memory_bounds_are_errors_at_the_macros_line(tmp_path, body, words):
    m = macro_machine(tmp_path, body)
    g = tmp_path / "f.gcode"
    g.write_text("G28\nFOO\n")
    with pytest.raises(amctl.Error) as e:
        amctl.estimate(g, m)
    assert e.value.file.endswith("p.cfg") and e.value.line == 8
    assert words in str(e.value)


def test_a_fan_out_of_macro_calls_stops(tmp_path):
    cfg = CFG + "".join(f"[gcode_macro FAN{i}]\ngcode:\n  FAN{i + 1}\n  FAN{i + 1}\n" for i in range(40))
    cfg += "[gcode_macro FAN40]\ngcode:\n  G4 P0\n"
    (tmp_path / "p.cfg").write_text(cfg)
    (tmp_path / "f.gcode").write_text("FAN0\n")
    with pytest.raises(amctl.Error) as e:
        amctl.estimate(tmp_path / "f.gcode", amctl.Machine.load(tmp_path / "p.cfg"))
    assert "expansion limit" in str(e.value) and e.value.file.endswith("p.cfg")


@pytest.mark.parametrize("line,col", [
    (f"G1 X10 F{TINY}", 8), (f"M204 S{TINY}", 6), ("SET_VELOCITY_LIMIT VELOCITY=1e-300", 20),
    (f"M220 S{TINY}", 6), (f"M203 X{TINY}", 6), ("SET_GCODE_OFFSET Z=1 MOVE=1 MOVE_SPEED=1e-300", 18),
    (f"M207 S1 F{TINY}", 9),
], ids=["F", "M204", "SET_VELOCITY_LIMIT", "M220", "M203", "SET_GCODE_OFFSET", "M207"])
def test_positive_values_no_machine_has_are_refused(tmp_path, line, col):
    g = tmp_path / "f.gcode"
    g.write_text(f"G28\n{line}\nG1 X20 Y20\n")
    with pytest.raises(amctl.Error) as e:
        amctl.estimate(g)
    assert (e.value.line, e.value.column) == (2, col)


def test_tiny_machine_limits_are_refused():
    with pytest.raises(amctl.Error):
        amctl.Machine.load(None, set={"printer.max_velocity": 1e-300})
    with pytest.raises(amctl.Error):
        amctl.Machine.load(None, set={"printer.max_accel": 1e-300})


def test_a_directory_or_a_missing_file_is_an_error_naming_it(tmp_path):
    d = tmp_path / "d.gcode"
    d.mkdir()
    for call in (lambda p: amctl.estimate(p), lambda p: amctl.simulate(p, natural_frequency_hz=40),
                 lambda p: amctl.plan(p)):
        with pytest.raises(amctl.Error) as e:
            call(d)
        assert e.value.file == str(d) and "directory" in str(e.value)
        with pytest.raises(amctl.Error) as e:
            call(tmp_path / "none.gcode")
        assert e.value.file == str(tmp_path / "none.gcode")


def test_cr_only_line_ends_are_lines(tmp_path):
    g = tmp_path / "cr.gcode"
    g.write_text(GOOD.replace("\n", "\r"), newline="")
    r = amctl.estimate(g)
    lf = tmp_path / "lf.gcode"
    lf.write_text(GOOD)
    assert r["moves"] == amctl.estimate(lf)["moves"] == 3
    assert r["total_time_s"] == amctl.estimate(lf)["total_time_s"]


def test_a_fifo_is_read_once_by_simulate(tmp_path):
    # simulate reads the file twice (M593 before the first move, then the print): a FIFO
    # can be read only once; the second pass reads the reader's own copy.
    fifo = tmp_path / "in.fifo"
    os.mkfifo(fifo)
    writer = threading.Thread(target=lambda: fifo.write_text(GOOD))
    writer.start()
    r = amctl.simulate(fifo, natural_frequency_hz=40)
    writer.join()
    assert r["moves"] == 3


def test_outputs_never_replace_the_input_or_a_device(tmp_path, gfile):
    before = gfile.read_text()
    with pytest.raises(amctl.Error) as e:
        amctl.report(gfile, output=gfile)
    assert "input" in str(e.value)
    with pytest.raises(amctl.Error):
        amctl.compensate(gfile, natural_frequency_hz=40, csv=gfile)
    assert gfile.read_text() == before
    fifo = tmp_path / "out.fifo"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()))
    reader.start()
    cfg = tmp_path / "s.cfg"
    cfg.write_text(CFG + "".join(f"[{n}]\nrotation_distance: {r}\nmicrosteps: 16\nposition_max: 200\n"
                                 for n, r in (("stepper_x", 40), ("stepper_y", 40), ("stepper_z", 8))) +
                   "[extruder]\nrotation_distance: 33.5\nmicrosteps: 16\nnozzle_diameter: 0.4\n"
                   "filament_diameter: 1.75\n")
    amctl.steps(gfile, amctl.Machine.load(cfg), csv=fifo)
    reader.join()
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert got[0].startswith("stepper,time_s,direction\n")
    assert sorted(os.listdir(tmp_path)) == ["f.gcode", "out.fifo", "s.cfg"]  # no temporary left


def test_a_10_hz_record_gets_no_shaper_recommendation(tmp_path):
    a = tmp_path / "a.csv"
    a.write_text("#time,accel_x,accel_y,accel_z\n" +
                 "".join(f"{i / 10:.1f},{(i % 5) - 2},{(i % 3) - 1},9800\n" for i in range(3000)))
    with pytest.raises(amctl.Error) as e:
        amctl.resonance_calibrate(a, axis="x")
    assert "sampled at 10 Hz" in str(e.value)


def test_fleet_csv_to_a_bad_path_is_an_error_not_a_traceback(tmp_path, gfile):
    r = subprocess.run([sys.executable, "-m", "amctl.fleet", str(gfile), "--workers", "0",
                        "--csv", str(tmp_path / "no" / "such" / "dir" / "out.csv")],
                       capture_output=True, text=True, env=os.environ)
    assert r.returncode == 2
    assert r.stderr.startswith("amctl.fleet: error: ") and "Traceback" not in r.stderr
    r = subprocess.run([sys.executable, "-m", "amctl.fleet", str(gfile), "--workers", "0",
                        "--csv", str(tmp_path)], capture_output=True, text=True, env=os.environ)
    assert r.returncode == 2 and "directory" in r.stderr


def test_fleet_json_has_no_infinity(tmp_path, gfile):
    rows = fleet.run([str(gfile)], ["default"], workers=0)
    json.dumps(rows, allow_nan=False)


def test_messages_keep_what_follows_a_nul_byte(tmp_path):
    g = tmp_path / "f.gcode"
    g.write_bytes(b"G1 X10\nG1 X\x00Y\n")
    with pytest.raises(amctl.Error) as e:
        amctl.estimate(g)
    assert "x00Y' in G1" in str(e.value) and e.value.line == 2  # the text after the NUL is kept


# ---- round three: numbers that are no values, outputs over any input, plates ----
NOT_VALUES = [float("nan"), float("inf"), float("-inf"), 1e-320, 10 ** 400]


@pytest.mark.parametrize("value", NOT_VALUES, ids=["nan", "inf", "-inf", "subnormal", "int_beyond_a_double"])
@pytest.mark.parametrize("call,param", [
    (lambda g, v: amctl.plan(g, t_begin=v), "t_begin"),
    (lambda g, v: amctl.plan(g, t_end=v), "t_end"),
    (lambda g, v: amctl.simulate(g, natural_frequency_hz=v), "natural_frequency_hz"),
    (lambda g, v: amctl.simulate(g, natural_frequency_hz=40, shaper_damping_ratio=v), "shaper_damping_ratio"),
    (lambda g, v: amctl.report(g, sample_rate_hz=v), "sample_rate_hz"),
    (lambda g, v: amctl.report(g, damping_ratio=v), "damping_ratio"),
    (lambda g, v: amctl.compensate(g, natural_frequency_hz=v), "natural_frequency_hz"),
    (lambda g, v: amctl.hotend(core_to_block_w_k=v), "core_to_block_w_k"),
    (lambda g, v: amctl.bed(noise_k=v), "noise_k"),
    (lambda g, v: amctl.sls_margins(kp=v), "kp"),
    (lambda g, v: amctl.shaper_show("mzv", v), "freq_hz"),
    (lambda g, v: amctl.write_m73(g, str(g) + ".m73", interval_s=v), "interval_s"),
], ids=["plan_t_begin", "plan_t_end", "simulate_f", "simulate_shaper_damping", "report_rate", "report_zeta",
        "compensate_f", "hotend_core", "bed_noise", "sls_margins_kp", "shaper_show_f", "write_m73_interval"])
def test_numbers_that_are_no_values_are_errors_naming_the_parameter(gfile, call, param, value):
    # Whether the function would use the value or not (a flag of a model not asked for).
    with pytest.raises(amctl.Error) as e:
        call(gfile, value)
    assert param in str(e.value) and "expected a finite number" in str(e.value)
    assert sorted(os.listdir(gfile.parent)) == ["f.gcode"]


@pytest.mark.parametrize("value", [None, "1", [1.0], b"1", True], ids=["None", "str", "list", "bytes", "bool"])
def test_wrong_types_are_type_errors_naming_the_parameter(gfile, value):
    with pytest.raises(TypeError) as e:
        amctl.plan(gfile, t_begin=value) if value is not None else amctl.shaper_show("mzv", value)
    assert ("t_begin" if value is not None else "freq_hz") in str(e.value)


def test_write_m73_on_a_plate_of_a_3mf_writes_its_text(tmp_path):
    # An expert names the plate and gets that plate's G-code with M73 lines, as text (a printer
    # reads text; rewriting the archive would change a project file the slicer owns).
    sys.path.insert(0, os.path.join(os.environ.get("AMCTL_SOURCE_DIR", "."), "tests", "reference"))
    import make_3mf
    plate2 = (GOOD * 3).encode()
    p = tmp_path / "p.gcode.3mf"
    p.write_bytes(make_3mf.sliced_3mf([GOOD.encode(), plate2]))
    before = p.read_bytes()
    out = tmp_path / "plate2.gcode"
    n = amctl.write_m73(f"{p}/Metadata/plate_2.gcode", out)
    text = out.read_text()
    lines = [ln for ln in text.splitlines() if not ln.startswith("M73 ")]
    assert lines == plate2.decode().splitlines()  # the plate's own lines, in order, nothing else
    assert text.splitlines()[-1] == "M73 P100 R0" and n["lines"] == text.count("M73 ")
    assert p.read_bytes() == before
    r = subprocess.run([os.environ.get("AMCTL_CLI", "amctl"), "estimate", f"{p}/Metadata/plate_2.gcode",
                        "--write-m73", str(tmp_path / "cli.gcode")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "cli.gcode").read_text() == text


def test_fleet_csv_never_replaces_what_it_reads(tmp_path, gfile):
    cfg = tmp_path / "p.cfg"
    cfg.write_text(CFG)
    for target in (gfile, cfg):
        before = target.read_bytes()
        r = subprocess.run([sys.executable, "-m", "amctl.fleet", str(gfile), "-m", str(cfg), "--workers", "0",
                            "--csv", str(target)], capture_output=True, text=True, env=os.environ)
        assert r.returncode == 2 and "is an input" in r.stderr and "Traceback" not in r.stderr, r.stderr
        assert target.read_bytes() == before


@pytest.mark.skipif(os.geteuid() != 0 and not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_fleet_csv_on_a_full_disk_and_read_only(tmp_path, gfile):
    r = subprocess.run([sys.executable, "-m", "amctl.fleet", str(gfile), "--workers", "0", "--csv", "/dev/full"],
                       capture_output=True, text=True, env=os.environ)
    assert r.returncode == 2 and "No space left" in r.stderr and "Traceback" not in r.stderr
    ro = tmp_path / "ro.csv"
    ro.write_text("keep\n")
    ro.chmod(0o444)
    r = subprocess.run([sys.executable, "-m", "amctl.fleet", str(gfile), "--workers", "0", "--csv", str(ro)],
                       capture_output=True, text=True, env=os.environ)
    assert r.returncode == 2 and "read-only" in r.stderr and ro.read_text() == "keep\n"


# ---- round four: one set of checks for the command line and Python (thermal, shaper show),
# the bed mesh, SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE and the SLS 3D configuration.

@pytest.mark.parametrize("fn,kwargs,name", [
    (amctl.hotend, {"power_w": 1e19}, "power_w"),
    (amctl.hotend, {"power_w": 1.0}, "power_w"),  # cannot reach the target
    (amctl.hotend, {"capacity_j_k": 1e19}, "capacity_j_k"),
    (amctl.hotend, {"loss_w_k": 1e308}, "loss_w_k"),
    (amctl.hotend, {"fan_loss_w_k": 1e19}, "fan_loss_w_k"),
    (amctl.hotend, {"sensor_tau_s": 1e-300}, "sensor_tau_s"),
    (amctl.hotend, {"sensor_delay_s": 1e308}, "sensor_delay_s"),
    (amctl.hotend, {"core_capacity_j_k": 1e19}, "core_capacity_j_k"),
    (amctl.hotend, {"target_c": 1e19}, "target_c"),
    (amctl.hotend, {"target_c": 30.0}, "target_c"),  # not 20 K above ambient
    (amctl.hotend, {"noise_k": 1e308}, "noise_k"),
    (amctl.hotend, {"cycles": 2}, "cycles"),
    (amctl.bed, {"target_c": 1e308}, "target_c"),
    (amctl.bed, {"capacity_j_k": 1e19}, "capacity_j_k"),
    (amctl.sls_margins, {"kp_w_m2k": 1e19}, "kp_w_m2k"),
    (amctl.sls_margins, {"ti_s": 1e308}, "ti_s"),
    (amctl.sls_margins, {"length_mm": 1e19}, "length_mm"),
    (amctl.sls_margins, {"density_kg_m3": 1e308}, "density_kg_m3"),
    (amctl.sls_margins, {"specific_heat_j_kgk": 1e19}, "specific_heat_j_kgk"),
    (amctl.sls_margins, {"conductivity_w_mk": 1e308}, "conductivity_w_mk"),
    (amctl.sls_margins, {"beta_1_s": 0.5}, "beta_1_s"),
    (amctl.sls_margins, {"modes": 0}, "modes"),
    (amctl.sls_build, {"layers": -1}, "layers"),
    (amctl.sls_build, {"layers": 10 ** 6}, "layers"),
    (amctl.shaper_show, {"type": "zv", "freq_hz": 1e-300}, "freq_hz"),
    (amctl.shaper_show, {"type": "zv", "freq_hz": 40, "damping_ratio": 1.0}, "damping_ratio"),
    (amctl.shaper_show, {"type": "zv", "freq_hz": 40, "residual_at_hz": [1e19]}, "residual_at_hz"),
    (amctl.shaper_show, {"type": "zv", "freq_hz": 40, "test_damping_ratio": -0.1}, "test_damping_ratio"),
    (amctl.shaper_show, {"type": "zv", "freq_hz": 40, "firmware": "marlin", "marlin_sample_rate_hz": 1e308},
     "marlin_sample_rate_hz"),
    (amctl.shaper_show, {"type": "zv", "freq_hz": 40, "firmware": "marlin", "marlin_sample_rate_hz": 10},
     "freq_hz"),
    (amctl.shaper_show, {"type": "zvdd", "freq_hz": 40, "firmware": "klipper"}, "type"),
], ids=lambda v: v if isinstance(v, str) else None)
def test_the_command_lines_ranges_hold_in_python(fn, kwargs, name):
    # The same checks as `amctl thermal ...` / `amctl shaper show` (one C++ function), the
    # parameter named by its keyword.
    with pytest.raises(amctl.Error) as e:
        fn(**kwargs)
    assert str(e.value).startswith(name + ": "), str(e.value)


def test_a_marlin_shaper_of_high_damping_finishes():
    # max_accel's bisection never ended once its bounds were 1e8 apart by less than 1e-8.
    r = amctl.shaper_show("zv", 40, 0.99, firmware="marlin")
    assert r["max_accel_mm_s2"] > 0


MESH_CFG = (CFG + "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 200\n"
            "[stepper_y]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 200\n"
            "[stepper_z]\nrotation_distance: 8\nmicrosteps: 16\nposition_max: 200\n"
            "[bed_mesh]\nmesh_min: 10, 10\nmesh_max: 190, 190\n"
            "#*# <---------------------- SAVE_CONFIG ---------------------->\n"
            "#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n"
            "#*# [bed_mesh default]\n#*# version = 1\n#*# points =\n"
            "#*# \t  0.01, -0.02, 0.03\n#*# \t  0.0, 0.015, -0.01\n#*# \t  0.02, 0.005, 0.0\n"
            "#*# min_x = 10.0\n#*# max_x = 190.0\n#*# min_y = 10.0\n#*# max_y = 190.0\n"
            "#*# x_count = 3\n#*# y_count = 3\n#*# mesh_x_pps = PPS\n#*# mesh_y_pps = PPS\n"
            "#*# algo = lagrange\n#*# tension = 0.2\n")


def test_a_bed_mesh_too_large_to_upsample_is_an_error_before_allocating(tmp_path):
    p = tmp_path / "p.cfg"
    p.write_text(MESH_CFG.replace("PPS", "1500"))
    g = tmp_path / "f.gcode"
    g.write_text("SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nBED_MESH_PROFILE LOAD=default\nG1 X100 Y100 Z0.2 F6000\n")
    with pytest.raises(amctl.Error) as e:
        amctl.estimate(g, p)
    assert e.value.file.endswith("p.cfg") and e.value.line == 36 and e.value.column == 18
    assert "expected at most 4096 along an axis" in str(e.value)
    p.write_text(MESH_CFG.replace("PPS", "2"))
    assert amctl.estimate(g, p)["moves"] >= 1


@pytest.mark.parametrize("line,col", [
    ("SET_INPUT_SHAPER SHAPER_FREQ_X=1e-300", 32),
    ("SET_PRESSURE_ADVANCE ADVANCE=1e6", 30),
    ("BED_MESH_OFFSET X=1e10", 19),
])
def test_step_tuning_and_mesh_commands_out_of_range_name_their_place(tmp_path, line, col):
    p = tmp_path / "p.cfg"
    p.write_text(MESH_CFG.replace("PPS", "2").replace(
        "[bed_mesh]", "[extruder]\nrotation_distance: 33.5\nmicrosteps: 16\nnozzle_diameter: 0.4\n"
        "filament_diameter: 1.75\n[input_shaper]\nshaper_freq_x: 40\nshaper_freq_y: 40\n[bed_mesh]"))
    g = tmp_path / "f.gcode"
    g.write_text(GOOD + line + "\nG1 X30 E3\n")
    with pytest.raises(amctl.Error) as e:
        amctl.steps(g, p)
    assert e.value.file.endswith("f.gcode") and e.value.line == 7 and e.value.column == col


def test_an_empty_sls3d_configuration_is_an_error(tmp_path):
    c = tmp_path / "s.toml"
    c.write_text("# nothing here yet\n")
    with pytest.raises(amctl.Error) as e:
        amctl.sls3d(c)
    assert "found no section" in str(e.value)
