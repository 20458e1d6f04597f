"""amctl.sls3d: the same results as `amctl thermal sls3d --json` (docs/sls3d.md)."""

import json

import pytest

import amctl


def _engine_or_skip():
    try:
        amctl.sls3d(case="slab-flux", thickness_mm=0.1, times_s=[0.01])
    except amctl.Error as e:
        if "not available" in str(e) or "could not be loaded" in str(e):
            pytest.skip(str(e))
        raise


def test_slab_flux_matches_the_cli(cli):
    _engine_or_skip()
    r = amctl.sls3d(case="slab-flux", thickness_mm=1.0, flux_w_m2=1000.0, times_s=[0.5, 2.0])
    c = json.loads(cli("thermal", "sls3d", "--case", "slab-flux", "--thickness-mm", "1", "--flux-w-m2", "1000",
                       "--times-s", "0.5,2", "--json"))
    assert r["top_rise_k"] == pytest.approx(c["top_rise_k"], rel=1e-12)
    # The series on the same slab (Carslaw & Jaeger 3.3), to the model's accuracy.
    assert r["top_rise_k"] == pytest.approx(r["series_top_rise_k"], rel=1e-3)


def test_bad_config_is_an_error_with_its_place(tmp_path):
    _engine_or_skip()
    bad = tmp_path / "bad.toml"
    bad.write_text("[powder]\nconductivity_w_mk = -0.1\n")
    with pytest.raises(amctl.Error) as e:
        amctl.sls3d(bad)
    assert e.value.file == str(bad) and e.value.line == 2 and e.value.column is not None
    assert "conductivity" in e.value.detail


def test_unknown_case_and_wrong_type():
    with pytest.raises(amctl.Error):
        amctl.sls3d(case="no-such-case")
    with pytest.raises(TypeError):
        amctl.sls3d(case="slab-flux", thickness_mm="1")
