"""Tests of the measured surface reflectance library (`bandopt.datasets.surfaces`).

References used: a live read of the `earthlib` package (counts and values of the
vendored extract), the raw Illumina/ASTER files in ../shared/data/surfaces
(unit conversion), an independent asphalt spectrum (ASTER asphalt via Illumina),
and physical invariants (snow bright, water dark in the near infrared).
"""

import json
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt.datasets import _surfaces_build as build, surfaces as S  # noqa: N812
from bandopt.spectra import GRID_1NM


EARTHLIB_CLASS = {  # bandopt id -> earthlib LEVEL_3 (metadata column), stated by hand
    "asphalt": "asphalt",
    "road": "road",
    "parking_lot": "parking_lot",
    "sidewalk": "sidewalk",
    "driveway": "driveway",
    "composition_shingle": "comp_shingle",
    "wood_shingle": "wood_shingle",
    "tile_roof": "tile",
    "metal_roof": "metal",
    "concrete_roof_tile": "concrete_tile",
    "sand": "sand",
    "soil": "soil",
}
REQUIRED = (
    "asphalt", "road", "parking_lot", "sidewalk", "driveway", "composition_shingle",
    "wood_shingle", "tile_roof", "metal_roof", "concrete_roof_tile", "soil", "grass",
    "water", "snow",
)  # fmt: skip
ASTER = ("grass", "water", "snow")


@pytest.fixture(scope="module")
def earthlib_live():
    """earthlib's full library read directly: wavelengths [nm], spectra, metadata."""
    earthlib = pytest.importorskip("earthlib")
    from earthlib import config

    spectra, names, sensor = earthlib.read.envi_library(config.full_endmember_path)
    wl = np.asarray(sensor.band_centers, float) * 1000.0  # header is in micrometres
    return wl, np.asarray(spectra), config.full_metadata, list(names)


def _raw_value(path: Path, wavelength_um: float) -> float:
    """The second column of the line whose first column is `wavelength_um`."""
    for line in path.read_text().splitlines():
        parts = line.split()
        if len(parts) == 2 and abs(float(parts[0]) - wavelength_um) < 1e-9:
            return float(parts[1])
    raise LookupError(wavelength_um)


# ------------------------------------------------------------ contents


def test_at_least_ten_types_each_with_spectra():
    assert set(REQUIRED) <= set(S.SURFACE_TYPES)
    assert len(S.SURFACE_TYPES) >= 10
    for name in S.SURFACE_TYPES:
        s = S.surface(name)
        assert s.name == name
        assert s.n >= 1
        assert (
            s.reflectance.shape
            == (s.n, s.wavelength_nm.size)
            == (
                len(s.spectrum_ids),
                s.wavelength_nm.size,
            )
        )
        assert s.wavelength_nm[0] <= 380.0 and s.wavelength_nm[-1] >= 1100.0


def test_counts_match_live_earthlib_metadata(earthlib_live):
    _, _, meta, _ = earthlib_live
    live = meta.groupby("LEVEL_3").size()
    for name, cls in EARTHLIB_CLASS.items():
        if name == "soil":
            # a documented seeded subsample of 500 of all soil spectra
            assert S.surface(name).n == build.N_SOIL < live[cls]
            assert S.library_info()["classes"][name]["n_in_earthlib"] == live[cls]
        else:
            assert S.surface(name).n == live[cls], name
    # the numbers quoted in ../shared/data/README.md for the built classes
    quoted = {"asphalt": 18, "road": 170, "parking_lot": 48, "sidewalk": 60,
              "driveway": 9, "composition_shingle": 353, "wood_shingle": 34,
              "tile_roof": 18, "metal_roof": 18, "concrete_roof_tile": 31}  # fmt: skip
    assert {n: S.surface(n).n for n in quoted} == quoted
    assert live["soil"] == 4185


def test_vendored_spectra_equal_live_earthlib(earthlib_live):
    wl, spectra, meta, names = earthlib_live
    keep = (wl > 399.5) & (wl < 1100.5)
    for name, cls in EARTHLIB_CLASS.items():
        s = S.surface(name)
        rows = S._earthlib_npz()[f"rows__{name}"]
        assert set(meta["LEVEL_3"].to_numpy()[rows]) == {cls}
        assert list(s.spectrum_ids) == [names[i] for i in rows]
        assert len(set(rows)) == s.n  # no spectrum twice
        measured = s.wavelength_nm >= 400.0
        np.testing.assert_array_equal(s.wavelength_nm[measured], np.round(wl[keep]))
        np.testing.assert_array_equal(
            s.reflectance[:, measured], spectra[rows][:, keep]
        )


