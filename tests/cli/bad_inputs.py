#!/usr/bin/env python3
"""Every bad input gets exit code 2, one message on stderr naming where it is and what was
expected, and leaves no output file behind (docs/testing.md, "Bad input").

Each row of CASES is a command run by the real amctl binary in a fresh directory holding
the row's files. The first line of stderr must be

    amctl: error: WHERE: MESSAGE

where WHERE is the row's `where` exactly (FILE:LINE[:COL] for a file, the flag for a
command-line value) and MESSAGE says what was found and what was expected ("found X, expected Y"
or "must be Y, got X"). Every path in `outputs` must not exist afterwards, nor any other
new file.

usage: bad_inputs.py AMCTL [-k SUBSTRING]
"""
import os
import re
import struct
import subprocess
import sys
import tempfile
import zlib

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reference"))
import bgcode_writer  # noqa: E402  (binary G-code written from the specification)
import make_3mf  # noqa: E402  (sliced 3MF archives written with zipfile)

GOOD_GCODE = "G28\nG90\nM82\nG1 X10 Y10 F6000\nG1 X20 E1\nG1 Y20 E2\n"
GOOD_TOML = '[printer]\nname = "t"\nmax_velocity = 300\nmax_accel = 3000\n'
GOOD_CFG = "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
STEPPER_CFG = GOOD_CFG + "".join(
    f"[{s}]\nrotation_distance: {r}\nmicrosteps: 16\nposition_max: 200\n"
    for s, r in (("stepper_x", 40), ("stepper_y", 40), ("stepper_z", 8))) + (
    "[extruder]\nrotation_distance: 33.5\nmicrosteps: 16\nnozzle_diameter: 0.4\n"
    "filament_diameter: 1.75\n")
RAW_HEADER = "#time,accel_x,accel_y,accel_z\n"
RAW_ROWS = "".join(f"{i / 1000:.3f},{(i % 5) - 2},{(i % 3) - 1},9800\n" for i in range(2000))
CUBE_FACET = ("facet normal 0 0 -1\n outer loop\n  vertex 0 0 0\n  vertex 0 1 0\n"
              "  vertex 1 0 0\n endloop\nendfacet\n")


def latin1(data):
    return data.decode("latin-1")


def bgcode(text, compression="deflate", encoding="text"):
    return bgcode_writer.write_bgcode(text, compression, encoding)[0]


def first_gcode_block(data):
    """(offset, header bytes, parameter bytes, stored bytes) of the first G-code block."""
    at = 10
    while True:
        btype, comp, size = struct.unpack_from("<HHI", data, at)
        header = 8 if comp == 0 else 12
        stored = size if comp == 0 else struct.unpack_from("<I", data, at + 8)[0]
        params = 6 if btype == 5 else 2
        if btype == 1:
            return at, header, params, stored
        at += header + params + stored + 4


