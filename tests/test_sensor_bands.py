"""BandSet parametrisation, JSON input/output, tabulated bands, CSV export."""

import csv
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt.sensor import BandSet, TabulatedBands, export_response_csv
from bandopt.spectra import GRID_1NM


WL = jnp.asarray(GRID_1NM)


@settings(deadline=None, max_examples=20)
@given(
    bands=st.lists(
        st.tuples(st.floats(0.0, 1.0), st.floats(15.0, 400.0), st.floats(2.0, 50.0)),
        min_size=1,
        max_size=5,
    )
)
def test_json_round_trip(tmp_path_factory, bands):
    centre = [380 + f / 2 + u * (520 - f) for u, f, _ in bands]
    fwhm = [f for _, f, _ in bands]
    k = [kk for _, _, kk in bands]
    original = BandSet.from_physical(centre, fwhm, k, name="round trip")
    path = tmp_path_factory.mktemp("json") / "bands.json"
    original.to_json(path)
    again = BandSet.from_json(path)
    assert again.names == original.names and again.name == "round trip"
    for attr in ("centre_nm", "fwhm_nm", "shape_k"):
        np.testing.assert_allclose(getattr(again, attr), getattr(original, attr), 1e-9)


def test_physical_parameters_are_recovered_and_bounded():
    b = BandSet.from_physical(
        [400.0, 589.0, 880.0], [40.0, 15.0, 40.0], [2.0, 6.0, 50.0]
    )
    # supports on the range ends and FWHM on its floor are nudged 1e-9 inside
    np.testing.assert_allclose(b.centre_nm, [400.0, 589.0, 880.0], atol=1e-6)
    np.testing.assert_allclose(b.fwhm_nm, [40.0, 15.0, 40.0], atol=1e-6)
    np.testing.assert_allclose(b.shape_k, [2.0, 6.0, 50.0], rtol=1e-12)
    # any raw values give supports inside the data range and FWHM >= floor
    raw = jax.random.normal(jax.random.key(0), (3, 1000)) * 20
    wild = BandSet(raw[0], raw[1], raw[2], names=tuple(f"b{i}" for i in range(1000)))
    edges = np.asarray(wild.edges_nm)
    assert edges.min() >= 380.0 - 1e-9 and edges.max() <= 900.0 + 1e-9  # rounding
    assert float(wild.fwhm_nm.min()) >= 15.0
    assert float(wild.shape_k.min()) >= 1.5 and float(wild.shape_k.max()) <= 100


def test_from_edges_reads_fifty_percent_points():
    b = BandSet.from_edges([(430, 512), (489, 585)], names=["blue", "green"])
    np.testing.assert_allclose(b.centre_nm, [471.0, 537.0], rtol=1e-12)
    np.testing.assert_allclose(b.fwhm_nm, [82.0, 96.0], rtol=1e-9)
    r = b.response(jnp.asarray([430.0, 512.0, 489.0, 585.0]))
    np.testing.assert_allclose(r[0, :2], 0.5, rtol=1e-9)
    np.testing.assert_allclose(r[1, 2:], 0.5, rtol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"centre_nm": [560.0], "fwhm_nm": [10.0]}, "below min_fwhm_nm=15"),
        ({"centre_nm": [890.0], "fwhm_nm": [40.0]}, "leaves the data range"),
        ({"centre_nm": [560.0], "fwhm_nm": [40.0], "shape_k": [200.0]}, "shape_k=200"),
        ({"centre_nm": [560.0, 600.0], "fwhm_nm": [40.0], "names": ["a"]}, "names"),
    ],
)
def test_bad_physical_parameters_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        BandSet.from_physical(**kwargs)


def test_narrow_band_needs_explicit_floor():
    b = BandSet.from_physical([560.0], [3.0], min_fwhm_nm=1.0)
    np.testing.assert_allclose(b.fwhm_nm, [3.0], rtol=1e-9)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("{not json", r"bad\.json: invalid JSON"),
        ('{"name": "x"}', r"bad\.json: bands: expected a non-empty list"),
        ('{"bands": [{"centre_nm": 500}]}', r"bad\.json: bands\[0\]\.fwhm_nm: missing"),
        (
            '{"bands": [{"centre_nm": 500, "fwhm_nm": -4}]}',
            r"bands\[0\]\.fwhm_nm: expected a positive",
        ),
        (
            '{"bands": [{"centre_nm": "500", "fwhm_nm": 40}]}',
            r"bands\[0\]\.centre_nm: expected a number, got '500'",
        ),
        (
            '{"bands": [{"centre_nm": 500, "fwhm_nm": 40, "width": 3}]}',
            r"bands\[0\]\.width: unknown field",
        ),
        (
            '{"bands": [{"edges_nm": [600, 500]}]}',
            r"bands\[0\]\.edges_nm: need lower < upper",
        ),
        (
            # beyond a range the file states (without one the range widens and
            # the commands' coverage rule applies: tests/test_cli_inputs.py)
            '{"range_nm": [380, 900], "bands": [{"centre_nm": 880, "fwhm_nm": 60}]}',
            r"bad\.json: bands: Band 'B1': support 850-910 nm",
        ),
        (
            '{"bands": [{"name": "a", "centre_nm": 500, "fwhm_nm": 40},'
            ' {"name": "a", "centre_nm": 600, "fwhm_nm": 40}]}',
            "names must be unique",
        ),
    ],
)
def test_bad_json_names_file_and_field(tmp_path, text, match):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        BandSet.from_json(path)