def test_build_script_reproduces_vendored_file():
    assert build.compare(build.extract()) == []


def test_vendored_aster_files_are_unchanged_copies(shared_dir):
    for name in ASTER:
        file = S._ASTER_TYPES[name][0]
        vendored = (S.DATA_DIR / file).read_bytes()
        assert vendored == (shared_dir / "data" / "surfaces" / file).read_bytes()


def test_values_in_unit_interval_before_any_clipping():
    data = S._earthlib_npz()
    for name in EARTHLIB_CLASS:
        r = data[f"reflectance__{name}"]
        assert np.all(np.isfinite(r)) and r.min() >= 0.0 and r.max() <= 1.0
    for name in ASTER:
        file, xu, yu, _ = S._ASTER_TYPES[name]
        _, r = S.read_aster(S.DATA_DIR / file, wavelength_unit=xu, reflectance_unit=yu)
        assert r.min() >= 0.0 and r.max() <= 1.0, name
    for s in S.surfaces().values():
        assert np.all(np.isfinite(s.reflectance))
        assert s.reflectance.min() >= 0.0 and s.reflectance.max() <= 1.0


def test_extrapolated_range_is_exactly_380_to_400_for_earthlib():
    for name in EARTHLIB_CLASS:
        s = S.surface(name)
        assert s.extrapolated_range_nm == (380.0, 400.0)
        assert s.measured_range_nm[0] == 400.0
        np.testing.assert_array_equal(s.wavelength_nm[s.extrapolated_mask], [380, 390])
        fine = s.resample(GRID_1NM)
        np.testing.assert_array_equal(
            fine.wavelength_nm[fine.extrapolated_mask], np.arange(380.0, 400.0)
        )
        # constant extrapolation: every flagged sample equals the 400 nm value
        at400 = fine.reflectance[:, fine.wavelength_nm == 400.0]
        np.testing.assert_array_equal(
            fine.reflectance[:, fine.extrapolated_mask],
            np.broadcast_to(at400, (fine.n, 20)),
        )
    for name in ASTER:
        assert S.surface(name).extrapolated_range_nm is None
        assert not S.surface(name).extrapolated_mask.any()


@pytest.mark.parametrize(
    ("name", "wavelength_um", "scale"),
    [("grass", 0.55, 0.01), ("grass", 0.85, 0.01), ("snow", 0.55, 0.01),
     ("water", 0.55, 1.0), ("water", 0.85, 1.0)],
)  # fmt: skip
def test_aster_units_against_raw_file(shared_dir, name, wavelength_um, scale):
    raw = _raw_value(shared_dir / "data" / "surfaces" / f"{name}.aster", wavelength_um)
    got = S.surfaces(name, [wavelength_um * 1000.0])[name].reflectance[0, 0]
    # percent -> fraction for grass and snow (20.497 % -> 0.20497), water as is
    assert got == pytest.approx(raw * scale, rel=1e-12)


# ------------------------------------------------------------ physics


def test_snow_brighter_than_every_asphalt_in_the_visible():
    grid = np.arange(400.0, 701.0)
    d = S.surfaces(["snow", "asphalt"], grid)
    assert d["snow"].reflectance.min() > 0.9  # fresh snow ~0.95 in the visible
    assert d["snow"].reflectance.min() > d["asphalt"].reflectance.max()


def test_water_darkest_in_the_near_infrared():
    grid = np.arange(900.0, 1101.0)
    names, mean = S.mean_reflectance(None, grid)
    nir = dict(zip(names, mean.mean(axis=1), strict=True))
    assert nir["water"] < 0.03  # liquid water absorbs strongly beyond 900 nm
    assert min(nir, key=nir.get) == "water"
    assert nir["grass"] > 0.3  # vegetation's NIR plateau


def test_asphalt_agrees_with_independent_aster_asphalt(shared_dir):
    # Illumina's ASTER asphalt (one sample, 0.42-14 um, percent): a different
    # sample of the same material, so within a factor 2, not equal.
    wl, r = S.read_aster(
        shared_dir / "data" / "surfaces" / "asphalt.aster",
        wavelength_unit="micrometers",
        reflectance_unit="percent",
    )
    assert wl[0] == pytest.approx(420.0)
    grid = np.arange(450.0, 701.0, 10.0)
    ref = np.interp(grid, wl, r)
    ours = S.surfaces("asphalt", grid)["asphalt"].reflectance
    assert np.all((ours.mean(axis=0) / ref > 0.5) & (ours.mean(axis=0) / ref < 2.0))
    assert np.all(ref <= ours.max(axis=0) * 1.1)  # near the bright end of the spread