def bgcode_damaged_byte(text):
    b = bytearray(bgcode(text))
    at, header, params, stored = first_gcode_block(b)
    b[at + header + params + stored // 2] ^= 0x20
    return bytes(b), at


def bgcode_first_block_type(text, btype):
    b = bytearray(bgcode(text))
    struct.pack_into("<H", b, 10, btype)
    return bytes(b)


def bgcode_cut(text):
    b = bgcode(text)
    at, header, params, stored = first_gcode_block(b)
    return b[:at + header + params + stored // 2]


GZIP_HALF = zlib.compressobj(6, zlib.DEFLATED, 31)
GZIP_HALF = (GZIP_HALF.compress(("G1 X10 Y10 F6000\n" * 2000).encode()) + GZIP_HALF.flush())
GZIP_HALF = GZIP_HALF[:len(GZIP_HALF) // 2]
M503 = ("echo:  M92 X80.00 Y80.00 Z400.00 E93.00\necho:  M203 X500.00 Y500.00 Z5.00 E25.00\n"
        "echo:  M201 X500.00 Y500.00 Z100.00 E5000.00\necho:  M204 P500.00 R500.00 T500.00\n"
        "echo:  M205 B20000.00 S0.00 T0.00 J0.08\n")
CONFIGURATION_H = ("#pragma once\n#define DEFAULT_AXIS_STEPS_PER_UNIT   { 80, 80, 400, 93 }\n"
                   "#define DEFAULT_MAX_FEEDRATE          { 500, 500, 5, 25 }\n"
                   "#define DEFAULT_MAX_ACCELERATION      { 500, 500, 100, 5000 }\n"
                   "#define DEFAULT_ACCELERATION          500\n")
CUBE_STL = "solid t\n" + ("facet normal 0 0 -1\n outer loop\n  vertex 0 0 0\n  vertex 0 1 0\n"
                          "  vertex 1 0 0\n endloop\nendfacet\n") + "endsolid t\n"

SLS3D_ARGS = ["thermal", "sls3d", "--config", "s.toml", "--vtu-dir", "vtu", "--report", "out.html", "--csv", "out.csv"]
SLS3D_OUTPUTS = ["vtu", "out.html", "out.csv"]


def case(name, args, files, where, outputs=(), dirs=(), links=None, modes=None):
    """`dirs`: directories to make; `links`: {link: target} symbolic links to make; `modes`:
    {file: mode} permissions to set on files of `files` (0o444: read-only)."""
    return {"name": name, "args": args, "files": files, "where": where, "outputs": outputs,
            "dirs": tuple(dirs), "links": dict(links or {}), "modes": dict(modes or {})}


CASES = [
    # ---- G-code (estimate and the commands that write a file) ----
    case("gcode_word_without_number", ["estimate", "f.gcode"],
         {"f.gcode": "G1 X10\nG1 Xabc\n"}, "f.gcode:2:5"),
    case("gcode_nan_coordinate", ["estimate", "f.gcode"],
         {"f.gcode": "G1 X10\nG1 Ynan\n"}, "f.gcode:2:5"),
    case("gcode_two_decimal_points", ["estimate", "f.gcode"],
         {"f.gcode": "G90\nG1 X1.2.3\n"}, "f.gcode:2:8"),
    case("gcode_double_sign", ["estimate", "f.gcode"],
         {"f.gcode": "G1 X--5\n"}, "f.gcode:1:5"),
    case("gcode_negative_feedrate", ["estimate", "f.gcode"],
         {"f.gcode": "G1 X10\nG1 X20 F-100\n"}, "f.gcode:2:8"),
    case("gcode_checksum_mismatch", ["estimate", "f.gcode"],
         {"f.gcode": "N1 G1 X10*99\n"}, "f.gcode:1:10"),
    case("gcode_negative_velocity_limit", ["estimate", "f.gcode"],
         {"f.gcode": "G1 X1\nSET_VELOCITY_LIMIT ACCEL=-5\n"}, "f.gcode:2:20"),
    case("gcode_negative_m204", ["estimate", "f.gcode"],
         {"f.gcode": "G1 X1\n\nM204 S-100\n"}, "f.gcode:3:6"),
    case("gcode_negative_dwell", ["estimate", "f.gcode"],
         {"f.gcode": "G4 P-1\n"}, "f.gcode:1:4"),
    case("gcode_coordinate_beyond_1e9_mm", ["estimate", "f.gcode"],
         {"f.gcode": "G1 X10000000000\n"}, "f.gcode:1:4"),
    case("gcode_arc_without_centre", ["estimate", "f.gcode"],
         {"f.gcode": "G1 X10 Y10\nG2 X20 Y10\n"}, "f.gcode:2:4"),
    case("gcode_binary_bytes", ["estimate", "f.gcode"],
         {"f.gcode": "G1 X10\nG1 X\x01\x02\n"}, "f.gcode:2:5"),
    case("gcode_truncated_word", ["estimate", "f.gcode"],
         {"f.gcode": GOOD_GCODE + "G1 X20 Y"}, "f.gcode:7:9"),
    case("m73_output_not_left_behind", ["estimate", "f.gcode", "--write-m73", "out.gcode"],
         {"f.gcode": GOOD_GCODE + "G1 Xq\n"}, "f.gcode:7:5", ["out.gcode"]),
    case("plan_csv_not_left_behind", ["plan", "f.gcode", "-o", "out.csv"],
         {"f.gcode": GOOD_GCODE + "G1 Xq\n"}, "f.gcode:7:5", ["out.csv"]),
    case("steps_csv_not_left_behind", ["steps", "f.gcode", "-m", "p.cfg", "--csv", "out.csv"],
         {"f.gcode": GOOD_GCODE + "G1 Xq\n", "p.cfg": STEPPER_CFG}, "f.gcode:7:5", ["out.csv"]),
    case("report_html_not_left_behind", ["report", "f.gcode", "-o", "out.html"],
         {"f.gcode": GOOD_GCODE + "G1 Xq\n"}, "f.gcode:7:5", ["out.html"]),
    case("simulate_csv_not_left_behind",
         ["simulate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "out.csv"],
         {"f.gcode": GOOD_GCODE + "G1 Xq\n"}, "f.gcode:7:5", ["out.csv"]),
    case("compensate_csv_not_left_behind",
         ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "out.csv"],
         {"f.gcode": GOOD_GCODE + "G1 Xq\n"}, "f.gcode:7:5", ["out.csv"]),
    # ---- amctl machine TOML ----
    case("toml_unknown_key", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": GOOD_TOML + "max_acel = 5\n"}, "m.toml:5:1"),
    case("toml_unknown_section", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": GOOD_TOML + "[bogus]\nx = 1\n"}, "m.toml:5:2"),
    case("toml_negative_limit", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": '[printer]\nmax_accel = -3000\n'}, "m.toml:2:13"),
    case("toml_nan_limit", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": '[printer]\nmax_velocity = nan\n'}, "m.toml:2:16"),
    case("toml_text_for_number", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": '[printer]\nmax_accel = "fast"\n'}, "m.toml:2:13"),
    case("toml_syntax_error", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": '[printer\nmax_accel = 3\n'}, "m.toml:1:9"),
    case("toml_truncated_string", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": '[printer]\nname = "abc'}, "m.toml:2:12"),
    case("toml_unknown_firmware", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": '[printer]\nfirmware = "repetier"\n'}, "m.toml:2:12"),
    case("toml_short_jerk_array", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": '[printer]\nfirmware = "marlin"\n[marlin]\njerk = [1, 2]\n'},
         "m.toml:4:8"),
    case("toml_negative_microsteps", ["machine", "show", "m.toml"],
         {"m.toml": '[stepper_x]\nmicrosteps = -16\n'}, "m.toml:2:14"),
    # ---- Klipper printer.cfg ----
    case("cfg_negative_accel", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG.replace("max_accel: 3000", "max_accel: -5")},
         "p.cfg:4:12"),
    case("cfg_malformed_number", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG.replace("max_accel: 3000", "max_accel: 3e")},
         "p.cfg:4:12"),
    case("cfg_nan_velocity", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG.replace("max_velocity: 300", "max_velocity: nan")},
         "p.cfg:3:15"),
    case("cfg_limited_axis_velocity_above_max", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE,
          "p.cfg": GOOD_CFG.replace("cartesian", "limited_cartesian") + "max_x_velocity: 400\n"},
         "p.cfg:5:17"),
    case("cfg_limited_scale_not_boolean", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE,
          "p.cfg": GOOD_CFG.replace("cartesian", "limited_corexy") + "scale_xy_accel: maybe\n"},
         "p.cfg:5:17"),
    case("cfg_unknown_kinematics", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG.replace("cartesian", "cartesianish")},
         "p.cfg:2:13"),
    case("cfg_option_before_section", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": "max_accel: 5\n" + GOOD_CFG}, "p.cfg:1:1"),
    case("cfg_line_without_colon", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG + "garbage\n"}, "p.cfg:5:1"),
    case("cfg_missing_include", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG + "[include nothere.cfg]\n"}, "p.cfg:5:1"),
    case("cfg_error_inside_include", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": "[include sub/x.cfg]\n" + GOOD_CFG,
          "sub/x.cfg": "[extruder]\nnozzle_diameter: -0.4\n"}, "sub/x.cfg:2:18"),
    case("cfg_recursive_include", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG + "[include p.cfg]\n"}, "p.cfg:5:1"),
    case("cfg_position_min_above_max", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE,
          "p.cfg": GOOD_CFG + "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\n"
                   "position_min: 50\nposition_max: 10\n"}, "p.cfg:9:15"),
    case("cfg_negative_run_current", ["stepper", "simulate", "--scenario", "seed003", "-m", "p.cfg"],
         {"p.cfg": GOOD_CFG + "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\n"
                   "[stepper_y]\nrotation_distance: 40\nmicrosteps: 16\n"
                   "[tmc2209 stepper_x]\nrun_current: -0.8\n"}, "p.cfg:12:14"),
    case("toml_negative_backlash", ["machine", "show", "m.toml"],
         {"m.toml": '[stepper_x]\nbacklash = -0.1\n'}, "m.toml:2:12"),
    # ---- closed-loop stepper simulation: refused before simulating, naming the limit ----
    case("stepper_unstable_gain", ["stepper", "simulate", "--scenario", "reversing-strokes",
                                   "--controller", "pid", "--kp", "20", "--csv", "out.csv"],
         {}, "--kp", ["out.csv"]),
    case("stepper_current_above_rating", ["stepper", "simulate", "--scenario",
                                          "reversing-strokes", "--run-current-a", "1.5"],
         {}, "--run-current-a"),
    case("stepper_boost_above_rating", ["stepper", "simulate", "--scenario", "reversing-strokes",
                                        "--controller", "feedforward", "--max-current-a", "2.5"],
         {}, "--max-current-a"),
    case("stepper_encoder_rate_above_ssi", ["stepper", "simulate", "--scenario",
                                            "reversing-strokes", "--controller", "pid",
                                            "--encoder-rate-hz", "60000"], {}, "--encoder-rate-hz"),
    case("stepper_encoder_rate_too_low", ["stepper", "simulate", "f.gcode", "--controller", "pid",
                                          "--encoder-rate-hz", "200", "--csv", "out.csv"],
         {"f.gcode": GOOD_GCODE}, "--encoder-rate-hz", ["out.csv"]),
    case("stepper_encoder_too_coarse", ["stepper", "simulate", "--scenario", "reversing-strokes",
                                        "--controller", "feedforward", "--encoder-resolution-um",
                                        "10"], {}, "--encoder-resolution-um"),
    case("stepper_unknown_motor", ["stepper", "simulate", "--scenario", "reversing-strokes", "-m",
                                   "m.toml"],
         {"m.toml": GOOD_TOML + '[stepper_x]\nmotor = "nema99"\n'}, "m.toml:6:9"),
    case("cfg_autotune_unknown_motor", ["machine", "show", "p.cfg"],
         {"p.cfg": GOOD_CFG + "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\n"
                   "[autotune_tmc stepper_x]\nmotor: nema99\n"}, "p.cfg:9:8"),
    # A controller's parameters the controller does not use, and non-physical values of the
    # ones it does (they ran silently before, 1e308 in a gain open loop ignores).
    case("stepper_open_unused_gain", ["stepper", "simulate", "--scenario", "reversing-strokes",
                                      "--controller", "open", "--kp", "1e308", "--csv", "out.csv"],
         {}, "--kp", ["out.csv"]),
    case("stepper_pid_unused_alpha", ["stepper", "simulate", "--scenario", "reversing-strokes",
                                      "--controller", "pid", "--alpha", "0.6"], {}, "--alpha"),
    case("stepper_open_unused_drag_gain", ["stepper", "simulate", "--scenario",
                                           "reversing-strokes", "--drag-gain", "1e308"],
         {}, "--drag-gain"),
    case("stepper_feedforward_drag_gain_overshoots", ["stepper", "simulate", "--scenario",
                                                      "reversing-strokes", "--controller",
                                                      "feedforward", "--drag-gain", "1e308"],
         {}, "--drag-gain"),
    case("stepper_feedforward_load_angle_past_pull_out", ["stepper", "simulate", "--scenario",
                                                          "reversing-strokes", "--controller",
                                                          "feedforward", "--load-angle-deg", "120"],
         {}, "--load-angle-deg"),
    case("stepper_pid_gain_1e308", ["stepper", "simulate", "--scenario", "reversing-strokes",
                                    "--controller", "pid", "--kp", "1e308"], {}, "--kp"),
    case("stepper_drag_1e308", ["stepper", "simulate", "--scenario", "reversing-strokes",
                                "--drag-n", "1e308"], {}, "--drag-n"),
    case("stepper_backlash_1e308", ["stepper", "simulate", "--scenario", "reversing-strokes",
                                    "--backlash-mm", "1e308"], {}, "--backlash-mm"),
    # ---- --set and other command-line values ----
    case("set_negative_limit", ["estimate", "f.gcode", "--set", "printer.max_accel=-1"],
         {"f.gcode": GOOD_GCODE}, "--set printer.max_accel=-1"),
    case("set_unknown_key", ["estimate", "f.gcode", "--set", "printer.max_acel=1"],
         {"f.gcode": GOOD_GCODE}, "--set printer.max_acel=1"),
    case("set_without_value", ["estimate", "f.gcode", "--set", "printer.max_accel"],
         {"f.gcode": GOOD_GCODE}, "--set printer.max_accel"),
    case("flag_not_a_number", ["estimate", "f.gcode", "--m73-interval", "abc"],
         {"f.gcode": GOOD_GCODE}, "--m73-interval"),
    case("flag_nan", ["estimate", "f.gcode", "--write-m73", "out.gcode", "--m73-interval", "nan"],
         {"f.gcode": GOOD_GCODE}, "--m73-interval", ["out.gcode"]),
    case("flag_unknown", ["estimate", "f.gcode", "--bogus"], {"f.gcode": GOOD_GCODE}, "--bogus"),
    case("flag_not_in_choices", ["estimate", "f.gcode", "--mode", "fast"],
         {"f.gcode": GOOD_GCODE}, "--mode"),
    case("flag_missing_required", ["resonance", "recommend", "--damping-ratio", "0.1"],
         {}, "--natural-frequency-hz"),
    case("flag_negative_damping", ["simulate", "f.gcode", "--natural-frequency-hz", "40",
                                   "--damping-ratio", "-1"], {"f.gcode": GOOD_GCODE},
         "--damping-ratio"),
    case("flag_zero_sample_rate", ["compensate", "f.gcode", "--natural-frequency-hz", "40",
                                   "--sample-rate-hz", "0", "--csv", "out.csv"],
         {"f.gcode": GOOD_GCODE}, "--sample-rate-hz", ["out.csv"]),
    case("flag_integer_expected", ["plan", "f.gcode", "--layer-begin", "1.5"],
         {"f.gcode": GOOD_GCODE}, "--layer-begin"),
    # ---- accelerometer CSV (resonance calibrate) ----
    case("accel_bad_header", ["resonance", "calibrate", "a.csv", "--axis", "x"],
         {"a.csv": "#t,ax,ay,az\n0,1,2,3\n"}, "a.csv:1"),
    case("accel_malformed_number", ["resonance", "calibrate", "a.csv", "--axis", "x"],
         {"a.csv": RAW_HEADER + "0.000,1,2,3\n0.001,1,abc,3\n"}, "a.csv:3"),
    case("accel_time_not_increasing", ["resonance", "calibrate", "a.csv", "--axis", "x"],
         {"a.csv": RAW_HEADER + "0.002,1,2,3\n0.001,1,2,3\n"}, "a.csv:3"),
    case("accel_truncated_row", ["resonance", "calibrate", "a.csv", "--axis", "y"],
         {"a.csv": RAW_HEADER + RAW_ROWS + "2.000,1,2"}, "a.csv:2002"),
    case("accel_nan_value", ["resonance", "calibrate", "a.csv", "--axis", "x"],
         {"a.csv": RAW_HEADER + "0.000,1,2,3\n0.001,nan,2,3\n"}, "a.csv:3"),
    case("accel_psd_not_left_behind",
         ["resonance", "calibrate", "a.csv", "--axis", "x", "--csv", "out.csv"],
         {"a.csv": RAW_HEADER + RAW_ROWS[:5000] + "x,1,2,3\n"}, "a.csv:{rows}", ["out.csv"]),
    # ---- process CSVs (shrink fit, calibrate-time) ----
    case("shrink_missing_column", ["shrink", "fit", "s.csv"],
         {"s.csv": "nominal_mm,measurd_mm\n10,10.1\n"}, "s.csv:1"),
    case("shrink_negative_nominal", ["shrink", "fit", "s.csv"],
         {"s.csv": "nominal_mm,measured_mm\n10,10.1\n-5,5\n20,20.2\n"}, "s.csv:3:1"),
    case("shrink_malformed_number", ["shrink", "fit", "s.csv"],
         {"s.csv": "nominal_mm,measured_mm\n10,10.1\n15,1.2.3\n20,20.2\n"}, "s.csv:3:4"),
    case("shrink_nan", ["shrink", "fit", "s.csv"],
         {"s.csv": "nominal_mm,measured_mm\n10,nan\n15,15.1\n20,20.2\n"}, "s.csv:2:4"),
    case("shrink_unterminated_quote", ["shrink", "fit", "s.csv"],
         {"s.csv": 'nominal_mm,measured_mm\n10,"10.1\n'}, "s.csv:2:4"),
    case("shrink_ragged_row", ["shrink", "fit", "s.csv"],
         {"s.csv": "nominal_mm,measured_mm\n10,10.1\n15\n20,20.2\n"}, "s.csv:3:1"),
    case("timings_negative_duration", ["calibrate-time", "t.csv"],
         {"t.csv": "gcode,duration_s\nf.gcode,-5\n", "f.gcode": GOOD_GCODE}, "t.csv:2:9"),
    case("timings_missing_gcode_column", ["calibrate-time", "t.csv"],
         {"t.csv": "file,duration_s\nf.gcode,5\n"}, "t.csv:1"),
    case("timings_save_not_left_behind", ["calibrate-time", "t.csv", "--save", "out.toml"],
         {"t.csv": "gcode,duration_s\nf.gcode,12\nf.gcode,abc\n", "f.gcode": GOOD_GCODE},
         "t.csv:3:9", ["out.toml"]),
    # ---- STL and the shrink model (shrink apply) ----
    case("stl_truncated", ["shrink", "apply", "--model", "m.stl", "--factors", "x=1.01", "-o",
                           "out.stl"], {"m.stl": "solid t\n" + CUBE_FACET[:60]}, "m.stl:5",
         ["out.stl"]),
    case("stl_malformed_vertex", ["shrink", "apply", "--model", "m.stl", "--factors", "x=1.01",
                                  "-o", "out.stl"],
         {"m.stl": "solid t\n" + CUBE_FACET.replace("vertex 0 1 0", "vertex 0 abc 0") + "endsolid t\n"},
         "m.stl:5:12", ["out.stl"]),
    case("stl_nan_vertex", ["shrink", "apply", "--model", "m.stl", "--factors", "x=1.01", "-o",
                            "out.stl"],
         {"m.stl": "solid t\n" + CUBE_FACET.replace("vertex 0 1 0", "vertex 0 nan 0") + "endsolid t\n"},
         "m.stl:5:12", ["out.stl"]),
    case("shrink_factors_negative", ["shrink", "apply", "--gcode", "f.gcode", "--factors",
                                     "x=-1", "-o", "out.gcode"], {"f.gcode": GOOD_GCODE},
         "--factors", ["out.gcode"]),
    case("shrink_model_bad_json", ["shrink", "apply", "--gcode", "f.gcode", "--factors",
                                   "model.json", "-o", "out.gcode"],
         {"f.gcode": GOOD_GCODE, "model.json": '{"axis": "Z",\n "factor": }\n'}, "model.json:2:12",
         ["out.gcode"]),
    case("shrink_model_factor_text", ["shrink", "apply", "--gcode", "f.gcode", "--factors",
                                      "model.json", "-o", "out.gcode"],
         {"f.gcode": GOOD_GCODE, "model.json": '{"axis": "Z",\n "factor": "big"}\n'},
         "model.json:2", ["out.gcode"]),
    case("shrink_gcode_not_left_behind", ["shrink", "apply", "--gcode", "f.gcode", "--factors",
                                          "x=1.01", "-o", "out.gcode"],
         {"f.gcode": GOOD_GCODE + "G1 X10 E\n"}, "f.gcode:7:9", ["out.gcode"]),
    # ---- thermal SLS configuration ----
    case("sls_unknown_section", ["thermal", "sls", "--config", "s.toml", "--csv", "out.csv"],
         {"s.toml": "[material]\ndensity_kg_m3 = 930\n[bogus]\nx = 1\n"}, "s.toml:3:1", ["out.csv"]),
    case("sls_negative_density", ["thermal", "sls", "--config", "s.toml", "--csv", "out.csv"],
         {"s.toml": "[material]\ndensity_kg_m3 = -930\n"}, "s.toml:2:17", ["out.csv"]),
    # ---- the 3D powder bed (amctl thermal sls3d) ----
    case("sls3d_negative_conductivity", SLS3D_ARGS,
         {"s.toml": "[powder]\nconductivity_w_mk = -0.1\n"}, "s.toml:2:21", SLS3D_OUTPUTS),
    case("sls3d_part_outside_the_disc", SLS3D_ARGS,
         {"s.toml": "[part]\ninner_radius_mm = 50.0\nouter_radius_mm = 120.0\n"}, "s.toml:3:19", SLS3D_OUTPUTS),
    case("sls3d_laser_never_reaches_the_part", SLS3D_ARGS,
         {"s.toml": "[laser]\nfield_radius_mm = 30.0\n"}, "s.toml:2:19", SLS3D_OUTPUTS),
    case("sls3d_time_step_off_the_schedule", SLS3D_ARGS,
         {"s.toml": "[numerics]\ndt_s = 0.7\n"}, "s.toml:2:8", SLS3D_OUTPUTS),
    case("sls3d_nan_density", SLS3D_ARGS,
         {"s.toml": "[sintered]\ndensity_kg_m3 = nan\n"}, "s.toml:2:17", SLS3D_OUTPUTS),
    case("sls3d_unknown_key", SLS3D_ARGS,
         {"s.toml": "[laser]\npower_watts = 30\n"}, "s.toml:2:1", SLS3D_OUTPUTS),
    case("sls3d_negative_global_refinements", SLS3D_ARGS,
         {"s.toml": "[numerics]\nglobal_refinements = -1\n"}, "s.toml:2:22", SLS3D_OUTPUTS),
    # ---- binary G-code (read by content, whatever the name) ----
    case("bgcode_corrupt_crc", ["estimate", "f.bgcode"],
         {"f.bgcode": latin1(bgcode_damaged_byte(GOOD_GCODE)[0])}, "f.bgcode"),
    case("bgcode_truncated", ["estimate", "f.bgcode"],
         {"f.bgcode": latin1(bgcode_cut(GOOD_GCODE))}, "f.bgcode"),
    case("bgcode_unknown_block_type", ["estimate", "f.bgcode"],
         {"f.bgcode": latin1(bgcode_first_block_type(GOOD_GCODE, 9))}, "f.bgcode"),
    case("bgcode_version_2", ["estimate", "f.gcode"],
         {"f.gcode": latin1(b"GCDE" + struct.pack("<IH", 2, 1))}, "f.gcode"),
    case("bgcode_bad_line_names_the_decoded_line", ["estimate", "f.bgcode"],
         {"f.bgcode": latin1(bgcode(GOOD_GCODE + "G1 Xq\n"))}, "f.bgcode:7:5"),
    case("m73_into_binary_gcode_name", ["estimate", "f.bgcode", "--write-m73", "out.bgcode"],
         {"f.bgcode": latin1(bgcode(GOOD_GCODE))}, "out.bgcode", ["out.bgcode"]),
    case("bgcode_plan_csv_not_left_behind", ["plan", "f.bgcode", "-o", "out.csv"],
         {"f.bgcode": latin1(bgcode_damaged_byte(GOOD_GCODE)[0])}, "f.bgcode", ["out.csv"]),
    # ---- sliced 3MF (.gcode.3mf) and models given as G-code ----
    case("gcode3mf_zip_bomb", ["estimate", "f.gcode.3mf"],
         {"f.gcode.3mf": latin1(make_3mf.bomb_3mf(20))}, "f.gcode.3mf"),
    case("gcode3mf_damaged_zip", ["estimate", "f.gcode.3mf"],
         {"f.gcode.3mf": latin1(make_3mf.sliced_3mf([GOOD_GCODE.encode()])[:200])}, "f.gcode.3mf"),
    case("gcode3mf_bad_line", ["estimate", "f.gcode.3mf"],
         {"f.gcode.3mf": latin1(make_3mf.sliced_3mf([(GOOD_GCODE + "G1 Xq\n").encode()]))},
         "f.gcode.3mf:7:5"),
    case("gcode3mf_several_plates_one_expected", ["plan", "f.gcode.3mf", "-o", "out.csv"],
         {"f.gcode.3mf": latin1(make_3mf.sliced_3mf([GOOD_GCODE.encode()] * 2))}, "f.gcode.3mf",
         ["out.csv"]),
    case("model_3mf_is_not_gcode", ["estimate", "m.3mf"],
         {"m.3mf": latin1(make_3mf.model_3mf())}, "m.3mf"),
    case("stl_given_as_gcode", ["estimate", "m.gcode"], {"m.gcode": CUBE_STL}, "m.gcode"),
    case("gzip_truncated", ["estimate", "f.gcode.gz"], {"f.gcode.gz": latin1(GZIP_HALF)},
         "f.gcode.gz"),
    # ---- the formats decoders on the one reader: every command that reads G-code ----
    case("bgcode_as_its_own_plan_output", ["plan", "f.bgcode", "-o", "f.bgcode"],
         {"f.bgcode": latin1(bgcode(GOOD_GCODE))}, "f.bgcode"),
    case("gzip_as_its_own_plan_output", ["plan", "f.gcode.gz", "-o", "f.gcode.gz"],
         {"f.gcode.gz": latin1(GZIP_HALF)}, "f.gcode.gz"),
    case("gzip_truncated_plan", ["plan", "f.gcode.gz", "-o", "out.csv"],
         {"f.gcode.gz": latin1(GZIP_HALF)}, "f.gcode.gz", ["out.csv"]),
    case("gzip_truncated_m73", ["estimate", "f.gcode.gz", "--write-m73", "out.gcode"],
         {"f.gcode.gz": latin1(GZIP_HALF)}, "f.gcode.gz", ["out.gcode"]),
    case("gzip_truncated_report", ["report", "f.gcode.gz", "-o", "out.html"],
         {"f.gcode.gz": latin1(GZIP_HALF)}, "f.gcode.gz", ["out.html"]),
    case("bgcode_bad_line_m73", ["estimate", "f.bgcode", "--write-m73", "out.gcode"],
         {"f.bgcode": latin1(bgcode(GOOD_GCODE + "G1 Xq\n"))}, "f.bgcode:7:5", ["out.gcode"]),
    case("bgcode_bad_line_compare", ["compare", "f.bgcode", "--natural-frequency-hz", "40",
                                     "--damping-ratio", "0.1"],
         {"f.bgcode": latin1(bgcode(GOOD_GCODE + "G1 Xq\n"))}, "f.bgcode:7:5"),
    case("gcode3mf_bad_line_scale", ["shrink", "apply", "--gcode", "f.gcode.3mf", "--factors", "x=1.01,y=1.01,z=1.01",
                                     "-o", "out.gcode"],
         {"f.gcode.3mf": latin1(make_3mf.sliced_3mf([(GOOD_GCODE + "G1 Xq\n").encode()]))},
         "f.gcode.3mf:7:5", ["out.gcode"]),
    case("stl_given_to_plan", ["plan", "m.gcode", "-o", "out.csv"], {"m.gcode": CUBE_STL}, "m.gcode",
         ["out.csv"]),
    case("configuration_h_tiny_feedrate", ["machine", "show", "Configuration.h"],
         {"Configuration.h": CONFIGURATION_H.replace("{ 500, 500, 5, 25 }", "{ 1e-305, 500, 5, 25 }")},
         "Configuration.h:3:39"),
    case("m503_tiny_feedrate", ["estimate", "f.gcode", "-m", "m503.txt"],
         {"f.gcode": GOOD_GCODE, "m503.txt": M503.replace("X500.00 Y500.00 Z5.00", "X0.0000000000000000001 Y500.00 Z5.00")},
         "m503.txt:2:14"),
    # ---- Marlin machines: M503 output, Configuration.h; empty machine files ----
    case("m503_malformed_number", ["estimate", "f.gcode", "-m", "m503.txt"],
         {"f.gcode": GOOD_GCODE, "m503.txt": M503.replace("Y500.00 Z5.00", "Y5o0.00 Z5.00")},
         "m503.txt:2:22"),
    case("m503_negative_accel", ["estimate", "f.gcode", "-m", "m503.txt"],
         {"f.gcode": GOOD_GCODE, "m503.txt": M503.replace("P500.00", "P-500.00")}, "m503.txt:4:14"),
    case("m503_missing_m204", ["estimate", "f.gcode", "-m", "m503.txt"],
         {"f.gcode": GOOD_GCODE, "m503.txt": M503.replace("echo:  M204 P500.00 R500.00 T500.00\n", "")},
         "m503.txt"),
    case("configuration_h_without_limits", ["machine", "show", "Configuration.h"],
         {"Configuration.h": "#pragma once\n#define MOTHERBOARD BOARD_RAMPS_14_EFB\n"},
         "Configuration.h"),
    case("configuration_h_short_array", ["machine", "show", "Configuration.h"],
         {"Configuration.h": CONFIGURATION_H.replace("{ 500, 500, 5, 25 }", "{ 500, 500, 5 }")},
         "Configuration.h:3:39"),
    case("toml_empty", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": ""}, "m.toml"),
    case("toml_only_defines", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": "#define DEFAULT_ACCELERATION 500\n"}, "m.toml"),
    # ---- Klipper PSD files ----
    case("psd_unknown_column_after_psd_xyz", ["resonance", "calibrate", "p.csv"],
         {"p.csv": "freq,psd_x,psd_y,psd_z,psd_xyz,bogus\n1,1,1,1,3,1\n2,1,1,1,3,1\n"}, "p.csv:1"),
    case("psd_several_records_short_row", ["resonance", "calibrate", "p.csv"],
         {"p.csv": "freq,a.csv,b.csv\n1,1,2\n2,1\n"}, "p.csv:3"),
    # ---- the command line: misspelt commands and options (with a did-you-mean) ----
    case("misspelt_command", ["estimat", "f.gcode"], {"f.gcode": GOOD_GCODE}, "estimat"),
    case("misspelt_subcommand", ["resonance", "calibrat", "f.csv"], {"f.csv": RAW_HEADER}, "calibrat"),
    case("misspelt_option", ["estimate", "f.gcode", "--machin", "voron24"], {"f.gcode": GOOD_GCODE},
         "--machin"),
    case("bad_file_limits_policy", ["estimate", "f.gcode", "--file-limits", "sometimes"],
         {"f.gcode": GOOD_GCODE}, "--file-limits"),
    case("resonance_probe_point_beyond_limits",
         ["resonance", "test-gcode", "--machine", "p.cfg", "--axis", "x", "-o", "out.gcode"],
         {"p.cfg": STEPPER_CFG + "[resonance_tester]\nprobe_points:\n    199.9, 100, 20\n"},
         "p.cfg:24", ["out.gcode"]),
    # ---- input shaper, pressure advance, printers without [extruder] (Klipper's checks) ----
    case("cfg_unknown_shaper_type", ["steps", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE,
          "p.cfg": STEPPER_CFG + "[input_shaper]\nshaper_freq_x: 40\nshaper_type_x: zvx\n"},
         "p.cfg:24:16"),
    case("cfg_negative_shaper_freq", ["steps", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": STEPPER_CFG + "[input_shaper]\nshaper_freq_x: -40\n"},
         "p.cfg:23:16"),
    case("cfg_negative_pressure_advance", ["steps", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": STEPPER_CFG + "pressure_advance: -0.04\n"},
         "p.cfg:22:19"),
    case("cfg_pressure_advance_smooth_time_above_limit", ["steps", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": STEPPER_CFG + "pressure_advance_smooth_time: 0.3\n"},
         "p.cfg:22:31"),
    case("cfg_negative_pressure_advance_smooth_time", ["steps", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": STEPPER_CFG + "pressure_advance_smooth_time: -0.01\n"},
         "p.cfg:22:31"),
    case("shaper_unknown_firmware",
         ["shaper", "show", "--type", "mzv", "--freq-hz", "40", "--damping-ratio", "0.1",
          "--firmware", "prusa"], {}, "--firmware"),
    case("shaper_type_the_firmware_lacks",
         ["shaper", "show", "--type", "zvdd", "--freq-hz", "40", "--damping-ratio", "0.1",
          "--firmware", "klipper"], {}, "--type"),
    case("shaper_klipper_only_parameters_on_marlin",
         ["shaper", "show", "--type", "mzv(n=4, t=0.9)", "--freq-hz", "40", "--damping-ratio", "0.1",
          "--firmware", "marlin"], {}, "--type"),
    case("shaper_negative_marlin_sample_rate",
         ["shaper", "show", "--type", "mzv", "--freq-hz", "40", "--damping-ratio", "0.1",
          "--firmware", "marlin", "--marlin-sample-rate-hz", "-1"], {}, "--marlin-sample-rate-hz"),
    case("toml_unknown_shaper_type", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE,
          "m.toml": GOOD_TOML + '[input_shaper]\nshaper_type_x = "zvx"\nshaper_freq_x = 40\n'},
         "m.toml:6:17"),
    case("toml_negative_shaper_freq", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": GOOD_TOML + "[input_shaper]\nshaper_freq_x = -40\n"},
         "m.toml:6:17"),
    case("toml_negative_pressure_advance", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": GOOD_TOML + "[extruder]\npressure_advance = -0.04\n"},
         "m.toml:6:20"),
    case("toml_pressure_advance_smooth_time_above_limit", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE,
          "m.toml": GOOD_TOML + "[extruder]\npressure_advance_smooth_time = 0.3\n"},
         "m.toml:6:32"),
    case("steps_extrude_without_extruder", ["steps", "f.gcode", "-m", "p.cfg", "--csv", "out.csv"],
         {"f.gcode": GOOD_GCODE, "p.cfg": STEPPER_CFG[:STEPPER_CFG.index("[extruder]")]},
         "f.gcode:5", ["out.csv"]),
    case("estimate_extrude_without_extruder", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": STEPPER_CFG[:STEPPER_CFG.index("[extruder]")]},
         "f.gcode:5"),
]


# ---- round two (outputs that never destroy, inputs read once, bounded macros, physical ranges) ----
MACRO_CFG = GOOD_CFG + "[gcode_macro FOO]\ngcode:\n  G4 P0\n  {body}\n"


def macro_case(name, body, where="p.cfg:8", extra=""):
    return case(name, ["estimate", "f.gcode", "-m", "p.cfg"],
                {"f.gcode": "G28\nFOO\n", "p.cfg": MACRO_CFG.replace("{body}", body) + extra}, where)


R2 = []
# Every writer refuses its own input as the output (by path, through a symbolic link or a hard
# link), and the input is left as it was.
for cmd, out_flag in (
        (["plan", "f.gcode"], "-o"), (["report", "f.gcode"], "-o"),
        (["simulate", "f.gcode", "--natural-frequency-hz", "40"], "--csv"),
        (["compensate", "f.gcode", "--natural-frequency-hz", "40"], "--csv"),
        (["steps", "f.gcode", "-m", "p.cfg"], "--csv"),
        (["estimate", "f.gcode"], "--write-m73"),
        (["shrink", "apply", "--gcode", "f.gcode", "--factors", "x=1.01"], "-o")):
    files = {"f.gcode": GOOD_GCODE, "p.cfg": STEPPER_CFG}
    name = cmd[0] if cmd[0] != "shrink" else "shrink_apply"
    R2.append(case(f"{name}_output_is_the_input", cmd + [out_flag, "f.gcode"], files, "f.gcode"))
    R2.append(case(f"{name}_output_links_to_the_input", cmd + [out_flag, "l.gcode"], files, "l.gcode",
                   links={"l.gcode": "f.gcode"}))
    R2.append(case(f"{name}_output_is_a_directory", cmd + [out_flag, "d"], files, "d", dirs=["d"]))
    R2.append(case(f"{name}_output_in_a_missing_directory", cmd + [out_flag, "nowhere/out"], files,
                   "nowhere/out"))
R2 += [
    case("compensate_gcode_output_is_the_input",
         ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "o.csv", "--gcode", "f.gcode"],
         {"f.gcode": GOOD_GCODE}, "f.gcode", ["o.csv"]),
    case("compensate_two_outputs_one_file",
         ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "o.csv", "--gcode", "o.csv"],
         {"f.gcode": GOOD_GCODE}, "--gcode", ["o.csv"]),
    case("resonance_psd_csv_is_the_record",
         ["resonance", "calibrate", "a.csv", "--axis", "x", "--csv", "a.csv"],
         {"a.csv": RAW_HEADER + RAW_ROWS}, "a.csv"),
    case("resonance_psd_csv_to_a_directory",
         ["resonance", "calibrate", "a.csv", "--axis", "x", "--csv", "d"],
         {"a.csv": RAW_HEADER + RAW_ROWS}, "d", dirs=["d"]),
    case("calibrate_time_save_over_the_timings",
         ["calibrate-time", "t.csv", "--save", "t.csv"],
         {"t.csv": "gcode,duration_s\nf.gcode,12\n", "f.gcode": GOOD_GCODE}, "t.csv"),
    case("sls_trace_over_the_config", ["thermal", "sls", "--config", "s.toml", "--csv", "s.toml"],
         {"s.toml": "[build]\nlayers_added = 1\n"}, "s.toml"),
    case("thermal_hotend_csv_to_a_directory", ["thermal", "hotend", "--csv", "d"], {}, "d", dirs=["d"]),
    case("thermal_margins_bode_to_a_directory", ["thermal", "sls-margins", "--bode-csv", "d"], {}, "d", dirs=["d"]),
    case("test_gcode_to_a_directory", ["resonance", "test-gcode", "--axis", "x", "-o", "d"], {}, "d", dirs=["d"]),
    case("test_gcode_to_a_missing_directory", ["resonance", "test-gcode", "--axis", "x", "-o", "no/t.gcode"],
         {}, "no/t.gcode"),
    case("stepper_sweep_csv_to_a_directory", ["stepper", "sweep", "-m", "p.cfg", "--csv", "d"],
         {"p.cfg": STEPPER_CFG}, "d", dirs=["d"]),
    case("shrink_apply_stl_over_the_model", ["shrink", "apply", "--model", "m.stl", "--factors", "x=1.01",
                                             "-o", "m.stl"],
         {"m.stl": "solid t\n" + CUBE_FACET + "endsolid t\n"}, "m.stl"),
    case("plan_json_with_the_csv_on_stdout", ["plan", "f.gcode", "-o", "-", "--json"],
         {"f.gcode": GOOD_GCODE}, "--json"),
    case("m73_to_stdout_with_json", ["estimate", "f.gcode", "--write-m73", "-", "--json"],
         {"f.gcode": GOOD_GCODE}, "--write-m73"),
]
# Inputs that cannot be read as asked: a directory, a missing file, binary G-code, for every
# command that reads one.
GCODE_COMMANDS = {
    "estimate": ["estimate", "{}"], "estimate_empirical": ["estimate", "{}", "--mode", "empirical"],
    "plan": ["plan", "{}"], "report": ["report", "{}", "-o", "r.html"],
    "simulate": ["simulate", "{}", "--natural-frequency-hz", "40"],
    "compensate": ["compensate", "{}", "--natural-frequency-hz", "40", "--csv", "o.csv"],
    "compare": ["compare", "{}", "--natural-frequency-hz", "40"],
    "steps": ["steps", "{}", "-m", "p.cfg"],
    "shrink_apply": ["shrink", "apply", "--gcode", "{}", "--factors", "x=1.01", "-o", "o.gcode"],
    "compare_profiles": ["estimate", "{}", "--compare-profiles"],
    "stepper_simulate": ["stepper", "simulate", "{}", "-m", "p.cfg"],
}
for name, args in GCODE_COMMANDS.items():
    fill = lambda v: [a.replace("{}", v) for a in args]
    outs = ["o.csv", "o.gcode", "r.html"]
    R2.append(case(f"{name}_input_is_a_directory", fill("d.gcode"), {"p.cfg": STEPPER_CFG}, "d.gcode",
                   outs, dirs=["d.gcode"]))
    R2.append(case(f"{name}_input_is_missing", fill("none.gcode"), {"p.cfg": STEPPER_CFG}, "none.gcode", outs))
    R2.append(case(f"{name}_input_is_binary_gcode", fill("b.gcode"),
                   {"b.gcode": "GCDE\x01\x00\x00\x00\x00\x00\x00\x00", "p.cfg": STEPPER_CFG}, "b.gcode", outs))
R2 += [
    case("machine_file_is_a_directory", ["estimate", "f.gcode", "-m", "d.cfg"], {"f.gcode": GOOD_GCODE},
         "d.cfg", dirs=["d.cfg"]),
    case("machine_show_directory", ["machine", "show", "d.toml"], {}, "d.toml", dirs=["d.toml"]),
    case("include_is_a_directory", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG + "[include sub]\n", "sub/x.cfg": "\n"}, "p.cfg:5:1"),
    case("timings_gcode_is_a_directory", ["calibrate-time", "t.csv"],
         {"t.csv": "gcode,duration_s\nd.gcode,12\n"}, "d.gcode", dirs=["d.gcode"]),
    case("timings_gcode_is_missing", ["calibrate-time", "t.csv"],
         {"t.csv": "gcode,duration_s\nnone.gcode,12\n"}, "none.gcode"),
    case("accel_record_is_a_directory", ["resonance", "calibrate", "d.csv", "--axis", "x"], {}, "d.csv",
         dirs=["d.csv"]),
    case("stl_is_a_directory", ["shrink", "apply", "--model", "d.stl", "--factors", "x=1.01", "-o", "o.stl"],
         {}, "d.stl", ["o.stl"], dirs=["d.stl"]),
    case("params_json_is_a_directory", ["estimate", "f.gcode", "--mode", "empirical", "--params", "d.json"],
         {"f.gcode": GOOD_GCODE}, "d.json", dirs=["d.json"]),
    case("shrink_csv_is_a_directory", ["shrink", "fit", "d.csv"], {}, "d.csv", dirs=["d.csv"]),
    case("sls_config_is_a_directory", ["thermal", "sls", "--config", "d.toml", "--csv", ""], {}, "d.toml",
         dirs=["d.toml"]),
    case("sls_config_is_missing", ["thermal", "sls", "--config", "none.toml", "--csv", ""], {}, "none.toml"),
    # CR-only line ends: each CR ends a line (the error is on line 3, not on line 1).
    case("gcode_cr_only_line_ends", ["estimate", "f.gcode"], {"f.gcode": "G28\rG1 X10 F6000\rG1 Xq\r"},
         "f.gcode:3:5"),
    case("gcode_mixed_line_ends", ["estimate", "f.gcode"], {"f.gcode": "G28\r\nG1 X10 F6000\rG1 Y5\nG1 Yq\n"},
         "f.gcode:4:5"),
    case("gcode_cr_only_plan_not_left_behind", ["plan", "f.gcode", "-o", "o.csv"],
         {"f.gcode": "G28\rG1 X10 F6000\rG1 Xq\r"}, "f.gcode:3:5", ["o.csv"]),
    case("gcode_nul_byte_in_a_word", ["estimate", "f.gcode"], {"f.gcode": "G1 X10\nG1 X\x00\n"}, "f.gcode:2:5"),
]
# The macro engine: every bound an error at the macro's printer.cfg line, naming the bound.
R2 += [
    macro_case("macro_filter_chain", "{ 1" + "|abs" * 3000 + " }"),
    macro_case("macro_attribute_chain", "{ printer" + ".a" * 3000 + " }"),
    macro_case("macro_item_chain", "{ printer" + "['a']" * 3000 + " }"),
    macro_case("macro_plus_chain", "{ 1" + " + 1" * 3000 + " }"),
    macro_case("macro_concat_chain", "{ 'a'" + " ~ 'a'" * 3000 + " }"),
    macro_case("macro_and_chain", "{ 1" + " and 1" * 3000 + " }"),
    macro_case("macro_call_chain", "{ range" + "(1)" * 3000 + " }"),
    macro_case("macro_not_chain", "{ " + "not " * 3000 + "1 }"),
    macro_case("macro_parentheses", "{ " + "(" * 3000 + "1" + ")" * 3000 + " }"),
    macro_case("macro_statements_nested", "{% if 1 %}" * 300 + "{% endif %}" * 300),
    macro_case("macro_string_doubling", "{% set ns = namespace(s='x') %}{% for i in range(64) %}"
               "{% set ns.s = ns.s ~ ns.s %}{% endfor %}", "p.cfg:8"),
    macro_case("macro_list_doubling", "{% set ns = namespace(l=[1]) %}{% for i in range(64) %}"
               "{% set ns.l = ns.l + ns.l %}{% endfor %}", "p.cfg:8"),
    macro_case("macro_shared_list_doubling", "{% set ns = namespace(l=[1]) %}{% for i in range(90) %}"
               "{% set ns.l = [ns.l, ns.l] %}{% endfor %}{ ns.l }", "p.cfg:8"),
    macro_case("macro_replace_amplification", "{ ('x' * 1000)|replace('x', 'y' * 100000) }", "p.cfg:8"),
    macro_case("macro_join_amplification", "{ (['y' * 100000] * 1000)|join('z' * 100000) }", "p.cfg:8"),
    macro_case("macro_repetition", "{ 'x' * 9000000000000000000 }", "p.cfg:8"),
    macro_case("macro_range_near_int64", "{ range(-9223372036854775807, 9223372036854775807)|length }", "p.cfg:8"),
    macro_case("macro_loop_iterations", "{% for i in range(1000000) %}{% for j in range(10) %}{% endfor %}"
               "{% endfor %}", "p.cfg:8"),
    macro_case("macro_work", "{% set s = 'x' * 1000000 %}{% for i in range(1000000) %}{% if 'y' in s %}"
               "{% endif %}{% endfor %}", "p.cfg:8"),
    case("macro_calls_fan_out", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": "G28\nFAN0\n", "p.cfg": GOOD_CFG + "".join(
             f"[gcode_macro FAN{i}]\ngcode:\n  FAN{i + 1}\n  FAN{i + 1}\n" for i in range(40)) +
          "[gcode_macro FAN40]\ngcode:\n  G4 P0\n"}, "p.cfg:{rows}"),
    case("macro_template_too_long", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": "G28\n", "p.cfg": MACRO_CFG.replace("{body}", "M117 " + "x" * 1100000)}, "p.cfg:6"),
    case("macro_variable_nested_literal", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": "G28\n", "p.cfg": GOOD_CFG + "[gcode_macro FOO]\nvariable_x: " + "[" * 300 + "]" * 300 +
          "\ngcode:\n  G4\n"}, "p.cfg:6:13"),
]
# Physical ranges: a positive value a machine cannot have is refused where it is written.
TINY = "0." + "0" * 310 + "1"  # below 1e-300, as a G-code word writes it (no exponent)
HUGE = "1" + "0" * 300
for name, line, col in (
        ("feedrate_tiny", f"G1 X10 F{TINY}", 8), ("m204_tiny", f"M204 S{TINY}", 6),
        ("velocity_limit_1e-300", "SET_VELOCITY_LIMIT VELOCITY=1e-300", 20),
        ("accel_limit_1e-300", "SET_VELOCITY_LIMIT ACCEL=1e-300", 20),
        ("scv_1e-300", "SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=1e-300", 20),
        ("m220_tiny", f"M220 S{TINY}", 6), ("m221_tiny", f"M221 S{TINY}", 6),
        ("m201_tiny", f"M201 X{TINY}", 6), ("m203_tiny", f"M203 X{TINY}", 6),
        ("gcode_offset_speed_1e-300", "SET_GCODE_OFFSET Z=1 MOVE=1 MOVE_SPEED=1e-300", 18),
        ("m207_tiny", f"M207 S1 F{TINY}", 9), ("m208_tiny", f"M208 F{TINY}", 6),
        ("dwell_huge", f"G4 P{HUGE}", 4), ("retract_speed_1e-300", "SET_RETRACTION RETRACT_SPEED=1e-300", 16),
        ("feedrate_huge", f"G1 X10 F{HUGE}", 8), ("m220_huge", f"M220 S{HUGE}", 6),
        ("feedrate_1e-300_reads_as_f1_e-300", "G1 X10 F1e-300", 0)):
    if col == 0:  # F1e-300 is F1 and E-300 in G-code: a valid move (no error), not listed here
        continue
    R2.append(case(f"gcode_{name}", ["estimate", "f.gcode"], {"f.gcode": f"G28\n{line}\nG1 X20 Y20\n"},
                   f"f.gcode:2:{col}"))
