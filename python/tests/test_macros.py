"""Klipper [gcode_macro] expansion and [gcode_arcs] through amctl.estimate: the same keys as
`amctl estimate --json` (macros, unknown_commands), macros timed as their expansion by the real
Jinja2 (tests/reference/macro), arcs unknown without [gcode_arcs]. As
tests/plan/macro_estimate_test.cpp and tests/plan/gcode_arcs_test.cpp."""

import pytest

import amctl

REF = "tests/reference/macro/"
PRINTER = "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 5000\n" \
          "square_corner_velocity: 0\nminimum_cruise_ratio: 0\n"


def _without_compute_time(d):
    return {k: v for k, v in d.items() if k != "compute_time_s"}


def test_macros_and_their_report_equal_the_cli(cli, source_dir):
    path, cfg = str(source_dir / (REF + "print.gcode")), str(source_dir / (REF + "printer.cfg"))
    want = cli.json("estimate", path, "--machine", cfg, "--json")
    got = amctl.estimate(path, machine=cfg)
    assert _without_compute_time(got) == _without_compute_time(want)
    assert [m["name"] for m in got["macros"]] == ["PRINT_START", "M109", "_PURGE_LINE", "PRINT_END"]
    assert all(m["expanded"] == 1 and m["skip_reason"] is None for m in got["macros"])
    assert got["unknown_commands"] == []


def test_macros_are_timed_as_the_jinja2_expansion(source_dir):
    a = amctl.estimate(str(source_dir / (REF + "print.gcode")),
                       machine=str(source_dir / (REF + "printer.cfg")))
    b = amctl.estimate(str(source_dir / (REF + "print_expanded.gcode")),
                       machine=str(source_dir / (REF + "printer_base.cfg")))
    assert a["total_time_s"] == pytest.approx(b["total_time_s"], abs=1e-9)
    assert a["moves"] == b["moves"]


def test_a_macro_amctl_cannot_evaluate_is_skipped_with_its_line(cli, tmp_path):
    cfg = tmp_path / "printer.cfg"
    cfg.write_text(PRINTER + "[gcode_macro PROBE_Z]\ngcode:\n  G1 X5 F6000\n"
                   "  G1 Z{printer.probe.last_z_result}\n")
    g = tmp_path / "t.gcode"
    g.write_text("G1 X10 F6000\nPROBE_Z\n")
    want = cli.json("estimate", str(g), "--machine", str(cfg), "--json")
    got = amctl.estimate(str(g), machine=str(cfg))
    assert _without_compute_time(got) == _without_compute_time(want)
    (m,) = got["macros"]
    assert (m["name"], m["calls"], m["expanded"], m["skipped"]) == ("PROBE_Z", 1, 0, 1)
    assert m["first_skipped_line"] == 2
    assert m["skip_reason"].startswith(f"at {cfg}:10: 'printer.probe' is undefined")
    assert got["total_time_s"] == pytest.approx(0.12, abs=1e-12)  # the file's own move only


def test_arcs_are_unknown_without_gcode_arcs(cli, tmp_path):
    cfg = tmp_path / "printer.cfg"
    cfg.write_text(PRINTER)
    g = tmp_path / "arc.gcode"
    g.write_text("G1 X10 F6000\nG2 X20 Y0 I5 J0\n")
    want = cli.json("estimate", str(g), "--machine", str(cfg), "--json")
    got = amctl.estimate(str(g), machine=str(cfg))
    assert _without_compute_time(got) == _without_compute_time(want)
    assert [u["name"] for u in got["unknown_commands"]] == ["G2"]
    assert got["total_time_s"] == pytest.approx(0.12, abs=1e-12)
    cfg.write_text(PRINTER + "[gcode_arcs]\nresolution: 0.5\n")
    with_arcs = amctl.estimate(str(g), machine=str(cfg))
    assert with_arcs["unknown_commands"] == []
    assert with_arcs["moves"] == 1 + 31  # floor(5 pi / 0.5) segments (gcode_arcs.py)