# ------------------------------------------------------------ resampling


def test_resampling_keeps_values_at_the_nodes_and_is_linear_between():
    s = S.surface("road")
    fine = S.surfaces("road")["road"]
    at_nodes = np.isin(fine.wavelength_nm, s.wavelength_nm)
    assert at_nodes.sum() == 53  # 380, 390, ..., 900
    np.testing.assert_array_equal(
        fine.reflectance[:, at_nodes], s.reflectance[:, s.wavelength_nm <= 900]
    )
    i = np.searchsorted(s.wavelength_nm, 550.0)
    mid = fine.reflectance[:, fine.wavelength_nm == 555.0][:, 0]
    np.testing.assert_allclose(
        mid, 0.5 * (s.reflectance[:, i] + s.reflectance[:, i + 1])
    )
    grass = S.surface("grass")  # 1 nm native grid: unchanged on GRID_1NM
    np.testing.assert_array_equal(
        S.surfaces("grass")["grass"].reflectance,
        grass.reflectance[
            :, (grass.wavelength_nm >= 380) & (grass.wavelength_nm <= 900)
        ],
    )


@settings(deadline=None, max_examples=25)
@given(
    st.lists(st.floats(380.0, 1100.0), min_size=1, max_size=20, unique=True),
    st.sampled_from(S.SURFACE_TYPES),
)
def test_resampled_values_lie_between_neighbouring_samples(points, name):
    grid = np.sort(np.asarray(points))
    s = S.surface(name)
    out = s.resample(grid).reflectance
    hi = np.clip(np.searchsorted(s.wavelength_nm, grid), 1, s.wavelength_nm.size - 1)
    a, b = s.reflectance[:, hi - 1], s.reflectance[:, hi]
    tol = 1e-12
    assert np.all(out >= np.minimum(a, b) - tol) and np.all(
        out <= np.maximum(a, b) + tol
    )
    # linear interpolation commutes with the mean over spectra
    _, mean = S.mean_reflectance(name, grid)
    np.testing.assert_allclose(mean[0], out.mean(axis=0), rtol=1e-12, atol=1e-15)


def test_grid_outside_the_data_is_an_error():
    for bad in ([370.0, 500.0], [500.0, 1200.0]):
        with pytest.raises(ValueError, match=r"380-1100 nm"):
            S.surfaces("asphalt", bad)
    with pytest.raises(ValueError, match="strictly increasing"):
        S.mean_reflectance("asphalt", [500.0, 450.0])


# ------------------------------------------------------------ sampling, names


def test_sample_reflectance_draws_measured_spectra():
    grid = np.arange(400.0, 901.0, 10.0)
    draws = S.sample_reflectance("road", 1000, seed=1, wavelength_nm=grid)
    assert draws.shape == (1000, grid.size)
    table = S.surfaces("road", grid)["road"].reflectance
    match = np.all(draws[:, None, :] == table[None, :, :], axis=-1)
    assert np.all(match.any(axis=1))  # every draw is one measured spectrum
    # uniform with replacement: expected distinct = 170 (1 - exp(-1000/170)) = 169.5
    assert len(np.unique(match.argmax(axis=1))) > 150
    again = S.sample_reflectance("road", 1000, seed=1, wavelength_nm=grid)
    np.testing.assert_array_equal(draws, again)
    other = S.sample_reflectance("road", 1000, seed=2, wavelength_nm=grid)
    assert not np.array_equal(draws, other)
    assert S.sample_reflectance("snow", 0, seed=0).shape == (0, GRID_1NM.size)
    with pytest.raises(ValueError, match="`n`"):
        S.sample_reflectance("snow", -1, seed=0)


@pytest.mark.parametrize(
    ("given", "expected"),
    [("Parking Lot", "parking_lot"), ("PARKING-LOT", "parking_lot"),
     ("parkinglot", "parking_lot"), ("comp_shingle", "composition_shingle"),
     ("Concrete roof-tile", "concrete_roof_tile"), ("Snow", "snow")],
)  # fmt: skip
def test_names_match_ignoring_case_and_separators(given, expected):
    assert S.surface(given).name == expected


def test_unknown_name_lists_the_choices():
    with pytest.raises(ValueError, match=r"'concrete'.*'asphalt'.*'snow'"):
        S.surface("concrete")
    with pytest.raises(ValueError, match="Unknown surface type"):
        S.mean_reflectance(["grass", "lava"])