R2 += [
    case("toml_max_velocity_1e-300", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": '[printer]\nmax_velocity = 1e-300\n'}, "m.toml:2:16"),
    case("toml_max_accel_1e-300", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": '[printer]\nmax_accel = 1e-300\n'}, "m.toml:2:13"),
    case("toml_marlin_feedrate_1e-300", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": '[printer]\nfirmware = "marlin"\n[marlin]\n'
                                           'max_feedrate = [1e-300, 300, 10, 50]\n'}, "m.toml:4:17"),
    case("cfg_max_velocity_1e-300", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG.replace("max_velocity: 300", "max_velocity: 1e-300")},
         "p.cfg:3:15"),
    case("cfg_max_accel_1e-300", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG.replace("max_accel: 3000", "max_accel: 1e-300")},
         "p.cfg:4:12"),
    case("set_max_velocity_1e-300", ["estimate", "f.gcode", "--set", "printer.max_velocity=1e-300"],
         {"f.gcode": GOOD_GCODE}, "--set printer.max_velocity=1e-300"),
    case("set_max_accel_1e-300", ["estimate", "f.gcode", "--set", "printer.max_accel=1e-300"],
         {"f.gcode": GOOD_GCODE}, "--set printer.max_accel=1e-300"),
    case("set_max_jerk_1e-300", ["estimate", "f.gcode", "--set", "printer.max_jerk=1e-300"],
         {"f.gcode": GOOD_GCODE}, "--set printer.max_jerk=1e-300"),
    case("simulate_sample_rate_1e12", ["simulate", "f.gcode", "--natural-frequency-hz", "40",
                                       "--sample-rate-hz", "1e12"], {"f.gcode": GOOD_GCODE}, "--sample-rate-hz"),
    case("report_sample_rate_1e12", ["report", "f.gcode", "--natural-frequency-hz", "40",
                                     "--sample-rate-hz", "1e12", "-o", "r.html"],
         {"f.gcode": GOOD_GCODE}, "--sample-rate-hz", ["r.html"]),
    case("compare_sample_rate_1e12", ["compare", "f.gcode", "--natural-frequency-hz", "40",
                                      "--sample-rate-hz", "1e12"], {"f.gcode": GOOD_GCODE}, "--sample-rate-hz"),
    case("compensate_sample_rate_1e12", ["compensate", "f.gcode", "--natural-frequency-hz", "40",
                                         "--sample-rate-hz", "1e12", "--csv", "o.csv"],
         {"f.gcode": GOOD_GCODE}, "--sample-rate-hz", ["o.csv"]),
    case("compensate_lead_in_1e9", ["compensate", "f.gcode", "--natural-frequency-hz", "40",
                                    "--lead-in-s", "1e9", "--csv", "o.csv"],
         {"f.gcode": GOOD_GCODE}, "--lead-in-s", ["o.csv"]),
    case("sls_layers_2e9", ["thermal", "sls", "--layers", "2000000000", "--csv", ""], {}, "--layers"),
    case("sls_layers_negative", ["thermal", "sls", "--layers", "-5", "--csv", ""], {}, "--layers"),
    case("shrink_factor_1e300", ["shrink", "apply", "--gcode", "f.gcode", "--factors", "x=1e300", "-o", "o.gcode"],
         {"f.gcode": GOOD_GCODE}, "--factors", ["o.gcode"]),
    case("shrink_factor_tiny", ["shrink", "apply", "--gcode", "f.gcode", "--factors", "y=1e-300", "-o", "o.gcode"],
         {"f.gcode": GOOD_GCODE}, "--factors", ["o.gcode"]),
    case("params_unknown_key", ["estimate", "f.gcode", "--mode", "empirical", "--params", "p.json"],
         {"f.gcode": GOOD_GCODE, "p.json": '{"raster_speed_mm_s": 60,\n "rastr_speed_mm_s": 70}\n'}, "p.json:2"),
    case("params_nested_deep", ["estimate", "f.gcode", "--mode", "empirical", "--params", "p.json"],
         {"f.gcode": GOOD_GCODE, "p.json": "[" * 100000 + "]" * 100000}, "p.json:1"),
    case("accel_record_at_10_hz", ["resonance", "calibrate", "a.csv", "--axis", "x"],
         {"a.csv": RAW_HEADER + "".join(f"{i / 10:.1f},{(i % 5) - 2},{(i % 3) - 1},9800\n" for i in range(3000))},
         "a.csv"),
]

