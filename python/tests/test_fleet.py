"""amctl.fleet: every file on every machine, in this process and on a local Dask cluster."""

import json
import math
import subprocess
import sys

import pytest

import amctl
from amctl import fleet

FILES = ["tests/reference/klipper/syn_square.gcode", "tests/reference/klipper/syn_arcs.gcode",
         "examples/30_belt_corner.gcode"]
MACHINES = ["voron24", "prusa-mk3s"]


def _without_clock(rows):
    return [{k: v for k, v in r.items() if k != "compute_time_s"} for r in rows]


def test_in_process_rows_equal_the_cli(source_dir, cli):
    files = [str(source_dir / f) for f in FILES]
    rows = fleet.run(files, MACHINES, workers=0)
    assert [(r["file"], r["machine"]) for r in rows] == [(f, m) for f in files for m in MACHINES]
    for r in rows:
        assert r["error"] is None
        ref = cli("estimate", r["file"], "--machine", r["machine"], "--json")
        ref = json.loads(ref)
        assert r["total_time_s"] == ref["total_time_s"]  # the same doubles
        assert r["moves"] == ref["moves"]
        assert r["layers"] == len(ref["layers"])
        assert r["filament_mm"] == ref["filament_mm"]


def test_local_cluster_gives_the_same_rows_in_input_order(source_dir):
    files = [str(source_dir / f) for f in FILES]
    here = fleet.run(files, MACHINES, workers=0)
    there = fleet.run(files, MACHINES, workers=2, batch=2)
    assert _without_clock(there) == _without_clock(here)


def test_a_bad_file_is_one_error_row(tmp_path, source_dir):
    bad = tmp_path / "bad.gcode"
    bad.write_text("G1 X10 F6000\nG1 X1.2.3\n")
    good = str(source_dir / FILES[0])
    rows = fleet.run([good, str(bad), str(tmp_path / "missing.gcode")], ["voron24"], workers=0)
    assert rows[0]["error"] is None and rows[0]["total_time_s"] > 0
    assert "bad.gcode:2:" in rows[1]["error"] and rows[1]["total_time_s"] is None
    assert "missing.gcode" in rows[2]["error"]
    # A bad machine is an error row too, for every file.
    rows = fleet.run([good], ["no-such-preset"], workers=0)
    assert rows[0]["error"] and "no-such-preset" in rows[0]["error"]


def test_command_line_json_csv_and_exit_codes(tmp_path, source_dir):
    env_cmd = [sys.executable, "-m", "amctl.fleet"]
    files = [str(source_dir / f) for f in FILES[:2]]
    r = subprocess.run(env_cmd + files + ["-m", "voron24", "--workers", "0", "--json"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert [x["file"] for x in rows] == sorted(files)
    out = tmp_path / "rows.csv"
    bad = tmp_path / "bad.gcode"
    bad.write_text("G1 X1.2.3\n")
    r = subprocess.run(env_cmd + files + [str(bad), "-m", "voron24", "--workers", "0",
                                          "--csv", str(out)], capture_output=True, text=True)
    assert r.returncode == 1  # one run failed, the others were written
    lines = out.read_text().splitlines()
    assert lines[0].split(",")[:3] == ["file", "machine", "set"]
    assert len(lines) == 4
    r = subprocess.run(env_cmd + [str(tmp_path / "nothing-*.gcode"), "--workers", "0"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "no G-code file" in r.stderr


def test_sweep_grid_matches_closed_forms(tmp_path):
    # One 10 mm move from rest to rest at F6000 (100 mm/s), no cruise smoothing:
    #   a = 1000: 100^2 / 2000 = 5 mm per ramp, a triangle: t = 2 v / a = 0.2 s;
    #   a = 4000: 1.25 mm per ramp, 7.5 mm cruise: t = 2 * 0.025 + 0.075 = 0.125 s.
    g = tmp_path / "line.gcode"
    g.write_text("G1 X10 F6000\n")
    df = fleet.sweep([str(g)], "default", {"printer.max_accel": [1000, 4000],
                                           "printer.minimum_cruise_ratio": [0]}, workers=0)
    assert list(df["printer.max_accel"]) == [1000, 4000]
    assert math.isclose(df["total_time_s"][0], 0.2, rel_tol=1e-12)
    assert math.isclose(df["total_time_s"][1], 0.125, rel_tol=1e-12)
    assert df["error"].isna().all()
    with pytest.raises(TypeError):
        fleet.sweep([str(g)], "default", {"printer.max_accel": 1000})


def test_bad_arguments_raise_amctl_error():
    with pytest.raises(amctl.Error):
        fleet.run([], ["voron24"], workers=0)
    with pytest.raises(amctl.Error):
        fleet.run(["x.gcode"], ["voron24"], workers=0, batch=0)
    with pytest.raises(amctl.Error):
        fleet.expand_inputs(["/nonexistent/*.gcode"])


def test_directories_plates_and_empty_files(tmp_path, source_dir):
    # A directory stands for its G-code files, in any format, for fleet.run as for the command
    # line; a 3MF of two plates is two rows; an empty file is a row that says "no moves".
    import shutil
    import zipfile
    d = tmp_path / "queue"
    d.mkdir()
    square = source_dir / FILES[0]
    shutil.copy(square, d / "a.gcode")
    (d / "empty.gcode").write_text("")
    (d / "notes.txt").write_text("not G-code")
    with zipfile.ZipFile(d / "two.gcode.3mf", "w", zipfile.ZIP_DEFLATED) as z:
        z.write(square, "Metadata/plate_1.gcode")
        z.write(source_dir / FILES[1], "Metadata/plate_2.gcode")
    expected = [str(d / "a.gcode"), str(d / "empty.gcode"),
                str(d / "two.gcode.3mf") + "/Metadata/plate_1.gcode",
                str(d / "two.gcode.3mf") + "/Metadata/plate_2.gcode"]
    assert amctl.gcode_inputs([d]) == expected
    rows = fleet.run([d], ["voron24"], workers=0)
    assert [r["file"] for r in rows] == expected
    assert all(r["error"] is None for r in rows)
    assert rows[1]["total_time_s"] == 0 and rows[1]["note"] == "no moves"
    assert rows[0]["note"] is None
    # Each plate's numbers are its G-code's.
    assert rows[2]["total_time_s"] == rows[0]["total_time_s"]
    assert rows[3]["total_time_s"] == amctl.estimate(source_dir / FILES[1], machine="voron24")["total_time_s"]
    assert fleet.expand_inputs([str(d)]) == sorted(expected)
    (tmp_path / "nothing").mkdir()
    with pytest.raises(amctl.Error, match="directory without G-code"):
        amctl.gcode_inputs([tmp_path / "nothing"])
def test_file_limits_reach_every_run(tmp_path):
    # M204 S4000 in the file on a 1000 mm/s^2 machine: kept (0.125 s) or capped (0.2 s),
    # the closed forms of test_sweep_grid_matches_closed_forms.
    g = tmp_path / "line.gcode"
    g.write_text("M204 S4000\nG1 X10 F6000\n")
    sets = {"printer.max_accel": 1000, "printer.minimum_cruise_ratio": 0}
    keep = fleet.run([str(g)], ["default"], overrides=sets, workers=0)
    cap = fleet.run([str(g)], ["default"], overrides=sets, workers=0, file_limits="cap")
    assert math.isclose(keep[0]["total_time_s"], 0.125, rel_tol=1e-12)
    assert math.isclose(cap[0]["total_time_s"], 0.2, rel_tol=1e-12)
    with pytest.raises(amctl.Error):
        fleet.run([str(g)], ["default"], workers=0, file_limits="never")
