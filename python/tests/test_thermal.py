"""Thermal studies: closed forms and the seed's reference figures, and agreement with
`amctl thermal ... --json`."""

import math

import numpy as np
import pytest

import amctl


def test_sls_margins_truncation_error_is_the_closed_form():
    # ||G - G_1||_inf = 2 l/(k0 pi^2) (pi^2/6 - 1) (the tail of the modal series at w = 0);
    # with l = 0.1 m it exceeds the margin: Theorem 2 does not apply.
    r = amctl.sls_margins(length_mm=100.0, modes=1, hamiltonian_modes=20)
    want = 2 * 0.1 / (0.28 * math.pi ** 2) * (math.pi ** 2 / 6 - 1)
    assert r["hinf_G_minus_GN"] == pytest.approx(want, rel=1e-12)
    assert r["theorem2_applicable"] is False


def test_sls_margins_paper_pi_matches_the_scipy_reference():
    # tests/reference/thermal_powder_bed_tf.py (numpy grid + scipy bounded maximisation)
    r = amctl.sls_margins()
    assert r["margin_on_GN"] == pytest.approx(2.6390409866e-03, abs=1e-12)
    assert r["margin_on_G"] == pytest.approx(2.6856984441e-03, abs=1e-12)
    assert r["closed_loop_stable_GN"] is True


@pytest.mark.parametrize("kw,flags", [
    ({}, []),
    (dict(kp_w_m2k=0.5, ti_s=2.0, modes=3, length_mm=0.2, beta_1_s=-0.02),
     ["--kp", 0.5, "--ti", 2.0, "--modes", 3, "--length-mm", 0.2, "--beta", -0.02]),
])
def test_sls_margins_is_the_cli_json(cli, kw, flags):
    assert amctl.sls_margins(**kw) == cli.json("thermal", "sls-margins", *flags, "--json")


def test_sls_build_is_the_cli_json_with_the_trace(cli, tmp_path):
    csv = tmp_path / "trace.csv"
    want = cli.json("thermal", "sls", "--layers", 3, "--csv", csv, "--json")
    got = amctl.sls_build(layers=3)
    extra = {"per_layer", "trace"}
    assert {k: v for k, v in got.items() if k not in extra} == want
    assert len(got["per_layer"]) == 4  # the start-up interval and three additions
    assert max(p["dip_k"] for p in got["per_layer"]) == pytest.approx(want["max_dip_k"], rel=1e-12)
    t = np.genfromtxt(csv, delimiter=",", names=True)
    assert len(t) == len(got["trace"]["t_s"])
    assert np.allclose(got["trace"]["t_s"], t["t_s"], rtol=0, atol=5.1e-7)
    assert np.allclose(got["trace"]["y_c"], t["y_c"], rtol=0, atol=5.1e-7)
    assert np.array_equal(got["trace"]["layers"], t["layers"].astype(np.int32))


def test_hotend_and_bed_are_the_cli_json(cli):
    got = amctl.hotend()
    traces = got.pop("traces")
    assert got == cli.json("thermal", "hotend", "--json")
    assert set(traces) == {r["controller"] for r in got["runs"]}
    for tr in traces.values():
        assert tr["t_s"].shape == tr["measured_c"].shape == tr["duty"].shape
        assert tr["duty"].min() >= 0.0 and tr["duty"].max() <= 1.0
    b = amctl.bed(target_c=70.0, rule="some_overshoot")
    b.pop("traces")
    assert b == cli.json("thermal", "bed", "--target", 70, "--rule", "some_overshoot", "--json")


def test_thermal_errors():
    with pytest.raises(amctl.Error, match="modes"):
        amctl.sls_margins(modes=0)
    with pytest.raises(amctl.Error, match="length_mm"):
        amctl.sls_margins(length_mm=-1.0)
    with pytest.raises(TypeError, match="kp_w_m2k"):
        amctl.sls_margins(kp_w_m2k="0.3")
    with pytest.raises(amctl.Error, match="anti_windup"):
        amctl.sls_build(layers=1, anti_windup="sometimes")
    with pytest.raises(amctl.Error, match="rule"):
        amctl.hotend(rule="fast")
    with pytest.raises(TypeError, match="cycles"):
        amctl.hotend(cycles=4.5)


def test_the_cli_spellings_are_the_same_parameters():
    assert amctl.sls_margins(kp=0.5, ti=2.0, modes=3, beta=-0.02) == \
        amctl.sls_margins(kp_w_m2k=0.5, ti_s=2.0, modes=3, beta_1_s=-0.02)
    with pytest.raises(amctl.Error, match="kp_w_m2k or kp"):
        amctl.sls_margins(kp=0.5, kp_w_m2k=0.5)