def test_json_accepts_edges_and_range(tmp_path):
    path = tmp_path / "dmsp.json"
    path.write_text(
        json.dumps(
            {
                "name": "d",
                "range_nm": [380, 1101],
                "bands": [{"name": "PAN", "edges_nm": [400, 1100]}],
            }
        )
    )
    b = BandSet.from_json(path)
    np.testing.assert_allclose(b.centre_nm, [750.0], rtol=1e-9)
    np.testing.assert_allclose(b.shape_k, [6.0], rtol=1e-12)  # thesis default
    assert b.upper_nm == 1101.0


def test_tabulated_band_matches_table_and_reports_what_is_off_grid():
    wl = np.arange(850.0, 951.0, 1.0)
    r = np.clip(1 - np.abs(wl - 900) / 50, 0, None)  # triangle 850-950, peak at 900
    t = TabulatedBands.from_table(wl, r, names=["tri"])
    np.testing.assert_allclose(t.fraction_outside(WL), [0.5], atol=1e-9)
    np.testing.assert_allclose(t.edges_nm, [[875.0, 925.0]])
    np.testing.assert_allclose(t.centre_nm, [900.0])
    np.testing.assert_allclose(
        t.response(jnp.asarray([800.0, 875.5, 1000.0])), [[0.0, 0.51, 0.0]]
    )
    with pytest.raises(ValueError, match="tri"):
        t.band_average(jnp.ones(WL.shape), WL)


def test_tabulated_copy_of_a_band_set_agrees():
    b = BandSet.from_physical([500.0, 700.0], [60.0, 100.0], [6.0, 3.0])
    t = TabulatedBands.from_bands(b, np.arange(300.0, 1000.0, 0.25))
    np.testing.assert_allclose(t.response(WL), b.response(WL), atol=1e-4)
    np.testing.assert_allclose(t.area_nm(), b.area_nm(), rtol=1e-5)
    np.testing.assert_allclose(t.fwhm_nm, b.fwhm_nm, rtol=1e-4)


def test_csv_export(tmp_path):
    b = BandSet.from_physical([450.0, 650.0], [40.0, 80.0], names=["blue", "red"])
    path = export_response_csv(b, tmp_path / "r.csv")
    with path.open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["wavelength_nm", "blue", "red"]
    assert len(rows) == 1 + len(GRID_1NM)
    table = np.asarray(rows[1:], float)
    np.testing.assert_allclose(table[:, 0], GRID_1NM)
    np.testing.assert_allclose(table[:, 1:].T, b.response(WL), rtol=1e-7, atol=1e-300)


@pytest.mark.parametrize("n", [2, 13, 52])
def test_contiguous_bands_tile_the_range_meeting_at_half_maximum(n):
    b = BandSet.contiguous(n)
    width = (900.0 - 380.0) / n
    assert len(b) == n and b.name == f"contiguous-{n}" and b.names[-1] == f"C{n}"
    np.testing.assert_allclose(b.fwhm_nm, width, rtol=1e-6)
    edges = np.asarray(b.edges_nm)
    np.testing.assert_allclose(edges[0, 0], 380.0, atol=1e-6)
    np.testing.assert_allclose(edges[-1, 1], 900.0, atol=1e-6)
    np.testing.assert_allclose(edges[1:, 0], edges[:-1, 1], atol=1e-6)  # no gaps
    # each band is at half maximum where its neighbour is: the two meet there
    r = np.asarray(b.response(jnp.asarray(edges[:-1, 1])))
    idx = np.arange(n - 1)
    np.testing.assert_allclose(r[idx, idx], 0.5, rtol=1e-5)
    np.testing.assert_allclose(r[idx + 1, idx], 0.5, rtol=1e-5)


@pytest.mark.parametrize("n", [1, 0, -3, True])
def test_contiguous_bands_refuse_a_bad_count(n):
    with pytest.raises(ValueError, match="integer n >= 2"):
        BandSet.contiguous(n)


def test_contiguous_bands_round_trip_through_a_band_set_file(tmp_path):
    path = tmp_path / "c26.json"
    BandSet.contiguous(26).to_json(path)
    back = BandSet.from_json(path)
    np.testing.assert_allclose(back.centre_nm, BandSet.contiguous(26).centre_nm)
    np.testing.assert_allclose(back.fwhm_nm, 20.0, rtol=1e-6)
    # 10 nm bands are below what a band-set file may hold: refused, said why
    BandSet.contiguous(52).to_json(path)
    with pytest.raises(ValueError, match="fwhm_nm=10 is below min_fwhm_nm=15"):
        BandSet.from_json(path)
