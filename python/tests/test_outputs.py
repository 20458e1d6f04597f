"""Large tables as numpy's .npy format (docs/outputs.md): `amctl plan -o X.npy`, `amctl steps
--csv X.npy` and `amctl compensate --csv X.npy` write the same rows as their CSV, which numpy
reads without amctl (numpy.load); checked here against the CSV read by pandas, an independent
reader of the other format."""

import io
import subprocess

import numpy as np
import pandas as pd
import pytest

import amctl


def _both(cli, tmp_path, args, flag):
    """Runs the command twice, to a .csv and to a .npy; returns (DataFrame, structured array)."""
    csv = tmp_path / "t.csv"
    npy = tmp_path / "t.npy"
    cli(*args, flag, csv)
    cli(*args, flag, npy)
    return (pd.read_csv(csv, keep_default_na=False, float_precision="round_trip"),
            np.load(npy, allow_pickle=False))


def test_steps_npy_equals_the_csv(cli, source_dir, tmp_path):
    ref = source_dir / "tests" / "reference" / "klipper"
    df, arr = _both(cli, tmp_path, ["steps", ref / "syn_tuning_advance.gcode", "--machine",
                                    ref / "steps_cartesian_shaped.cfg"], "--csv")
    assert arr.dtype.names == ("stepper", "time_s", "direction")
    assert arr.dtype["time_s"] == np.dtype("<f8") and arr.dtype["direction"] == np.dtype("i1")
    assert len(arr) == len(df) > 1000
    # The CSV prints each time in its shortest round-trip form: the doubles are equal.
    assert np.array_equal(arr["time_s"], df["time_s"].to_numpy())
    assert np.array_equal(arr["direction"].astype(int), df["direction"].to_numpy())
    assert [s.decode() for s in arr["stepper"]] == list(df["stepper"])
    assert set(df["stepper"]) >= {"stepper_x", "stepper_y", "extruder"}


def test_plan_npy_equals_the_csv_and_the_python_plan(cli, source_dir, tmp_path):
    gcode = source_dir / "tests" / "reference" / "klipper" / "syn_circle1000.gcode"
    machine = source_dir / "configs" / "klipper-voron-v0.cfg"
    df, arr = _both(cli, tmp_path, ["plan", gcode, "--machine", machine], "-o")
    assert len(arr) == len(df) > 900
    assert list(arr.dtype.names) == list(df.columns)
    for name in arr.dtype.names:
        if arr.dtype[name].kind == "S":
            assert [v.decode() for v in arr[name]] == [str(v) for v in df[name]], name
        else:
            assert np.array_equal(arr[name], df[name].to_numpy().astype(arr.dtype[name])), name
    # The same names and values as the package's own plan (MOVE_DTYPE), a third reader.
    py = amctl.plan(str(gcode), str(machine))
    for name in arr.dtype.names:
        if arr.dtype[name].kind == "S":
            assert [v.decode() for v in arr[name]] == list(py[name]), name
        else:
            assert np.array_equal(arr[name], py[name].astype(arr.dtype[name])), name


def test_compensate_npy_holds_the_csv_to_its_nine_decimals(cli, source_dir, tmp_path):
    df, arr = _both(cli, tmp_path, ["compensate", source_dir / "examples" / "30_belt_corner.gcode",
                                    "--machine", source_dir / "examples" / "30_belt_corner_printer.cfg",
                                    "--method", "lpfbf", "--natural-frequency-hz", "40"], "--csv")
    assert list(arr.dtype.names) == list(df.columns)
    assert len(arr) == len(df) > 100
    for name in arr.dtype.names:
        assert np.max(np.abs(arr[name] - df[name].to_numpy())) <= 5.1e-10, name


def test_simulate_npy_holds_the_csv_to_its_printed_digits(cli, source_dir, tmp_path):
    df, arr = _both(cli, tmp_path, ["simulate", source_dir / "examples" / "30_belt_corner.gcode",
                                    "--machine", source_dir / "examples" / "30_belt_corner_printer.cfg",
                                    "--natural-frequency-hz", "40"], "--csv")
    assert list(arr.dtype.names) == list(df.columns)
    assert len(arr) == len(df) > 100
    assert np.array_equal(arr["line"], df["line"].to_numpy().astype(np.uint64))
    # The CSV prints 6 decimals (z 4); the contour error and vibration 6 significant digits.
    for name in ("t_s", "cmd_x_mm", "cmd_y_mm", "sim_x_mm", "sim_y_mm"):
        assert np.max(np.abs(arr[name] - df[name].to_numpy())) <= 5.1e-7, name
    assert np.max(np.abs(arr["cmd_z_mm"] - df["cmd_z_mm"].to_numpy())) <= 5.1e-5
    for name in ("contour_error_mm", "vibration_mm"):
        assert np.allclose(arr[name], df[name].to_numpy(), rtol=5e-6, atol=1e-12), name


def test_a_pipe_is_refused_for_npy_and_nothing_is_written(source_dir, tmp_path):
    import os
    exe = os.environ.get("AMCTL_CLI", str(source_dir / "build" / "release" / "apps" / "amctl" / "amctl"))
    fifo = tmp_path / "p.npy"
    os.mkfifo(fifo)
    r = subprocess.run([exe, "plan", source_dir / "examples" / "30_belt_corner.gcode", "-o", fifo],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2
    assert "expected a regular file" in r.stderr and "p.npy" in r.stderr
