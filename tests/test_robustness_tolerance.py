"""The robustness study as a tolerance scan: as-built sensors, rows paired
with the nominal one, and the intervals read from a summary."""

import json

import numpy as np
import pytest

from bandopt import robustness as rb
from bandopt.sensor.reference import resolve_band_set
from tests.test_robustness import LIGHT, STUDY


def test_as_built_moves_one_band_or_all():
    bands = resolve_band_set(STUDY.band_sets[0][1]).bands
    name = bands.names[0]
    moved = rb.as_built(bands, rb.Perturbation("band-centre", 5.0, name))
    np.testing.assert_allclose(moved.centre_nm[0], bands.centre_nm[0] + 5.0)
    np.testing.assert_allclose(moved.centre_nm[1:], bands.centre_nm[1:])
    wide = rb.as_built(bands, rb.Perturbation("band-fwhm", 2.0, name))
    np.testing.assert_allclose(wide.fwhm_nm[0], 2.0 * bands.fwhm_nm[0])
    np.testing.assert_allclose(wide.fwhm_nm[1:], bands.fwhm_nm[1:])
    wl = np.linspace(380.0, 900.0, 521)
    leak = np.asarray(rb.as_built(bands, rb.Perturbation("leakage", 0.01)).response(wl))
    assert leak.min() >= 0.01 - 1e-9  # a floor everywhere in the data range
    aoi = rb.as_built(bands, rb.Perturbation("aoi", 20.0))
    assert np.all(np.asarray(aoi.centre_nm) < np.asarray(bands.centre_nm))  # blue
    assert rb.as_built(bands, rb.Perturbation("clean")) is bands
    with pytest.raises(ValueError, match="band 'X9' is not in the band set"):
        rb.as_built(bands, rb.Perturbation("band-centre", 1.0, "X9"))
    with pytest.raises(ValueError, match="a band is named"):
        rb.Perturbation("band-fwhm", 1.1)
    with pytest.raises(ValueError, match="a band is named"):
        rb.Perturbation("noise", 30.0, "B1")


def test_the_scan_rows_cover_every_band_and_reach_past_any_filter_spec():
    rows = rb.tolerance_perturbations(["B1", "PAN"])
    assert rows[0].kind == "clean"
    labels = [p.label for p in rows]
    assert len(set(labels)) == len(labels)
    for b in ("B1", "PAN"):
        c = [p.value for p in rows if p.kind == "band-centre" and p.band == b]
        f = [p.value for p in rows if p.kind == "band-fwhm" and p.band == b]
        assert min(c) <= -40 and max(c) >= 40 and min(f) <= 0.5 and max(f) >= 2.0
    assert max(p.value for p in rows if p.kind == "leakage") >= 0.05


def _summary(points):
    """A summary with a clean row (MAE 10, 1, 100) and rows (kind, band,
    value, factor): every metric's MAE times `factor`."""
    rows = [{"band_set": "r", "kind": "clean", "value": 0.0, "LER": 10.0, "G": 1.0,
             "CCT": 100.0, "level1_correct": 0.9, "partitions": 2}]  # fmt: skip
    for kind, band, value, f in points:
        row = {"band_set": "r", "kind": kind, "value": value, "LER": 10.0 * f,
               "G": 1.0, "CCT": 100.0, "level1_correct": 0.8}  # fmt: skip
        if band:
            row["band"] = band
        rows.append(row)
    return {"rows": rows}


def test_intervals_end_where_the_criterion_first_fails():
    pts = [("band-centre", "B1", v, f) for v, f in
           ((-40, 3.0), (-20, 1.2), (-10, 1.05), (-5, 1.0), (5, 1.02), (10, 1.08),
            (20, 1.09), (40, 1.1))]  # fmt: skip
    pts += [("band-fwhm", "B1", v, f) for v, f in ((0.5, 1.5), (0.7, 1.11), (2.0, 1.0))]
    pts += [("leakage", "", 1e-3, 1.0), ("leakage", "", 0.05, 2.0)]
    tol = rb.tolerance_intervals(_summary(pts), "r")
    c = tol["per_band"]["B1"]["centre_nm"]
    assert c["interval"] == [-10.0, 40.0] and c["fails_at"] == [-20.0, None]
    assert not c["open_low"] and c["open_high"]  # 40 nm still passes (1.10)
    f = tol["per_band"]["B1"]["fwhm_factor"]
    assert f["interval"] == [1.0, 2.0] and f["fails_at"] == [0.7, None]
    assert tol["leakage"]["interval"] == [0.0, 1e-3]
    assert tol["leakage"]["fails_at"] == [None, 0.05]
    assert tol["per_band"]["B1"]["centre_nm"]["points"][0]["level1_correct_diff"] == (
        pytest.approx(-0.1)
    )


def test_a_tiny_scan_is_paired_with_its_nominal_row(tmp_path):
    """A zero deviation reproduces the nominal row to rounding (same lamps,
    scenes, noise draws and fit); a large one changes the answers."""
    name = resolve_band_set(STUDY.band_sets[0][1]).bands.names[0]
    study = rb.tolerance_study(
        partitions=1, preset="tiny", atmospheres="none", lamps_per_class=2,
        config=LIGHT,
        perturbations=(
            rb.Perturbation("clean"),
            rb.Perturbation("band-centre", 0.0, name),
            rb.Perturbation("band-centre", 40.0, name),
            rb.Perturbation("leakage", 0.05),
        ),
    )  # fmt: skip
    records = rb.run_study(study, tmp_path / "records.jsonl")
    by = {}
    for r in records:
        by.setdefault(r["perturbation"], []).append(r)
    zero, far = f"{name} centre +0 nm", f"{name} centre +40 nm"
    key = ("LER", "G", "CCT")
    for a, b in zip(by["clean"], by[zero], strict=True):
        assert a["lamp"] == b["lamp"]
        for k in key:  # the rebuilt band set: equal to rounding
            assert b.get(k) == pytest.approx(a.get(k), rel=1e-9), k
    assert any(
        a.get("LER") != b.get("LER") for a, b in zip(by["clean"], by[far], strict=True)
    )
    summary = rb.summarise(records, study)
    tol = rb.write_tolerances(summary, tmp_path)
    saved = json.loads((tmp_path / "tolerance.json").read_text())
    assert saved == json.loads(json.dumps(tol))
    assert (tmp_path / "tolerance.png").is_file()
    assert [r for r in summary["rows"] if r.get("band") == name]
