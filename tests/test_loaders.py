"""User spectrum loaders: round trips, clear errors, property tests."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt.datasets.loaders import (
    SpectrumWarning,
    read_csv,
    read_prn,
    read_spectrum,
    read_tm27,
)


def _write_csv(path, w, v, header=True, sep=","):
    lines = (["wavelength_nm,value"] if header else []) + [
        f"{float(a)!r}{sep}{float(b)!r}" for a, b in zip(w, v, strict=True)
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


_grid = st.integers(min_value=10, max_value=200).flatmap(
    lambda n: st.tuples(
        st.just(np.linspace(380.0, 780.0, n)),
        st.lists(st.floats(0.0, 1e6, allow_nan=False), min_size=n, max_size=n),
    )
)


@settings(deadline=None, max_examples=30)
@given(data=_grid, header=st.booleans(), sep=st.sampled_from([",", ";", "\t", " "]))
def test_csv_round_trip(tmp_path_factory, data, header, sep):
    w, v = data
    v = np.asarray(v)
    if v.max() <= 0:
        v[0] = 1.0
    path = _write_csv(tmp_path_factory.mktemp("csv") / "s.csv", w, v, header, sep)
    s = read_csv(path)
    np.testing.assert_array_equal(s.wavelength_nm, w)
    np.testing.assert_array_equal(s.values, v)


@settings(deadline=None, max_examples=30)
@given(
    data=_grid,
    i=st.integers(0, 8),
    kind=st.sampled_from(["dup", "decrease", "nan", "neg"]),
)
def test_csv_bad_input_names_file_and_problem(tmp_path_factory, data, i, kind):
    w, v = data
    w, v = w.copy(), np.asarray(v) + 1.0
    if kind == "dup":
        w[i + 1] = w[i]
        match = "duplicate wavelength"
    elif kind == "decrease":
        w[i], w[i + 1] = w[i + 1], w[i]
        match = "not increasing"
    elif kind == "nan":
        v[i] = np.nan
        match = "NaN"
    else:
        v[i] = -0.02 * v.max() - 1.0
        match = "negative beyond"
    path = _write_csv(tmp_path_factory.mktemp("bad") / "bad.csv", w, v)
    with pytest.raises(ValueError, match=match) as err:
        read_csv(path)
    assert "bad.csv" in str(err.value)


def test_small_negatives_clipped_with_warning(tmp_path):
    w = np.linspace(380, 780, 50)
    v = np.ones(50)
    v[3] = -0.005
    with pytest.warns(SpectrumWarning, match="clipped"):
        s = read_csv(_write_csv(tmp_path / "n.csv", w, v))
    assert s.values[3] == 0.0


@pytest.mark.parametrize(
    ("w", "match"),
    [
        (np.linspace(380, 780, 5), "at least 10"),
        (np.linspace(400, 780, 50), "does not cover"),
    ],
)
def test_too_few_points_or_short_range(tmp_path, w, match):
    with pytest.raises(ValueError, match=match):
        read_csv(_write_csv(tmp_path / "x.csv", w, np.ones(w.size)))


def test_unknown_unit_and_bad_line(tmp_path):
    path = _write_csv(tmp_path / "u.csv", np.linspace(380, 780, 20), np.ones(20))
    with pytest.raises(ValueError, match="unknown unit 'furlongs'"):
        read_csv(path, unit="furlongs")
    path.write_text("wavelength_nm,value\n380,1\n390,abc\n")
    with pytest.raises(ValueError, match="line 3"):
        read_csv(path)
    with pytest.raises(ValueError, match="unknown file type"):
        read_spectrum(_write_csv(tmp_path / "x.foo", [1], [1]))


def test_photon_units_converted(tmp_path):
    w = np.linspace(380, 780, 41)
    q = np.ones(41)
    s = read_csv(_write_csv(tmp_path / "q.csv", w, q), unit="umol m-2 s-1 nm-1")
    np.testing.assert_allclose(s.values, 119.627 / w)


def test_prn_reads_li1800_layout(shared_dir):
    s = read_prn(shared_dir / "data/lamps_nir_li1800/Osram.HQIT.400W.PRN")
    assert s.measured_range_nm == (300.0, 900.0)
    raw = np.loadtxt(
        shared_dir / "data/lamps_nir_li1800/Osram.HQIT.400W.PRN", comments='"'
    )
    np.testing.assert_allclose(s.values, raw[:, 1] * 119.627 / raw[:, 0])


def test_prn_without_unit_rejected(tmp_path):
    body = "\n".join(f" {w}  1.0" for w in range(300, 901, 10))
    (tmp_path / "x.PRN").write_text('"FILE:X"\n"REM: something"\n' + body)
    with pytest.raises(ValueError, match="REM"):
        read_prn(tmp_path / "x.PRN")


def test_tm27_round_trip(tmp_path):
    import colour

    sd = colour.SDS_ILLUMINANTS["LED-B3"].copy()
    tm = colour.SpectralDistribution_IESTM2714(
        data=dict(zip(sd.wavelengths, sd.values, strict=True)),
        spectral_quantity="relative",
        header=colour.io.tm2714.Header_IESTM2714(
            manufacturer="test", description="LED-B3"
        ),
    )
    tm.path = str(tmp_path / "led.xml")
    tm.write()
    s = read_tm27(tmp_path / "led.xml")
    np.testing.assert_allclose(s.values, sd.values, rtol=1e-6)
    (tmp_path / "broken.xml").write_text("<not xml")
    with pytest.raises(ValueError, match=r"broken\.xml"):
        read_tm27(tmp_path / "broken.xml")
