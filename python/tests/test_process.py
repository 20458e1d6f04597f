"""Process planning: the shrinkage fit against numpy's least squares, and agreement with
`amctl shrink fit --json` and the empirical estimate."""

import csv

import numpy as np
import pytest

import amctl

TABLE1 = "examples/04_shrink_geometry1.csv"


def test_shrink_fit_is_numpys_least_squares_line(source_dir):
    path = str(source_dir / TABLE1)
    with open(path) as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    h = np.array([float(r["nominal_mm"]) for r in rows])
    err = np.array([float(r["measured_mm"]) for r in rows]) - h
    slope, intercept = np.polyfit(h, err, 1)
    r = amctl.shrink_fit(path)
    assert r["axis"] == "Z"
    assert r["n"] == len(h)
    assert r["slope"] == pytest.approx(slope, abs=1e-14)
    assert r["intercept"] == pytest.approx(intercept, abs=1e-12)
    assert r["factor"] == pytest.approx(1.0 / (1.0 + slope), abs=1e-12)


@pytest.mark.parametrize("kw,flags", [
    ({}, []),
    (dict(average=True, ranges=2), ["--average", "--ranges", "2"]),
    (dict(breaks_mm=[30.0]), ["--breaks", "30"]),
    (dict(breaks=[30.0, 60.0]), ["--breaks", "30,60"]),
    (dict(ranges="auto", confidence=0.9), ["--ranges", "auto", "--confidence", "0.9"]),
])
def test_shrink_fit_is_the_cli_json(cli, source_dir, kw, flags):
    path = str(source_dir / TABLE1)
    assert amctl.shrink_fit(path, **kw) == cli.json("shrink", "fit", path, *flags, "--json")


def test_empirical_estimate_with_params_is_the_cli_json(cli, source_dir):
    path = str(source_dir / "examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode")
    params = str(source_dir / "examples/04_empirical_start.json")
    want = cli.json("estimate", path, "--mode", "empirical", "--params", params, "--json")
    assert amctl.estimate_empirical(path, params=params) == want
    assert want["total_time_s"] > 0


def test_process_errors(source_dir, tmp_path):
    path = str(source_dir / TABLE1)
    with pytest.raises(amctl.Error, match="axis"):
        amctl.shrink_fit(path, axis="W")
    with pytest.raises(amctl.Error, match="ranges"):
        amctl.shrink_fit(path, ranges=0)
    with pytest.raises(TypeError, match="ranges"):
        amctl.shrink_fit(path, ranges="two")
    with pytest.raises(TypeError, match=r"breaks_mm\[0\]"):
        amctl.shrink_fit(path, breaks_mm=["10"])
    bad = tmp_path / "bad.csv"
    bad.write_text("nominal_mm,measured_mm\n10,abc\n")
    with pytest.raises(amctl.Error) as e:
        amctl.shrink_fit(str(bad))
    assert "bad.csv" in str(e.value)