# Numeric flags of every command: negative, NaN, infinite or absurd values are refused naming
# the flag, before any work.
# A closed mesh (four facets, outward normals): what shrink apply accepts.
TETRAHEDRON = "solid t\n" + "".join(
    f"facet normal 0 0 0\n outer loop\n  vertex {a}\n  vertex {b}\n  vertex {c}\n endloop\nendfacet\n"
    for a, b, c in (("0 0 0", "0 1 0", "1 0 0"), ("0 0 0", "1 0 0", "0 0 1"), ("0 0 0", "0 0 1", "0 1 0"),
                    ("1 0 0", "0 1 0", "0 0 1"))) + "endsolid t\n"
FLAG_CASES = [
    ("simulate", ["simulate", "f.gcode", "--natural-frequency-hz", "-40"], "--natural-frequency-hz"),
    ("simulate", ["simulate", "f.gcode", "--natural-frequency-hz", "nan"], "--natural-frequency-hz"),
    ("simulate", ["simulate", "f.gcode", "--natural-frequency-hz", "40", "--csv-rate-hz", "-1", "--csv", "o.csv"],
     "--csv-rate-hz"),
    ("simulate", ["simulate", "f.gcode", "--natural-frequency-hz", "40", "--worst", "-1"], "--worst"),
    ("simulate", ["simulate", "f.gcode", "--natural-frequency-hz", "40", "--corner-window-s", "-1"],
     "--corner-window-s"),
    ("simulate", ["simulate", "f.gcode", "--natural-frequency-hz", "40", "--t-begin", "nan"], "--t-begin"),
    ("simulate", ["simulate", "f.gcode", "--natural-frequency-hz", "40", "--shaper", "mzv",
                  "--shaper-freq-hz", "-5"], "--shaper-freq-hz"),
    ("simulate", ["simulate", "f.gcode", "--mass-kg", "-1", "--stiffness-n-per-m", "1000"], "--mass-kg"),
    ("compensate", ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--knot-spacing-s", "0",
                    "--method", "fbf", "--csv", "o.csv"], "--knot-spacing-s"),
    ("compensate", ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--degree", "0",
                    "--method", "fbf", "--csv", "o.csv"], "--degree"),
    ("compensate", ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--window-s", "-1",
                    "--method", "lpfbf", "--csv", "o.csv"], "--window-s"),
    ("compensate", ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--max-base-accel-mm-s2", "0",
                    "--csv", "o.csv"], "--max-base-accel-mm-s2"),
    ("compensate", ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--lead-in-s", "-1",
                    "--csv", "o.csv"], "--lead-in-s"),
    ("compensate", ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--plant-damping-ratio", "-0.5",
                    "--csv", "o.csv"], "--plant-damping-ratio"),
    ("compare", ["compare", "f.gcode", "--natural-frequency-hz", "0"], "--natural-frequency-hz"),
    ("compare", ["compare", "f.gcode", "--natural-frequency-hz", "40", "--damping-ratio", "inf"], "--damping-ratio"),
    ("compare", ["compare", "f.gcode", "--natural-frequency-hz", "40", "--sample-rate-hz", "0"], "--sample-rate-hz"),
    ("report", ["report", "f.gcode", "-o", "r.html", "--natural-frequency-hz", "-3"], "--natural-frequency-hz"),
    ("sweep", ["sweep", "--square-corner-velocity", "-1"], "--square-corner-velocity"),
    ("estimate", ["estimate", "f.gcode", "--write-m73", "o.gcode", "--m73-interval", "0"], "--m73-interval"),
    ("estimate", ["estimate", "f.gcode", "--write-m73", "o.gcode", "--m73-interval", "-60"], "--m73-interval"),
    ("plan", ["plan", "f.gcode", "--t-begin", "nan"], "--t-begin"),
    ("plan", ["plan", "f.gcode", "--t-end", "-inf"], "--t-end"),
    ("plan", ["plan", "f.gcode", "--layer-begin", "5", "--layer-end", "2"], "--layer-end"),
    ("thermal_sls_margins", ["thermal", "sls-margins", "--kp", "-1"], "--kp"),
    ("thermal_sls_margins", ["thermal", "sls-margins", "--ti", "0"], "--ti"),
    ("thermal_sls_margins", ["thermal", "sls-margins", "--length-mm", "-2"], "--length-mm"),
    ("thermal_sls_margins", ["thermal", "sls-margins", "--rho", "nan"], "--rho"),
    ("thermal_sls_margins", ["thermal", "sls-margins", "--modes", "0"], "--modes"),
    ("thermal_hotend", ["thermal", "hotend", "--target", "nan"], "--target"),
    ("thermal_hotend", ["thermal", "hotend", "--noise", "-1"], "--noise"),
    ("thermal_hotend", ["thermal", "hotend", "--cycles", "0"], "--cycles"),
    ("thermal_hotend", ["thermal", "hotend", "--power-w", "-40"], "--power-w"),
    ("thermal_bed", ["thermal", "bed", "--capacity-j-k", "0"], "--capacity-j-k"),
    ("shaper", ["shaper", "show", "--type", "mzv", "--freq-hz", "0", "--damping-ratio", "0.1"], "--freq-hz"),
    ("shaper", ["shaper", "show", "--type", "mzv", "--freq-hz", "40", "--damping-ratio", "1"], "--damping-ratio"),
    ("shaper", ["shaper", "show", "--type", "zv", "--freq-hz", "1e300", "--damping-ratio", "0.1"], "--freq-hz"),
    ("resonance_recommend", ["resonance", "recommend", "--natural-frequency-hz", "-40", "--damping-ratio", "0.1"],
     "--natural-frequency-hz"),
    ("resonance_recommend", ["resonance", "recommend", "--natural-frequency-hz", "40", "--damping-ratio", "2"],
     "--damping-ratio"),
    ("resonance_recommend", ["resonance", "recommend", "--natural-frequency-hz", "40", "--damping-ratio", "0.1",
                             "--max-smoothing-mm", "-1"], "--max-smoothing-mm"),
    ("test_gcode", ["resonance", "test-gcode", "--axis", "x", "--freq-start", "-5"], "--freq-start"),
    ("test_gcode", ["resonance", "test-gcode", "--axis", "x", "--freq-end", "1e12"], "--freq-end"),
    ("test_gcode", ["resonance", "test-gcode", "--axis", "x", "--hz-per-sec", "0"], "--hz-per-sec"),
    ("test_gcode", ["resonance", "test-gcode", "--axis", "x", "--point", "nan,1,1"], "--point"),
    ("stepper", ["stepper", "simulate", "--scenario", "seed003", "-m", "p.cfg", "--speed-mm-s", "-5"],
     "--speed-mm-s"),
    ("shrink_fit", ["shrink", "fit", "s.csv", "--confidence", "2"], "--confidence"),
    ("shrink_fit", ["shrink", "fit", "s.csv", "--breaks", "-1"], "--breaks"),
    ("shrink_apply", ["shrink", "apply", "--gcode", "f.gcode", "--factors", "x=1.01", "-o", "o.gcode",
                      "--origin", "nan,0,0"], "--origin"),
    ("shrink_apply", ["shrink", "apply", "--model", "m.stl", "--factors", "x=1.01", "-o", "o.stl",
                      "--layer-mm", "-0.2"], "--layer-mm"),    ("compensate", ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--damping-ratio-y", "-0.5",
                    "--csv", "o.csv"], "--damping-ratio-y"),
    ("compensate", ["compensate", "f.gcode", "--natural-frequency-hz", "40", "--natural-frequency-y-hz", "0",
                    "--csv", "o.csv"], "--natural-frequency-y-hz"),
]
for i, (name, args, where) in enumerate(FLAG_CASES):
    R2.append(case(f"flag_{name}_{i}", args,
                   {"f.gcode": GOOD_GCODE, "p.cfg": STEPPER_CFG,
                    "s.csv": "nominal_mm,measured_mm\n10,10.1\n15,15.1\n20,20.2\n",
                    "m.stl": TETRAHEDRON}, where,
                   ["o.csv", "o.gcode", "o.stl", "r.html"]))
