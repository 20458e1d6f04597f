"""amctl.plan / amctl.iter_plan: the planned moves as numpy structured arrays, against closed
forms and against the CSV of `amctl plan`."""

import io

import numpy as np
import pytest

import amctl
from conftest import SIMPLE

BOXBOSS = "examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode"
VORON = "configs/klipper-voron-v0.cfg"

CSV_COLUMNS = ("line,layer,feature,start_time_s,duration_s,x0_mm,y0_mm,z0_mm,e0_mm,x1_mm,y1_mm,"
               "z1_mm,e1_mm,distance_mm,start_v_mm_s,cruise_v_mm_s,end_v_mm_s,accel_mm_s2,"
               "jerk_mm_s3,accel_t_s,cruise_t_s,decel_t_s,profile,extrude_only").split(",")


def test_fields_are_the_csv_columns():
    assert list(amctl.MOVE_DTYPE.names) == CSV_COLUMNS


def test_one_move_has_the_closed_form_phases(gcode):
    moves = amctl.plan(gcode("G1 X10 F6000\n"), set=SIMPLE)
    assert moves.dtype == amctl.MOVE_DTYPE
    assert len(moves) == 1
    m = moves[0]
    # 100 mm/s reached after v/a = 0.02 s over v^2/(2a) = 1 mm; 8 mm cruise = 0.08 s.
    assert m["accel_t_s"] == pytest.approx(0.02, abs=1e-15)
    assert m["cruise_t_s"] == pytest.approx(0.08, abs=1e-15)
    assert m["decel_t_s"] == pytest.approx(0.02, abs=1e-15)
    assert m["duration_s"] == pytest.approx(0.12, abs=1e-15)
    assert (m["start_v_mm_s"], m["cruise_v_mm_s"], m["end_v_mm_s"]) == (0.0, 100.0, 0.0)
    assert m["accel_mm_s2"] == 5000.0
    assert (m["x0_mm"], m["x1_mm"], m["distance_mm"]) == (0.0, 10.0, 10.0)
    assert m["line"] == 1 and m["layer"] == -1
    assert m["profile"] == "trapezoid" and not m["extrude_only"]


def test_features_layers_and_retractions_are_tagged(gcode):
    text = (";LAYER_CHANGE\n;Z:0.2\nG1 Z0.2 F600\n;TYPE:External perimeter\nM83\n"
            "G1 X10 E1 F6000\nG1 E-0.8 F2400\n")
    moves = amctl.plan(gcode(text), set=SIMPLE)
    # before the first ;TYPE: the feature is "unknown", as in the CSV
    assert list(moves["feature"]) == ["unknown", "External perimeter", "External perimeter"]
    assert list(moves["extrude_only"]) == [False, False, True]
    assert moves["e1_mm"][2] - moves["e0_mm"][2] == pytest.approx(-0.8, abs=1e-12)
    # the retraction: 0.8 mm of E at 40 mm/s
    assert moves["distance_mm"][2] == pytest.approx(0.8, abs=1e-12)


def _read_cli_csv(text):
    special = {"feature": "U64", "profile": "U16", "extrude_only": "i1"}
    dtype = [(name, special.get(name, amctl.MOVE_DTYPE[name])) for name in CSV_COLUMNS]
    return np.genfromtxt(io.StringIO(text), delimiter=",", names=True, dtype=dtype,
                         autostrip=False, comments=None, encoding="utf-8")


@pytest.mark.parametrize("extra", [[], ["--layer-begin", "3", "--layer-end", "5"]])
def test_python_and_cli_agree_on_every_move(cli, source_dir, extra):
    path, spec = str(source_dir / BOXBOSS), str(source_dir / VORON)
    want = _read_cli_csv(cli("plan", path, "--machine", spec, *extra))
    kw = {}
    if extra:
        kw = {"layer_begin": 3, "layer_end": 5}
    got = amctl.plan(path, machine=spec, **kw)
    assert len(got) == len(want) > 100
    for name in CSV_COLUMNS:
        if name == "feature":
            # the CSV quotes names holding commas; boxboss's names hold none
            assert list(got[name]) == [str(s) for s in want[name]], name
        elif name == "profile":
            assert list(got[name]) == [str(s) for s in want[name]], name
        elif name == "extrude_only":
            assert np.array_equal(got[name], want[name].astype(bool)), name
        else:
            # the CSV holds the shortest decimal that reads back to the same double: bit equal
            assert np.array_equal(got[name], want[name]), name


def test_batches_join_to_the_whole_plan(source_dir):
    path = str(source_dir / BOXBOSS)
    whole = amctl.plan(path, machine="voron24")
    for batch_moves in (1, 7, 4096):
        batches = list(amctl.iter_plan(path, machine="voron24", batch_moves=batch_moves))
        assert all(len(b) > 0 for b in batches)
        joined = np.concatenate(batches)
        assert len(joined) == len(whole)
        for name in CSV_COLUMNS:
            assert np.array_equal(joined[name], whole[name]), (batch_moves, name)


def test_time_range_keeps_overlapping_moves(source_dir):
    path = str(source_dir / BOXBOSS)
    whole = amctl.plan(path, machine="voron24")
    end = whole["start_time_s"] + whole["duration_s"]
    sel = amctl.plan(path, machine="voron24", t_begin=100.0, t_end=200.0)
    keep = (end >= 100.0) & (whole["start_time_s"] <= 200.0)
    assert np.array_equal(sel["line"], whole["line"][keep])
    assert np.array_equal(sel["start_time_s"], whole["start_time_s"][keep])


def test_start_times_chain(source_dir):
    moves = amctl.plan(str(source_dir / BOXBOSS), machine="voron24")
    # Without dwells every move starts when the previous one ends.
    nxt = moves["start_time_s"][1:]
    end = moves["start_time_s"][:-1] + moves["duration_s"][:-1]
    assert np.all(nxt >= end - 1e-9)
    assert np.allclose(moves["duration_s"], moves["accel_t_s"] + moves["cruise_t_s"] + moves["decel_t_s"],
                       rtol=0, atol=1e-12)


def test_empty_file_gives_an_empty_array(gcode):
    moves = amctl.plan(gcode("; nothing\n"))
    assert len(moves) == 0 and moves.dtype == amctl.MOVE_DTYPE


def test_errors(gcode):
    with pytest.raises(amctl.Error) as e:
        amctl.plan(gcode("G1 X10\nG1 X1.2.3 F100\n"))
    assert (e.value.line, e.value.column) == (2, 8)
    with pytest.raises(TypeError, match="batch_moves"):
        amctl.iter_plan(gcode("G1 X1\n"), batch_moves=1.5)
    with pytest.raises(TypeError, match="layer_begin"):
        amctl.plan(gcode("G1 X1\n"), layer_begin="3")
    with pytest.raises(amctl.Error, match="batch_moves"):
        amctl.iter_plan(gcode("G1 X1\n"), batch_moves=0)
    with pytest.raises(amctl.Error, match="empty|range"):
        amctl.plan(gcode("G1 X1\n"), t_begin=5.0, t_end=1.0)
