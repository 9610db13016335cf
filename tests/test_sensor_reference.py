"""Reference sensor registry, vendored VIIRS DNB table, and `bandopt bands`."""

import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from bandopt.cli import main
from bandopt.sensor import REFERENCE_SENSORS, BandSet, TabulatedBands, reference_sensor
from bandopt.sensor.reference import resolve
from bandopt.spectra import GRID_1NM


BIB = Path(__file__).resolve().parents[1] / "bandopt" / "datasets" / "references.bib"
CLI_NAMES = [
    "viirs-dnb", "viirs-dnb-tabulated", "dmsp-ols", "sac-c", "sac-d", "cumulos",
    "luojia-1-01", "aerocube", "iss-dslr", "jilin-1-03b", "eros-b", "sdgsat-1",
    "nightsat",
]  # fmt: skip


def test_registry_names_resolve_ignoring_case_and_separators():
    assert sorted(REFERENCE_SENSORS) == sorted(CLI_NAMES)
    for name in CLI_NAMES:
        variant = name.upper().replace("-", "_")
        assert resolve(variant).key == name
        bands = reference_sensor(name)
        assert isinstance(bands, BandSet | TabulatedBands)
        assert len(bands.names) >= 1
    with pytest.raises(ValueError, match=r"expected one of \['aerocube'"):
        reference_sensor("landsat-9")


def test_every_citation_resolves_in_the_bibliography():
    keys = set(re.findall(r"@\w+\{([^,]+),", BIB.read_text()))
    for entry in REFERENCE_SENSORS.values():
        assert entry.citations and set(entry.citations) <= keys, entry.key
        assert entry.response_note


@pytest.mark.parametrize(
    ("name", "edges"),
    [
        ("dmsp-ols", [(400, 1100)]),
        ("luojia-1-01", [(460, 980)]),
        ("aerocube", [(400, 512), (480, 590), (560, 850)]),
        ("iss-dslr", [(420, 500), (490, 585), (580, 640)]),
        ("jilin-1-03b", [(430, 512), (489, 585), (580, 720)]),
        ("sdgsat-1", [(450, 900), (430, 520), (520, 615), (615, 900)]),
    ],
)
def test_published_edges_are_half_maximum_points(name, edges):
    bands = reference_sensor(name)
    np.testing.assert_allclose(bands.edges_nm, edges, atol=1e-6)
    np.testing.assert_allclose(bands.shape_k, 6.0, rtol=1e-9)


def test_bands_past_the_data_limit_report_lost_area():
    """DMSP-OLS reaches 1100 nm: the lost share equals an independent integral."""
    import scipy.integrate

    bands = reference_sensor("dmsp-ols")
    lost = float(bands.fraction_outside(GRID_1NM)[0])
    f = lambda x: 2.0 ** -(abs(2 * (x - 750.0) / 700.0) ** 6)  # noqa: E731
    total = scipy.integrate.quad(f, -2000, 3000, limit=200)[0]
    inside = scipy.integrate.quad(f, 380, 900)[0]
    np.testing.assert_allclose(lost, 1 - inside / total, rtol=1e-8)
    with pytest.raises(ValueError, match="outside the data grid"):
        bands.band_average(np.ones(GRID_1NM.size), GRID_1NM)


def test_vendored_viirs_table_is_the_shared_file(shared_dir):
    raw = np.loadtxt(
        shared_dir / "data/sensors/viirs_dnb_relative_response.dat", skiprows=1
    )
    bands = reference_sensor("viirs-dnb-tabulated")
    np.testing.assert_array_equal(bands.table_wavelength_nm, raw[:, 0])
    np.testing.assert_array_equal(bands.table_response[0], raw[:, 1])
    # half-maximum points stated in the data README
    np.testing.assert_allclose(bands.edges_nm[0], [501.5, 878.5], atol=0.5)
    assert float(bands.fraction_outside(GRID_1NM)[0]) == pytest.approx(0.0, abs=1e-12)
    assert "899.5" in bands.source_note


def test_nightsat_eye_bands_are_cie_curves():
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message='"Matplotlib" related API')
        from colour.colorimetry import SDS_LEFS_PHOTOPIC, SDS_LEFS_SCOTOPIC
    bands = reference_sensor("nightsat")
    entry = resolve("Nightsat")
    assert entry.detection_limit_w_m2_sr_nm == 2.5e-7 and entry.gsd_m == (50.0, 100.0)
    assert "reconstruction" in entry.title
    w = np.arange(400.0, 760.0, 7.0)
    r = np.asarray(bands.response(w))
    v = SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    vs = SDS_LEFS_SCOTOPIC["CIE 1951 Scotopic Standard Observer"]
    np.testing.assert_allclose(r[bands.names.index("photopic-V")], v[w], atol=1e-12)
    np.testing.assert_allclose(r[bands.names.index("scotopic-V'")], vs[w], atol=1e-12)


def test_cli_json_plot_and_csv(tmp_path, capsys):
    png, table = tmp_path / "b.png", tmp_path / "b.csv"
    rc = main(["bands", "Jilin_1_03B", "--json", "--plot", str(png),
               "--export-csv", str(table)])  # fmt: skip
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert info["key"] == "jilin-1-03b" and len(info["bands"]) == 3
    assert info["bands"][0]["half_max_edges_nm"] == [430.0, 512.0]
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    assert table.read_text().splitlines()[0] == "wavelength_nm,blue,green,red"


def test_cli_reads_a_json_file_and_reports_errors(tmp_path, capsys):
    good = tmp_path / "mine.json"
    BandSet.from_physical([589.0], [20.0], names=["Na"], name="mine").to_json(good)
    assert main(["bands", str(good)]) == 0
    assert "Na" in capsys.readouterr().out
    bad = tmp_path / "bad.json"
    bad.write_text('{"bands": [{"centre_nm": 500}]}')
    assert main(["bands", str(bad)]) == 2
    assert "bad.json: bands[0].fwhm_nm: missing" in capsys.readouterr().err
    assert main(["bands", "nope"]) == 2
    assert "expected one of" in capsys.readouterr().err