def test_sets_are_immutable_and_validated():
    s = S.surface("asphalt")
    with pytest.raises(ValueError, match="read-only"):
        s.reflectance[0, 0] = 0.5
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        S.SurfaceSet(
            name="x", wavelength_nm=np.array([400.0, 500.0]),
            reflectance=np.array([[0.5, 1.2]]), source="Anderson2023",
            extrapolated_range_nm=None, measured_range_nm=(400.0, 500.0),
            spectrum_ids=("a",),
        )  # fmt: skip


def test_source_keys_resolve_in_references():
    bib = (Path(S.__file__).parent / "references.bib").read_text()
    keys = set(re.findall(r"@\w+\{([^,]+),", bib))
    assert {S.surface(n).source for n in S.SURFACE_TYPES} <= keys
    assert {"Baldridge2009", "Herold2004"} <= keys  # cited in docstrings


# ------------------------------------------------------------ ASTER parser

HEADER = """Name: Test grass
Type: Vegetation
Description: two lines of
  description without a colon
X Units: Wavelength (micrometers)
Y Units: Reflectance (percent)
First X Value: 0.4200
Last X Value: 0.4000
Number of X Values: 3

0.4200 10.0
0.4100 20.0
0.4000 40.0
"""


def test_aster_header_gives_units_and_order(tmp_path):
    path = tmp_path / "h.aster"
    path.write_text(HEADER)
    wl, r = S.read_aster(path)
    np.testing.assert_allclose(wl, [400.0, 410.0, 420.0])  # descending file sorted
    np.testing.assert_allclose(r, [0.4, 0.2, 0.1])


UM_PCT = {"wavelength_unit": "um", "reflectance_unit": "%"}


@pytest.mark.parametrize(
    ("text", "kwargs", "match"),
    [
        ("0.40 10\n0.41 abc\n", UM_PCT,
         r"line 2"),
        ("0.40 10\n0.41 11 12\n", UM_PCT,
         r"line 2.*two numbers"),
        ("0.40 10\n0.41 11\n", {"reflectance_unit": "%"}, r"'X Units'"),
        ("0.40 10\n0.41 11\n", {"wavelength_unit": "um"}, r"'Y Units'"),
        ("0.40 10\n0.41 55\n", {**UM_PCT, "reflectance_unit": "fraction"},
         r"'Y Units'"),
        ("0.40 10\n0.41 11\n", {**UM_PCT, "wavelength_unit": "furlongs"},
         r"wavelength_unit.*unknown unit"),
        ("0.40 10\n0.42 11\n0.41 12\n", UM_PCT,
         r"line 3.*monotonic"),
        ("hello world\n0.40 10\n", {}, r"line 1"),
        (HEADER.replace("Number of X Values: 3", "Number of X Values: 4"), {},
         r"'Number of X Values'"),
        (HEADER.replace("(percent)", "(emissivity)"), {}, r"'Y Units'.*unknown unit"),
        (HEADER.replace("Last X Value: 0.4000", "Last X Value: 0.3900"), {},
         r"'Last X Value'"),
        (HEADER, {"reflectance_unit": "fraction"}, r"'Y Units' says"),
        ("0.40 10\n", UM_PCT,
         r"fewer than two"),
        ("400 10\n410 11\n", UM_PCT,
         r"'X Units'"),
    ],
)  # fmt: skip
def test_bad_aster_input_names_the_file(tmp_path, text, kwargs, match):
    path = tmp_path / "broken_grass.aster"
    path.write_text(text)
    with pytest.raises(ValueError, match=match) as err:
        S.read_aster(path, **kwargs)
    assert "broken_grass.aster" in str(err.value)


# ------------------------------------------------------------ CLI


def test_cli_json_and_plot(tmp_path, capsys):
    from bandopt.cli import main

    out = tmp_path / "surfaces.png"
    assert main(["surfaces", "--json", "--plot", str(out)]) == 0
    doc = json.loads(capsys.readouterr().out)
    rows = {r["name"]: r for r in doc["types"]}
    assert tuple(rows) == S.SURFACE_TYPES
    assert rows["soil"]["n"] == 500 and rows["soil"]["n_in_source"] == 4185
    assert rows["road"]["extrapolated_range_nm"] == [380.0, 400.0]
    for r in rows.values():
        assert np.all(np.asarray(r["percentile_low"]) <= r["percentile_high"])
        assert all(0.0 <= m <= 1.0 for m in r["mean"])
    assert out.stat().st_size > 10_000
    assert main(["surfaces", "--percentiles", "90", "10"]) == 2
    with pytest.raises(SystemExit) as exit_:
        main(["surfaces", "--help"])
    assert exit_.value.code == 0