CASES += R2

# Klipper's SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE (docs/steppers.md section 8): what Klipper
# refuses stops at its place, for `steps` and `estimate` alike.
SHAPED_CFG = STEPPER_CFG + "[input_shaper]\nshaper_freq_x: 40\nshaper_freq_y: 40\n"
for i, (line, col) in enumerate([
        ("SET_INPUT_SHAPER SHAPER_TYPE_X=foo", 32),
        ("SET_INPUT_SHAPER SHAPER_TYPE=zvdd", 30),
        ("SET_INPUT_SHAPER SHAPER_FREQ_X=-40", 32),
        ("SET_INPUT_SHAPER SHAPER_TYPE_Y=3hump_ei DAMPING_RATIO_Y=0.25", 57),
        ("SET_PRESSURE_ADVANCE ADVANCE=-0.02", 30),
        ("SET_PRESSURE_ADVANCE SMOOTH_TIME=0.25", 34),
        ("SET_PRESSURE_ADVANCE EXTRUDER=extruder1 ADVANCE=0.05", 31)]):
    for cmd in ("steps", "estimate"):
        CASES.append(case(f"step_tuning_{cmd}_{i}", [cmd, "f.gcode", "-m", "p.cfg"],
                          {"f.gcode": GOOD_GCODE + line + "\nG1 X30 E3\n", "p.cfg": SHAPED_CFG},
                          f"f.gcode:7:{col}"))

# ---- Klipper [bed_mesh] (docs/bedmesh.md): a saved profile that does not fill its grid, a
# value that is not a finite number, a key missing, fade_end at or below fade_start, an unknown
# profile loaded and a mesh taller than its fade distance.
MESH_ROWS = ["0.010000, -0.020000, 0.030000", "0.000000, 0.015000, -0.010000",
             "0.020000, 0.005000, 0.000000"]


def mesh_cfg(rows=MESH_ROWS, bed_mesh="", drop=None):
    keys = [("min_x", "10.0"), ("max_x", "190.0"), ("min_y", "10.0"), ("max_y", "190.0"),
            ("x_count", "3"), ("y_count", "3"), ("mesh_x_pps", "2"), ("mesh_y_pps", "2"),
            ("algo", "lagrange"), ("tension", "0.2")]
    saved = "".join(f"#*# \t  {r}\n" for r in rows) + "".join(
        f"#*# {k} = {v}\n" for k, v in keys if k != drop)
    # STEPPER_CFG is 21 lines: [bed_mesh] is line 22, the profile's header line 28, its rows 31-33.
    return (STEPPER_CFG + "[bed_mesh]\nmesh_min: 10, 10\nmesh_max: 190, 190\n" + bed_mesh +
            "#*# <---------------------- SAVE_CONFIG ---------------------->\n"
            "#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n"
            "#*# [bed_mesh default]\n#*# version = 1\n#*# points =\n" + saved)


MESH_GCODE = "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nBED_MESH_PROFILE LOAD=default\nG1 X100 Y100 Z0.2 F6000\n"
CASES += [
    case("bed_mesh_short_row", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": MESH_GCODE, "p.cfg": mesh_cfg([MESH_ROWS[0], "0.000000, 0.015000", MESH_ROWS[2]])},
         "p.cfg:32:8"),
    case("bed_mesh_missing_row", ["machine", "show", "p.cfg"],
         {"p.cfg": mesh_cfg(MESH_ROWS[:2])}, "p.cfg:30:13"),
    case("bed_mesh_nan_point", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": MESH_GCODE, "p.cfg": mesh_cfg([MESH_ROWS[0], "0.000000, nan, -0.010000", MESH_ROWS[2]])},
         "p.cfg:32:18"),
    case("bed_mesh_missing_key", ["steps", "f.gcode", "-m", "p.cfg", "--csv", "o.csv"],
         {"f.gcode": MESH_GCODE, "p.cfg": mesh_cfg(drop="x_count")}, "p.cfg:28:5", ["o.csv"]),
    case("bed_mesh_unknown_profile", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": MESH_GCODE.replace("LOAD=default", "LOAD=first_layer"), "p.cfg": mesh_cfg()},
         "f.gcode:2:23"),
    case("bed_mesh_taller_than_fade", ["steps", "f.gcode", "-m", "p.cfg", "--csv", "o.csv"],
         {"f.gcode": MESH_GCODE, "p.cfg": mesh_cfg(bed_mesh="fade_start: 1\nfade_end: 1.02\n")},
         "f.gcode:2:23", ["o.csv"]),
]


