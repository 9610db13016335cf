"""Issue 15, property test: over random band sets and spectra, every command's
JSON is valid (strict: no NaN/Infinity) and no number leaves its physical
range. Few examples, no deadline: each example runs the real command."""

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from bandopt.cli import main


SETTINGS = dict(
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
    derandomize=True,
)
K_M = 683.002  # lm/W: no spectrum has a larger luminous efficacy


def strict(text: str):
    def bad(c):
        raise ValueError(f"invalid JSON constant {c}")

    return json.loads(text, parse_constant=bad)


# a spectrum: a few emission bands (centre, width, height), some possibly
# entirely outside the visible, plus an optional flat continuum
peak = st.tuples(
    st.floats(380.0, 900.0), st.floats(0.5, 150.0), st.floats(0.0, 1.0)
)
spectra = st.tuples(st.lists(peak, min_size=1, max_size=4), st.floats(0.0, 0.2))


def _spectrum(spec):
    peaks, flat = spec
    w = np.arange(380.0, 901.0)
    s = np.full(w.shape, flat)
    for c, width, h in peaks:
        s += h * np.exp(-0.5 * ((w - c) / (width / 2.3548)) ** 2)
    if not s.max() > 0:
        s[-1] = 1.0  # validate_spectrum needs a positive value somewhere
    return w, s


@settings(max_examples=12, **SETTINGS)
@given(spec=spectra)
def test_metrics_json_is_valid_and_physical(spec, tmp_path_factory, capsys):
    w, s = _spectrum(spec)
    f = tmp_path_factory.mktemp("m") / "s.csv"
    f.write_text("\n".join(f"{a:g},{b:.10g}" for a, b in zip(w, s, strict=True)))
    assert main(["metrics", str(f), "--json"]) == 0
    (row,) = strict(capsys.readouterr().out)
    for k in ("LER", "LER_full_range"):
        assert row[k] is None or 0.0 <= row[k] <= K_M * (1 + 1e-9), row
    if row["LER"] is None:
        assert "LER" in row["null_reason"]
    assert row["CCT"] is None or row["CCT"] > 0
    assert row["Duv"] is None or abs(row["Duv"]) < 1.0
    assert row["G"] is None or np.isfinite(row["G"])


bands_st = st.lists(
    st.tuples(st.floats(390.0, 890.0), st.floats(5.0, 200.0), st.floats(2.0, 20.0)),
    min_size=1,
    max_size=5,
)


def _band_json(path, bands):
    path.write_text(
        json.dumps(
            {
                "name": "random",
                "bands": [
                    {"name": f"b{i}", "centre_nm": c, "fwhm_nm": f, "shape_k": k}
                    for i, (c, f, k) in enumerate(bands)
                ],
            }
        )
    )
    return path


@settings(max_examples=8, **SETTINGS)
@given(bands=bands_st)
def test_bands_json_is_valid_and_physical(bands, tmp_path_factory, capsys):
    f = _band_json(tmp_path_factory.mktemp("b") / "bands.json", bands)
    rc = main(["bands", str(f), "--json"])
    cap = capsys.readouterr()
    if rc != 0:  # refused: one line naming the file
        assert rc == 2 and str(f) in cap.err and cap.out == ""
        return
    info = strict(cap.out)
    for b in info["bands"]:
        assert b["fwhm_nm"] > 0 and 0.0 <= b["fraction_outside_grid"] <= 1.0
        lo, hi = b["half_max_edges_nm"]
        assert lo < b["centre_nm"] < hi


@settings(max_examples=3, **SETTINGS)
@given(bands=bands_st, noise=st.booleans())
def test_simulate_json_is_valid_and_physical(bands, noise, tmp_path_factory, capsys):
    d = tmp_path_factory.mktemp("s")
    f = _band_json(d / "bands.json", bands)
    args = ["--bands", str(f), "--lamps", "nist_traditional_hps", "cie_led_b1",
            "--surfaces", "asphalt", "--moon", "none", "--classes", "P4",
            "--atmospheres", "none", "--out", str(d / "out"), "--json"]  # fmt: skip
    rc = main(["simulate", *args, *(["--noise"] if noise else [])])
    cap = capsys.readouterr()
    if rc != 0:
        assert rc == 2 and str(f) in cap.err and cap.out == ""
        return
    out = strict(cap.out)
    for b in out["per_band"].values():
        assert b["min"] <= b["median"] <= b["max"]
        if not noise:  # noise-free radiance is never negative
            assert b["min"] >= 0.0 and b["negative_fraction"] == 0.0


@pytest.mark.slow  # trains the estimators per band set (~40 s each)
@settings(max_examples=2, **SETTINGS)
@given(bands=bands_st, spec=spectra)
def test_evaluate_estimates_stay_in_range(bands, spec, tmp_path_factory, capsys):
    d = tmp_path_factory.mktemp("e")
    f = _band_json(d / "bands.json", bands)
    w, s = _spectrum(spec)
    lamp = d / "lamp.csv"
    lamp.write_text("\n".join(f"{a:g},{b:.10g}" for a, b in zip(w, s, strict=True)))
    rc = main(["evaluate", "--bands", str(f), "--lamps", str(lamp), "--json"])
    cap = capsys.readouterr()
    if rc != 0:
        assert rc == 2 and cap.out == ""
        return
    (row,) = strict(cap.out)["lamps"]
    est = row["estimate"]
    assert est["LER"] is None or 0.0 <= est["LER"] <= K_M
    assert est["CCT"] is None or est["CCT"] > 0
