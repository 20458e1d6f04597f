"""Shared fixtures of the Python tests (run by CTest as python_tests, docs/python.md).

CTest sets PYTHONPATH=<build>/python, AMCTL_CLI (the built `amctl`) and AMCTL_SOURCE_DIR.
Run by hand:
    PYTHONPATH=build/release/python AMCTL_CLI=build/release/apps/amctl/amctl \\
        /usr/bin/python3 -m pytest -q python/tests
"""

import json
import os
import pathlib
import subprocess

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("AMCTL_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))


@pytest.fixture(scope="session")
def source_dir():
    return SOURCE_DIR


@pytest.fixture(scope="session")
def cli():
    """Runs the built amctl CLI; returns stdout (str). Fails (not skips) without it: the
    agreement checks are part of the suite."""
    exe = os.environ.get("AMCTL_CLI")
    if not exe:
        guess = SOURCE_DIR / "build" / "release" / "apps" / "amctl" / "amctl"
        exe = str(guess)
    assert pathlib.Path(exe).is_file(), f"amctl CLI not found at {exe}: set AMCTL_CLI"

    def run(*args):
        r = subprocess.run([exe, *map(str, args)], capture_output=True, text=True)
        assert r.returncode == 0, f"amctl {' '.join(map(str, args))} failed: {r.stderr}"
        return r.stdout

    def run_json(*args):
        return json.loads(run(*args))

    run.json = run_json
    return run


@pytest.fixture
def gcode(tmp_path):
    """Writes G-code text to a file and returns its path (str)."""
    def write(text, name="t.gcode"):
        p = tmp_path / name
        p.write_text(text)
        return str(p)
    return write


# The machine of the closed forms (tests/plan/estimate_test.cpp): 300 mm/s, 5000 mm/s^2,
# full stops at every corner (square_corner_velocity 0), no cruise-ratio limit.
SIMPLE = {"printer.max_velocity": 300, "printer.max_accel": 5000,
          "printer.square_corner_velocity": 0, "printer.minimum_cruise_ratio": 0}