# ---- round three: every numeric flag, every output over any input, text encodings ----
R3 = []
R3_FILES = {"f.gcode": GOOD_GCODE, "p.cfg": STEPPER_CFG, "a.csv": RAW_HEADER + RAW_ROWS,
            "s.csv": "nominal_mm,measured_mm\n10,10.1\n15,15.1\n20,20.2\n", "m.stl": TETRAHEDRON}
R3_OUTS = ["o.csv", "o.gcode", "o.stl", "r.html", "t.gcode"]
# NaN, an infinity or a subnormal number is refused for every numeric flag of every command,
# naming the flag, before any work (a flag the command would not use included).
NUMERIC_FLAGS = {
    ("estimate", "f.gcode"): ["--m73-interval"],
    ("plan", "f.gcode", "-o", "o.csv"): ["--t-begin", "--t-end"],
    ("report", "f.gcode", "-o", "r.html"): ["--natural-frequency-hz", "--damping-ratio", "--sample-rate-hz"],
    ("simulate", "f.gcode", "--natural-frequency-hz", "40"): [
        "--natural-frequency-hz", "--damping-ratio", "--natural-frequency-y-hz", "--damping-ratio-y", "--mass-kg",
        "--stiffness-n-per-m", "--damping-n-s-per-m", "--sample-rate-hz", "--csv-rate-hz", "--t-begin", "--t-end",
        "--jerk", "--corner-window-s", "--shaper-freq-hz", "--shaper-freq-x-hz", "--shaper-freq-y-hz",
        "--shaper-damping-ratio"],
    ("sweep",): ["--square-corner-velocity"],
    ("compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "o.csv"): [
        "--natural-frequency-hz", "--damping-ratio", "--plant-natural-frequency-hz", "--plant-damping-ratio",
        "--knot-spacing-s", "--window-s", "--overlap-s", "--max-base-accel-mm-s2", "--effort-weight-s2",
        "--lead-in-s", "--sample-rate-hz"],
    ("compare", "f.gcode", "--natural-frequency-hz", "40"): [
        "--natural-frequency-hz", "--damping-ratio", "--max-base-accel-mm-s2", "--sample-rate-hz"],
    ("thermal", "sls-margins"): ["--kp", "--ti", "--length-mm", "--rho", "--cp", "--k", "--beta"],
    ("thermal", "hotend"): ["--target", "--noise", "--power-w", "--capacity-j-k", "--loss-w-k", "--fan-loss-w-k",
                            "--sensor-tau-s", "--sensor-delay-s", "--core-capacity-j-k", "--core-to-block-w-k"],
    ("thermal", "bed"): ["--target", "--power-w", "--core-to-block-w-k"],
    ("shrink", "fit", "s.csv"): ["--confidence"],
    ("shrink", "apply", "--gcode", "f.gcode", "--factors", "x=1.01", "-o", "o.gcode"): [
        "--layer-mm", "--first-layer-mm", "--plane-fraction"],
    ("shaper", "show", "--type", "mzv", "--freq-hz", "40"): [
        "--freq-hz", "--damping-ratio", "--residual-at-hz", "--test-damping-ratio"],
    ("resonance", "calibrate", "a.csv", "--axis", "x"): ["--max-smoothing-mm"],
    ("resonance", "recommend", "--natural-frequency-hz", "40", "--damping-ratio", "0.1"): [
        "--natural-frequency-hz", "--damping-ratio", "--max-smoothing-mm"],
    ("resonance", "test-gcode", "--axis", "x", "-o", "t.gcode"): [
        "--freq-start", "--freq-end", "--accel-per-hz", "--accel-mm-s2", "--hz-per-sec"],
    ("stepper", "simulate", "f.gcode", "-m", "p.cfg"): [
        "--speed-mm-s", "--drag-n", "--backlash-mm", "--run-current-a", "--kp", "--encoder-rate-hz",
        "--corrupt-probability"],
}
for base, flags in NUMERIC_FLAGS.items():
    for flag in flags:
        for value in ("nan", "inf", "1e-320"):
            args = list(base)
            if flag in args:
                args[args.index(flag) + 1] = value
            else:
                args += [flag, value]
            name = "_".join(w for w in base[:2] if not w.endswith((".gcode", ".csv")))
            R3.append(case(f"flag_{name}_{flag[2:]}_{value}", args, R3_FILES, flag, R3_OUTS))
# Values a machine cannot have, refused by the flag's physical range (they ended deep inside
# a model, "extra_settle_s must be finite", "state space: A(0, 2) must be finite", or ran).
for base, flag, value in (
        (("simulate", "f.gcode", "--natural-frequency-hz", "40"), "--natural-frequency-hz", "1e19"),
        (("simulate", "f.gcode", "--natural-frequency-hz", "40"), "--natural-frequency-hz", "600"),
        (("simulate", "f.gcode", "--natural-frequency-hz", "40"), "--damping-ratio", "1e19"),
        (("simulate", "f.gcode", "--natural-frequency-hz", "40"), "--jerk", "1e-300"),
        (("simulate", "f.gcode", "--natural-frequency-hz", "40"), "--shaper-freq-hz", "1e-300"),
        (("simulate", "f.gcode", "--natural-frequency-hz", "40"), "--corner-window-s", "1e19"),
        (("simulate", "f.gcode"), "--damping-n-s-per-m", "3"),
        (("simulate", "f.gcode", "--mass-kg", "0.5"), "--stiffness-n-per-m", "1e12"),
        (("sweep",), "--square-corner-velocity", "1e19"),
        (("compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "o.csv"), "--natural-frequency-hz", "1e308"),
        (("compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "o.csv"), "--damping-ratio", "1e308"),
        (("compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "o.csv"), "--plant-damping-ratio", "1e19"),
        (("compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "o.csv"), "--knot-spacing-s", "1e19"),
        (("compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "o.csv"), "--max-base-accel-mm-s2", "1e19"),
        (("compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv", "o.csv"), "--effort-weight-s2", "1e19"),
        (("compare", "f.gcode", "--natural-frequency-hz", "40"), "--natural-frequency-hz", "1e19"),
        (("compare", "f.gcode", "--natural-frequency-hz", "40"), "--max-base-accel-mm-s2", "1e308"),
        (("compare", "f.gcode", "--natural-frequency-hz", "40"), "--plant-offsets", "3000"),
        (("thermal", "sls-margins"), "--kp", "1e19"), (("thermal", "sls-margins"), "--ti", "1e308"),
        (("thermal", "sls-margins"), "--length-mm", "1e19"), (("thermal", "sls-margins"), "--rho", "1e308"),
        (("thermal", "sls-margins"), "--cp", "1e19"), (("thermal", "sls-margins"), "--k", "1e308"),
        (("thermal", "hotend"), "--target", "1e19"), (("thermal", "hotend"), "--target", "30"),
        (("thermal", "hotend"), "--noise", "1e308"), (("thermal", "hotend"), "--power-w", "1e19"),
        (("thermal", "hotend"), "--power-w", "1"), (("thermal", "hotend"), "--capacity-j-k", "1e19"),
        (("thermal", "hotend"), "--loss-w-k", "1e308"), (("thermal", "hotend"), "--fan-loss-w-k", "1e19"),
        (("thermal", "hotend"), "--sensor-tau-s", "1e19"), (("thermal", "hotend"), "--sensor-delay-s", "1e308"),
        (("thermal", "hotend"), "--core-capacity-j-k", "1e19"), (("thermal", "bed"), "--target", "1e308"),
        (("thermal", "bed"), "--capacity-j-k", "1e19"), (("thermal", "bed"), "--sensor-tau-s", "1e-300"),
        (("shrink", "apply", "--gcode", "f.gcode", "--factors", "x=1.01", "-o", "o.gcode"), "--layer-mm", "1e308"),
        (("shrink", "apply", "--gcode", "f.gcode", "--factors", "x=1.01", "-o", "o.gcode"), "--first-layer-mm", "1e19"),
        (("resonance", "recommend", "--natural-frequency-hz", "40", "--damping-ratio", "0.1"),
         "--natural-frequency-hz", "1e19"),
        (("resonance", "recommend", "--natural-frequency-hz", "40", "--damping-ratio", "0.1"),
         "--natural-frequency-hz", "1e-300"),
        (("resonance", "test-gcode", "--axis", "x", "-o", "t.gcode"), "--accel-per-hz", "1e308"),
        (("resonance", "test-gcode", "--axis", "x", "--style", "marlin", "-o", "t.gcode"), "--accel-mm-s2", "1e19"),
        (("stepper", "simulate", "f.gcode", "-m", "p.cfg"), "--speed-mm-s", "1e308"),
        (("simulate", "f.gcode", "--natural-frequency-hz", "40"), "--shaper-damping-ratio", "1e308")):
    args = list(base)
    if flag in args:
        args[args.index(flag) + 1] = value
    else:
        args += [flag, value]
    name = "_".join(w for w in base[:2] if not w.endswith((".gcode", ".csv")))
    R3.append(case(f"range_{name}_{flag[2:]}_{value}", args, R3_FILES, flag, R3_OUTS))

# Every output refuses every file the command reads, not only its G-code: the machine file
# (and a file it includes), the accelerometer record, the timings; and a read-only file.
INC_CFG = STEPPER_CFG.replace("[printer]", "[include inc.cfg]\n[printer]", 1)
WRITERS = {
    "estimate_m73": (["estimate", "f.gcode", "--write-m73"], []),
    "plan": (["plan", "f.gcode", "-o"], []),
    "report": (["report", "f.gcode", "-o"], []),
    "simulate": (["simulate", "f.gcode", "--natural-frequency-hz", "40", "--csv"], []),
    "compensate": (["compensate", "f.gcode", "--natural-frequency-hz", "40", "--csv"], []),
    "steps": (["steps", "f.gcode", "--csv"], []),
    "resonance_calibrate": (["resonance", "calibrate", "a.csv", "--axis", "x", "--csv"], []),
    "test_gcode": (["resonance", "test-gcode", "--axis", "x", "-o"], []),
    "stepper_sweep": (["stepper", "sweep", "--csv"], []),
    "stepper_simulate": (["stepper", "simulate", "f.gcode", "--csv"], []),
    "calibrate_time": (["calibrate-time", "t.csv", "--save"], []),
}
W_FILES = dict(R3_FILES, **{"t.csv": "gcode,duration_s\n" + "".join(
    f"g{i}.gcode,{5 + 7 * i}\n" for i in range(1, 5)), "inc.cfg": "\n"},
    **{f"g{i}.gcode": "G28\nG90\nM82\n" + "".join(f"G1 X{10 + 30 * (k % 2)} Y{5 * k} F{1500 * i}\n"
                                                   for k in range(10 * i)) for i in range(1, 5)})
for name, (args, _) in WRITERS.items():
    R3.append(case(f"{name}_output_is_the_machine_file", args + ["p.cfg", "-m", "p.cfg"], W_FILES, "p.cfg"))
    if name != "resonance_calibrate":  # reads the machine only with --recommend: no include known
        R3.append(case(f"{name}_output_is_an_include_of_the_machine", args + ["inc.cfg", "-m", "i.cfg"],
                       dict(W_FILES, **{"i.cfg": INC_CFG}), "inc.cfg"))
    R3.append(case(f"{name}_output_is_read_only", args + ["ro.out", "-m", "p.cfg"],
                   dict(W_FILES, **{"ro.out": "keep\n"}), "ro.out", modes={"ro.out": 0o444}))
R3 += [
    case("report_output_is_the_accelerometer_record", ["report", "f.gcode", "--accel", "a.csv", "-o", "a.csv"],
         R3_FILES, "a.csv"),
    case("stepper_sweep_csv_and_svg_one_file", ["stepper", "sweep", "-m", "p.cfg", "--csv", "o.csv", "--svg", "o.csv"],
         R3_FILES, "--svg", ["o.csv"]),
    case("shrink_apply_read_only_output", ["shrink", "apply", "--gcode", "f.gcode", "--factors", "x=1.01",
                                           "-o", "ro.gcode"],
         dict(R3_FILES, **{"ro.gcode": "keep\n"}), "ro.gcode", modes={"ro.gcode": 0o444}),
    case("shrink_apply_stl_read_only_output", ["shrink", "apply", "--model", "m.stl", "--factors", "x=1.01",
                                               "-o", "ro.stl"],
         dict(R3_FILES, **{"ro.stl": "keep\n"}), "ro.stl", modes={"ro.stl": 0o444}),
    case("thermal_hotend_read_only_csv", ["thermal", "hotend", "--csv", "ro.csv"], {"ro.csv": "keep\n"}, "ro.csv",
         modes={"ro.csv": 0o444}),
    case("thermal_sls_read_only_csv", ["thermal", "sls", "--csv", "ro.csv"], {"ro.csv": "keep\n"}, "ro.csv",
         modes={"ro.csv": 0o444}),
    case("sls_margins_read_only_bode", ["thermal", "sls-margins", "--bode-csv", "ro.csv"], {"ro.csv": "keep\n"},
         "ro.csv", modes={"ro.csv": 0o444}),
]
# A full disk: every writer's error names the output, exit 2.
for name, (args, _) in WRITERS.items():
    R3.append(case(f"{name}_output_on_a_full_disk", args + ["/dev/full", "-m", "p.cfg"], W_FILES, "/dev/full"))
R3 += [
    case("shrink_apply_output_on_a_full_disk", ["shrink", "apply", "--gcode", "f.gcode", "--factors", "x=1.01",
                                                "-o", "/dev/full"], R3_FILES, "/dev/full"),
    case("thermal_sls_csv_on_a_full_disk", ["thermal", "sls", "--csv", "/dev/full"], {}, "/dev/full"),
    case("thermal_bed_csv_on_a_full_disk", ["thermal", "bed", "--csv", "/dev/full"], {}, "/dev/full"),
]
# --write-m73 on a plate of a 3MF writes text; over the archive itself (through a link) it is
# refused as an input; a 3MF of several plates must name one.
PLATES = latin1(make_3mf.sliced_3mf([GOOD_GCODE.encode(), (GOOD_GCODE * 2).encode()]))
R3 += [
    case("m73_plate_output_links_to_the_archive",
         ["estimate", "p.gcode.3mf/Metadata/plate_2.gcode", "--write-m73", "l.gcode"],
         {"p.gcode.3mf": PLATES}, "l.gcode", links={"l.gcode": "p.gcode.3mf"}),
    case("m73_several_plates_none_named", ["estimate", "p.gcode.3mf", "--write-m73", "o.gcode"],
         {"p.gcode.3mf": PLATES}, "--write-m73", ["o.gcode"]),
    case("m73_plate_into_a_3mf_name", ["estimate", "p.gcode.3mf/Metadata/plate_1.gcode", "--write-m73", "o.gcode.3mf"],
         {"p.gcode.3mf": PLATES}, "o.gcode.3mf", ["o.gcode.3mf"]),
    case("m73_plate_bad_line", ["estimate", "p.gcode.3mf/Metadata/plate_2.gcode", "--write-m73", "o.gcode"],
         {"p.gcode.3mf": latin1(make_3mf.sliced_3mf([GOOD_GCODE.encode(), (GOOD_GCODE + "G1 Xq\n").encode()]))},
         "p.gcode.3mf/Metadata/plate_2.gcode:7:5", ["o.gcode"]),
]
# A NUL byte in a machine file: refused at its line and column, whatever the format.
M503_NUL = M503.replace("M203 X500.00", "M203 X500.00\x00", 1)
R3 += [
    case("m503_nul_byte_at_the_start", ["estimate", "f.gcode", "-m", "m503.txt"],
         {"f.gcode": GOOD_GCODE, "m503.txt": "\x00" + M503}, "m503.txt:1:1"),
    case("m503_nul_byte_in_a_value", ["estimate", "f.gcode", "-m", "m503.txt"],
         {"f.gcode": GOOD_GCODE, "m503.txt": M503_NUL}, f"m503.txt:2:{M503_NUL.split(chr(10))[1].index(chr(0)) + 1}"),
    case("m503_nul_byte_machine_show", ["machine", "show", "m503.txt"],
         {"m503.txt": M503.replace("M92", "M9\x002", 1)}, "m503.txt:1:10"),
    case("toml_nul_byte", ["estimate", "f.gcode", "-m", "m.toml"],
         {"f.gcode": GOOD_GCODE, "m.toml": GOOD_TOML.replace('"t"', '"t\x00"')}, "m.toml:2:10"),
    case("cfg_nul_byte", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": GOOD_CFG.replace("300", "3\x0000")}, "p.cfg:3:16"),
    case("configuration_h_nul_byte", ["machine", "show", "Configuration.h"],
         {"Configuration.h": CONFIGURATION_H.replace("500, 500", "500,\x00 500", 1)},
         f"Configuration.h:3:{CONFIGURATION_H.split(chr(10))[2].index('500, 500') + 5}"),
]
# Text encodings: UTF-16 is refused at 1:1 naming it; a UTF-8 byte-order mark is not part of
# the first line (the column counts as an editor shows it).
UTF16 = latin1("G28\nG1 X10 F600\n".encode("utf-16"))
BOM = "\xef\xbb\xbf"
R3 += [
    case("gcode_utf16_estimate", ["estimate", "u.gcode"], {"u.gcode": UTF16}, "u.gcode:1:1"),
    case("gcode_utf16_plan", ["plan", "u.gcode", "-o", "o.csv"], {"u.gcode": UTF16}, "u.gcode:1:1", ["o.csv"]),
    case("gcode_utf16_simulate", ["simulate", "u.gcode", "--natural-frequency-hz", "40"], {"u.gcode": UTF16},
         "u.gcode:1:1"),
    case("gcode_utf16_big_endian", ["estimate", "u.gcode"],
         {"u.gcode": "\xfe\xff" + latin1("G28\n".encode("utf-16-be"))}, "u.gcode:1:1"),
    case("gcode_bom_then_a_bad_word", ["estimate", "f.gcode"], {"f.gcode": BOM + "G1 Xq\n"}, "f.gcode:1:5"),
    case("cfg_utf16", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": latin1(GOOD_CFG.encode("utf-16"))}, "p.cfg:1:1"),
    case("toml_utf16", ["machine", "show", "m.toml"], {"m.toml": latin1(GOOD_TOML.encode("utf-16"))}, "m.toml:1:1"),
    case("cfg_bom_then_a_bad_value", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": BOM + GOOD_CFG.replace("max_velocity: 300", "max_velocity: nan")},
         "p.cfg:3:15"),
    case("accel_csv_utf16", ["resonance", "calibrate", "a.csv", "--axis", "x"],
         {"a.csv": latin1((RAW_HEADER + RAW_ROWS[:200]).encode("utf-16"))}, "a.csv"),
    case("shrink_csv_utf16", ["shrink", "fit", "s.csv"],
         {"s.csv": latin1("nominal_mm,measured_mm\n10,10.1\n".encode("utf-16"))}, "s.csv:1:1"),
    case("params_json_utf16", ["estimate", "f.gcode", "--mode", "empirical", "--params", "p.json"],
         {"f.gcode": GOOD_GCODE, "p.json": latin1('{"raster_speed_mm_s": 60}'.encode("utf-16"))}, "p.json:1:1"),
    case("gcode_line_of_two_mebibytes", ["estimate", "f.gcode"], {"f.gcode": "G1 X1 ;" + "x" * (2 << 20) + "\n"},
         "f.gcode:1"),
    case("gcode_number_of_two_mebibytes", ["plan", "f.gcode", "-o", "o.csv"],
         {"f.gcode": "G28\nG1 X" + "1" * (2 << 20) + "\n"}, "f.gcode:2", ["o.csv"]),
    case("empty_shrink_csv", ["shrink", "fit", "s.csv"], {"s.csv": ""}, "s.csv"),
    case("empty_timings_csv", ["calibrate-time", "t.csv"], {"t.csv": ""}, "t.csv"),
    case("empty_stl", ["shrink", "apply", "--model", "m.stl", "--factors", "x=1.01", "-o", "o.stl"], {"m.stl": ""},
         "m.stl", ["o.stl"]),
    case("cfg_without_printer_section", ["estimate", "f.gcode", "-m", "p.cfg"],
         {"f.gcode": GOOD_GCODE, "p.cfg": "[mcu]\nserial: /dev/x\n"}, "p.cfg"),
]
CASES += R3


# ---- round four (2026-11-26): what landed after round three. The bed mesh's saved profiles
# and [bed_mesh] keys, BED_MESH_* in the G-code, SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE (in
# the G-code and the machine), Marlin's FT_MOTION shapers, the SLS 3D configuration.
R4 = []
# A saved profile's keys (lines 34-43 of mesh_cfg; the value after "#*# KEY = " counts the
# "#*# " the SAVE_CONFIG block writes).
MESH_KEY_LINES = {"min_x": 34, "max_x": 35, "min_y": 36, "max_y": 37, "x_count": 38, "y_count": 39,
                  "mesh_x_pps": 40, "mesh_y_pps": 41, "algo": 42, "tension": 43}
MESH_DEFAULTS = {"min_x": "10.0", "max_x": "190.0", "min_y": "10.0", "max_y": "190.0", "x_count": "3",
                 "y_count": "3", "mesh_x_pps": "2", "mesh_y_pps": "2", "algo": "lagrange", "tension": "0.2"}


def mesh_key(key, value):
    return mesh_cfg().replace(f"#*# {key} = {MESH_DEFAULTS[key]}\n", f"#*# {key} = {value}\n")


MESH_BAD = {
    "min_x": ["nan", "inf", "1e308", "-1e10", "abc", "1e400"],
    "max_x": ["nan", "-inf", "1e10", "0x10", "1,2"],
    "min_y": ["nan", "inf", "-1e308", "ten"],
    "max_y": ["nan", "1e10", "1e400", "190mm"],
    "x_count": ["0", "1", "-3", "2.5", "5000", "1e9", "abc", "2147483648"],
    "y_count": ["0", "1", "3.0", "5000", "nan"],
    "mesh_x_pps": ["-1", "3000", "1e9", "2147483648", "two"],
    "mesh_y_pps": ["-1", "3000", "1.5"],
    "tension": ["-0.1", "2.5", "nan", "inf", "abc"],
    "algo": ["foo", "LAGRANGE", "bilinear"],
}
for key, values in MESH_BAD.items():
    for i, v in enumerate(values):
        for cmd in (["machine", "show", "p.cfg"],) if i % 2 else (["estimate", "f.gcode", "-m", "p.cfg"],):
            R4.append(case(f"bed_mesh_profile_{key}_{i}", cmd, {"f.gcode": MESH_GCODE, "p.cfg": mesh_key(key, v)},
                           f"p.cfg:{MESH_KEY_LINES[key]}:{len(key) + 8}"))
# Both axes upsampled so that the whole grid (3003 x 3003 points) is beyond the bound.
R4.append(case("bed_mesh_profile_grid_too_large", ["machine", "show", "p.cfg"],
               {"p.cfg": mesh_cfg().replace("mesh_x_pps = 2", "mesh_x_pps = 1500").replace(
                   "mesh_y_pps = 2", "mesh_y_pps = 1500")}, "p.cfg:41:18"))
# A key of every saved profile missing: at the profile's header (column 5, after "#*# ").
for key in ("points", "min_x", "max_y", "y_count", "mesh_x_pps", "mesh_y_pps", "algo", "tension"):
    cfg = mesh_cfg(drop=key) if key != "points" else mesh_cfg().replace("#*# points =\n", "").replace(
        "".join(f"#*# \t  {r}\n" for r in MESH_ROWS), "")
    R4.append(case(f"bed_mesh_profile_missing_{key}", ["machine", "show", "p.cfg"], {"p.cfg": cfg}, "p.cfg:28:5"))
R4 += [
    case("bed_mesh_profile_version_not_a_number", ["machine", "show", "p.cfg"],
         {"p.cfg": mesh_cfg().replace("version = 1", "version = one")}, "p.cfg:29:15"),
    case("bed_mesh_profile_version_fraction", ["machine", "show", "p.cfg"],
         {"p.cfg": mesh_cfg().replace("version = 1", "version = 1.5")}, "p.cfg:29:15"),
]
# The probed points: each a finite number.
for i, bad in enumerate(["inf", "1e400", "-nan", "0x1", "1;2", "", "1e"]):
    row = f"0.000000, {bad}, -0.010000"
    R4.append(case(f"bed_mesh_points_{i}", ["estimate", "f.gcode", "-m", "p.cfg"],
                   {"f.gcode": MESH_GCODE, "p.cfg": mesh_cfg([MESH_ROWS[0], row, MESH_ROWS[2]])},
                   "p.cfg:32:18"))
# [bed_mesh] itself (lines 22-24; an added key is line 25).
for i, (key, value) in enumerate([("fade_start", "nan"), ("fade_end", "inf"), ("fade_target", "nan"),
                                  ("split_delta_z", "0.001"), ("move_check_distance", "1"),
                                  ("algorithm", "foo"), ("bicubic_tension", "3"), ("probe_count", "2, 3"),
                                  ("probe_count", "3.5, 3"), ("probe_count", "abc"), ("mesh_radius", "-1")]):
    R4.append(case(f"bed_mesh_section_{key}_{i}", ["machine", "show", "p.cfg"],
                   {"p.cfg": mesh_cfg(bed_mesh=f"{key}: {value}\n")}, f"p.cfg:25:{len(key) + 3}"))
for i, (key, value, line) in enumerate([("mesh_min", "nan, 10", 23), ("mesh_min", "1e10, 10", 23),
                                        ("mesh_max", "190, 1e308", 24), ("mesh_max", "190", 24),
                                        ("mesh_max", "5, 5", 24)]):
    cfg = mesh_cfg().replace(f"{key}: {'10, 10' if key == 'mesh_min' else '190, 190'}", f"{key}: {value}")
    col = len(key) + 3 + (value.index(",") + 1 if i == 2 else 0)
    R4.append(case(f"bed_mesh_section_{key}_{i}", ["machine", "show", "p.cfg"], {"p.cfg": cfg}, f"p.cfg:{line}:{col}"))
R4.append(case("bed_mesh_section_round_probe_count_even", ["machine", "show", "p.cfg"],
               {"p.cfg": mesh_cfg(bed_mesh="mesh_radius: 50\nround_probe_count: 4\n")}, "p.cfg:26:20"))
# BED_MESH_* in the G-code: at the value.
for i, line in enumerate(["BED_MESH_OFFSET X=1e10", "BED_MESH_OFFSET Y=-1e308", "BED_MESH_OFFSET ZFADE=1e308",
                          "BED_MESH_OFFSET X=inf", "BED_MESH_OFFSET X=", "BED_MESH_OFFSET ZFADE=0x1",
                          "BED_MESH_PROFILE LOAD=", "BED_MESH_PROFILE REMOVE="]):
    col = line.index("=") + 2
    gcode = MESH_GCODE.replace("G1 X100", line + "\nG1 X100")
    R4.append(case(f"bed_mesh_gcode_{i}", ["estimate", "f.gcode", "-m", "p.cfg"],
                   {"f.gcode": gcode, "p.cfg": mesh_cfg()}, f"f.gcode:3:{col}"))
R4.append(case("bed_mesh_gcode_removed_then_loaded", ["estimate", "f.gcode", "-m", "p.cfg"],
               {"f.gcode": MESH_GCODE.replace("G1 X100", "BED_MESH_PROFILE REMOVE=default\n"
                                              "BED_MESH_PROFILE LOAD=default\nG1 X100"), "p.cfg": mesh_cfg()},
               "f.gcode:4:23"))

# SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE: values no printer has (a shaper of 1e-300 Hz
# delayed every move by 1e300 s; ADVANCE=1e6 never finished), in `steps` and `estimate`.
for i, line in enumerate(["SET_INPUT_SHAPER SHAPER_FREQ_X=1e-300", "SET_INPUT_SHAPER SHAPER_FREQ_Y=1e-320",
                          "SET_INPUT_SHAPER SHAPER_FREQ_X=1e7", "SET_INPUT_SHAPER SHAPER_FREQ_Z=0.0001",
                          "SET_INPUT_SHAPER SHAPER_FREQ_Z=1e-300", "SET_INPUT_SHAPER SHAPER_FREQ_X=nan",
                          "SET_INPUT_SHAPER DAMPING_RATIO_Z=1e-320", "SET_INPUT_SHAPER SHAPER_FREQ_Y=0x20",
                          "SET_PRESSURE_ADVANCE ADVANCE=1e6", "SET_PRESSURE_ADVANCE ADVANCE=3",
                          "SET_PRESSURE_ADVANCE ADVANCE=1e308", "SET_PRESSURE_ADVANCE ADVANCE=1e-320",
                          "SET_PRESSURE_ADVANCE SMOOTH_TIME=1e-320", "SET_PRESSURE_ADVANCE ADVANCE=.05.1"]):
    col = line.index("=", line.index(" ")) + 2
    for cmd in ("steps", "estimate"):
        R4.append(case(f"step_tuning_r4_{cmd}_{i}", [cmd, "f.gcode", "-m", "p.cfg"],
                       {"f.gcode": GOOD_GCODE + line + "\nG1 X30 E3\n", "p.cfg": SHAPED_CFG}, f"f.gcode:7:{col}"))
# The same limits in the machine file: [input_shaper] (Z too) and [extruder] pressure_advance.
for i, (cfg, line, col) in enumerate([
        (SHAPED_CFG.replace("shaper_freq_x: 40", "shaper_freq_x: 1e-300"), 23, 16),
        (SHAPED_CFG + "shaper_freq_z: 1e7\n", 25, 16),
        (SHAPED_CFG + "shaper_freq_z: 1e-9\n", 25, 16),
        (STEPPER_CFG + "pressure_advance: 3\n", 22, 19),
        (STEPPER_CFG + "pressure_advance: 1e308\n", 22, 19)]):
    R4.append(case(f"machine_step_tuning_{i}", ["steps", "f.gcode", "-m", "p.cfg", "--csv", "o.csv"],
                   {"f.gcode": GOOD_GCODE, "p.cfg": cfg}, f"p.cfg:{line}:{col}", ["o.csv"]))

# Marlin's FT_MOTION shapers: the trajectory rate and a shaper its grid cannot hold.
SHOW = ["shaper", "show", "--type", "zv", "--freq-hz", "40", "--damping-ratio", "0.1", "--firmware", "marlin"]
for i, (extra, where) in enumerate([(["--marlin-sample-rate-hz", "1e-300"], "--marlin-sample-rate-hz"),
                                    (["--marlin-sample-rate-hz", "1e308"], "--marlin-sample-rate-hz"),
                                    (["--marlin-sample-rate-hz", "-1000"], "--marlin-sample-rate-hz"),
                                    (["--marlin-sample-rate-hz", "0.5"], "--marlin-sample-rate-hz"),
                                    (["--marlin-sample-rate-hz", "10"], "--freq-hz"),
                                    (["--firmware", "FT_MOTION"], "--firmware")]):
    args = list(SHOW)
    if extra[0] in args:
        args[args.index(extra[0]) + 1] = extra[1]
    else:
        args += extra
    R4.append(case(f"marlin_shaper_{i}", args, {}, where))
R4 += [
    case("marlin_shaper_freq_beyond_the_grid", SHOW[:5] + ["9e5"] + SHOW[6:], {}, "--freq-hz"),
    case("marlin_shaper_klipper_type_parameters", ["shaper", "show", "--type", "mzv(n=4,t=0.9)", "--freq-hz", "40",
                                                   "--damping-ratio", "0.1", "--firmware", "marlin"], {}, "--type"),
    case("simulate_shaper_firmware_unknown", ["simulate", "f.gcode", "--natural-frequency-hz", "40",
                                              "--shaper", "zv", "--shaper-freq-hz", "40",
                                              "--shaper-firmware", "reprap"], {"f.gcode": GOOD_GCODE},
         "--shaper-firmware"),
    case("simulate_shaper_firmware_empty", ["simulate", "f.gcode", "--natural-frequency-hz", "40",
                                            "--shaper-firmware", ""], {"f.gcode": GOOD_GCODE}, "--shaper-firmware"),
]

# The SLS 3D configuration: an empty file is a mistake (the defaults run without --config);
# sizes and rates a machine cannot have are refused before anything is allocated.
R4 += [
    case("sls3d_empty_config", SLS3D_ARGS, {"s.toml": ""}, "s.toml:1:1", SLS3D_OUTPUTS),
    case("sls3d_only_comments", SLS3D_ARGS, {"s.toml": "# my scenario\n\n# nothing yet\n"}, "s.toml:1:1",
         SLS3D_OUTPUTS),
    case("sls3d_only_blank_lines", SLS3D_ARGS, {"s.toml": "\n \n\t\n"}, "s.toml:1:1", SLS3D_OUTPUTS),
    case("sls3d_utf16", SLS3D_ARGS, {"s.toml": latin1("[bed]\nlayers = 3\n".encode("utf-16"))}, "s.toml:1:1",
         SLS3D_OUTPUTS),
]
for i, (section, key, value) in enumerate([
        ("bed", "disc_radius_mm", "1e308"), ("bed", "disc_radius_mm", "1e-300"), ("bed", "base_depth_mm", "1e9"),
        ("bed", "layer_thickness_mm", "1e-9"), ("bed", "layers", "2000000000"), ("laser", "power_w", "1e308"),
        ("laser", "power_w", "1e-9"), ("laser", "speed_mm_s", "1e-300"), ("laser", "speed_mm_s", "1e308"),
        ("laser", "hatch_mm", "1e-9"), ("laser", "spot_radius_mm", "1e-300"), ("laser", "field_radius_mm", "1e9"),
        ("numerics", "coarse_cell_mm", "1e-6"), ("numerics", "dt_s", "1e-300"), ("numerics", "dt_s", "1e-9"),
        ("output", "end_time_s", "1e308"), ("output", "end_time_s", "1e6")]):
    R4.append(case(f"sls3d_range_{section}_{key}_{i}", SLS3D_ARGS, {"s.toml": f"[{section}]\n{key} = {value}\n"},
                   f"s.toml:2:{len(key) + 4}", SLS3D_OUTPUTS))
# The same commands from a printer.cfg macro: at the line that calls it, naming the macro.
TUNE_CFG = SHAPED_CFG + ("[gcode_macro TUNE]\ngcode:\n  SET_INPUT_SHAPER SHAPER_FREQ_X={params.F}\n"
                         "  SET_PRESSURE_ADVANCE ADVANCE={params.A|default(0.04)}\n")
for i, call in enumerate(["TUNE F=1e-300", "TUNE F=40 A=1e6", "TUNE F=nan", "TUNE F=40 A=-1"]):
    for cmd in ("steps", "estimate"):
        R4.append(case(f"step_tuning_macro_{cmd}_{i}", [cmd, "f.gcode", "-m", "p.cfg"],
                       {"f.gcode": "G28\nG90\nM82\nG1 X10 Y10 F6000\n" + call + "\nG1 X30 E3\n", "p.cfg": TUNE_CFG},
                       "f.gcode:5"))
# The numerics' users: calibrate-time's durations and prints, resonance calibrate's record.
TIMINGS = {f"g{i}.gcode": W_FILES[f"g{i}.gcode"] for i in range(1, 5)}
for i, (rows, where) in enumerate([
        ("g1.gcode,1e308\ng2.gcode,12\ng3.gcode,19\ng4.gcode,26\n", "t.csv:2:10"),
        ("g1.gcode,1e-300\ng2.gcode,12\ng3.gcode,19\ng4.gcode,26\n", "t.csv:2:10"),
        ("g1.gcode,5\ng2.gcode,2e7\ng3.gcode,19\ng4.gcode,26\n", "t.csv:3:10"),
        ("g1.gcode,5\ng1.gcode,5\ng1.gcode,6\ng1.gcode,5\n", "t.csv"),
        ("g1.gcode,5\ng2.gcode,12\ng1.gcode,5\ng2.gcode,12\n", "t.csv")]):
    R4.append(case(f"calibrate_time_r4_{i}", ["calibrate-time", "t.csv", "--save", "o.toml"],
                   dict(TIMINGS, **{"t.csv": "gcode,duration_s\n" + rows}), where, ["o.toml"]))
R4.append(case("calibrate_time_minutes_beyond_the_range", ["calibrate-time", "t.csv"],
               dict(TIMINGS, **{"t.csv": "gcode,duration_min\ng1.gcode,1e6\ng2.gcode,2\ng3.gcode,3\n"
                                         "g4.gcode,4\n"}), "t.csv:2:10"))
ACCEL = RAW_HEADER + RAW_ROWS
R4 += [
    case("resonance_constant_axis", ["resonance", "calibrate", "a.csv", "--axis", "x", "--csv", "o.csv"],
         {"a.csv": RAW_HEADER + "".join(f"{i / 1000:.3f},0,{(i % 3) - 1},9800\n" for i in range(2000))}, "a.csv",
         ["o.csv"]),
    case("resonance_constant_axis_y", ["resonance", "calibrate", "a.csv", "--axis", "y"],
         {"a.csv": RAW_HEADER + "".join(f"{i / 1000:.3f},{(i % 5) - 2},7,9800\n" for i in range(2000))}, "a.csv"),
    case("resonance_acceleration_1e308", ["resonance", "calibrate", "a.csv", "--axis", "x"],
         {"a.csv": ACCEL.replace("\n0.005,", "\n0.005,1e308,0,0\n0.0051,", 1)}, "a.csv:7"),
    case("resonance_acceleration_beyond_any_sensor", ["resonance", "calibrate", "a.csv", "--axis", "x"],
         {"a.csv": ACCEL.replace("\n0.010,", "\n0.010,-1e12,0,0\n0.0101,", 1)}, "a.csv:12"),
]
CASES += R4

# Motor datasheet keys: a physical range per unit (core/quantity.cpp), so 1e308 or 1e-300 (a typo,
# a unit mix-up) is refused at its key, not simulated.
for key in ("run_current", "supply_voltage", "holding_torque", "rated_current", "phase_resistance",
            "phase_inductance", "rotor_inertia", "detent_torque"):
    for value in ("1e308", "1e-300"):
        CASES.append(case(f"toml_motor_{key}_{value}", ["machine", "show", "m.toml"],
                          {"m.toml": f"[stepper_x]\n{key} = {value}\n"},
                          f"m.toml:2:{len(key) + 4}"))


def says_found_and_expected(message):
    """'..., expected ...' or '... must be ..., got/found ...'."""
    if "expected" in message:
        return True
    return "must" in message and ("got" in message or "found" in message)


def run_case(amctl, c):
    with tempfile.TemporaryDirectory(prefix="amctl_bad_input_") as d:
        for rel, text in c["files"].items():
            p = os.path.join(d, rel)
            os.makedirs(os.path.dirname(p), exist_ok=True)
            with open(p, "wb") as f:
                f.write(text.encode("latin-1"))
        for rel in c.get("dirs", ()):
            os.makedirs(os.path.join(d, rel), exist_ok=True)
        for link, target in c.get("links", {}).items():
            os.symlink(target, os.path.join(d, link))
        for rel, mode in c.get("modes", {}).items():
            os.chmod(os.path.join(d, rel), mode)
        before = {rel: open(os.path.join(d, rel), "rb").read() for rel in c["files"]}
        r = subprocess.run([amctl] + c["args"], cwd=d, capture_output=True, timeout=60)
        problems = []
        if r.returncode != 2:
            problems.append(f"exit code {r.returncode}, expected 2")
        err = r.stderr.decode("utf-8", "replace")
        first = err.splitlines()[0] if err else ""
        where = c["where"]
        if where.endswith("{rows}"):
            where = re.escape(where[:-6]) + r"\d+"
        else:
            where = re.escape(where)
        m = re.match(r"amctl: error: " + where + r": (.+)$", first)
        if not m:
            problems.append(f"stderr does not start with 'amctl: error: {c['where']}: '")
        elif not says_found_and_expected(m.group(1)):
            problems.append("the message does not say what was found and what was expected")
        for out in c["outputs"]:
            if os.path.exists(os.path.join(d, out)):
                problems.append(f"left {out} behind")
        made = set(c["files"]) | set(c.get("dirs", ())) | set(c.get("links", {}))
        leftovers = [f for f in os.listdir(d) if f not in made and
                     not any(f == o for o in c["outputs"]) and f not in {"sub"}]
        if leftovers:
            problems.append(f"left files behind: {leftovers}")
        for rel, text in before.items():  # an input is never changed, whatever the output
            if open(os.path.join(d, rel), "rb").read() != text:
                problems.append(f"changed the input {rel}")
        return problems, first


def main():
    amctl = os.path.abspath(sys.argv[1])
    only = sys.argv[3] if len(sys.argv) > 3 and sys.argv[2] == "-k" else None
    failed = 0
    ran = 0
    for c in CASES:
        if only and only not in c["name"]:
            continue
        ran += 1
        problems, first = run_case(amctl, c)
        if problems:
            failed += 1
            print(f"FAIL {c['name']}: {'; '.join(problems)}\n     stderr: {first}")
    print(f"{ran - failed} of {ran} bad inputs answered as required")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
