"""Tolerance analysis (issue 13): the specification-interval rule on hand-made
rows, and on a small real study context (tiny preset, one lamp partition,
photon noise) the nominal score, both variants (estimator fitted to the
nominal bands; refitted on the perturbed ones) and the JSON schema."""

import json

import numpy as np
import pytest

from bandopt.search import (
    MAX_ERROR_RATIO,
    Space,
    partition_summary,
    specification_interval,
    study_resamples,
    tolerance_analysis,
    truth_sd,
)
from bandopt.search._study import score_design
from bandopt.search._tolerance import (
    AOI_DEG,
    CENTRE_SHIFTS_NM,
    FWHM_FACTORS,
    LEAKAGES,
)


def _rows(values, within, *, band="B1", parameter="centre_shift_nm", **extra):
    return [
        {"band": band, "parameter": parameter, "value": v, "within_10pct": ok, **extra}
        for v, ok in zip(values, within, strict=True)
    ]


def test_interval_is_the_contiguous_run_around_nominal():
    vals = [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]
    ok = [False, True, True, True, True, False, True]  # 3 passes, cut off by 2
    rows = _rows(vals, ok)
    assert specification_interval(rows, "B1", "centre_shift_nm", 0.0) == [-2.0, 1.0]
    # order of the rows does not matter
    assert specification_interval(rows[::-1], "B1", "centre_shift_nm", 0.0) == [
        -2.0,
        1.0,
    ]


def test_interval_ends_on_the_scan_limit_and_is_none_when_nominal_fails():
    vals = [0.8, 0.9, 1.0, 1.1, 1.2]
    every = _rows(vals, [True] * 5, parameter="fwhm_factor")
    # the whole scan passes: the interval is the scan (meaning "at least")
    assert specification_interval(every, "B1", "fwhm_factor", 1.0) == [0.8, 1.2]
    # nominal failing cannot happen in an analysis (ratio 1 there), but the
    # rule says what it would give
    bad = _rows(vals, [True, True, False, True, True], parameter="fwhm_factor")
    assert specification_interval(bad, "B1", "fwhm_factor", 1.0) is None
    # one-sided scans (leakage, AOI) start at nominal
    leak = _rows([0.0, 0.0025, 0.005], [True, False, True], band="all",
                 parameter="leakage")  # fmt: skip
    assert specification_interval(leak, "all", "leakage", 0.0) == [0.0, 0.0]


def test_interval_separates_the_variants_and_reads_old_rows():
    vals = [-1.0, 0.0, 1.0]
    old = _rows(vals, [True, True, False])  # an old CSV: no `calibrated` column
    cal = _rows(vals, [True, True, True], calibrated=True)
    rows = old + cal
    assert specification_interval(rows, "B1", "centre_shift_nm", 0.0) == [-1.0, 0.0]
    assert specification_interval(
        rows, "B1", "centre_shift_nm", 0.0, calibrated=True
    ) == [-1.0, 1.0]
    with pytest.raises(ValueError, match="no rows for band 'B9'"):
        specification_interval(rows, "B9", "centre_shift_nm", 0.0)


# ------------------------------------------------------------------------------
# a small real context: 291 lamps x 1 scene, 1 partition x 3 outer folds


SEED = 0


@pytest.fixture(scope="module")
def study():
    ctx, res = study_resamples("tiny", "P4", "none", 1, SEED)
    space = Space(2, pan="fixed", min_fwhm_nm=20.0, max_fwhm_nm=200.0,
                  lower_nm=380.0, upper_nm=900.0)  # fmt: skip
    bands = space.band_set([560.0, 820.0], [60.0, 40.0], name="test")
    return ctx, res, bands, tolerance_analysis(ctx, bands, res, seed=SEED)


def _row(a, band, parameter, value, calibrated):
    (r,) = [
        r
        for r in a.rows
        if (r["band"], r["parameter"], r["value"], r["calibrated"])
        == (band, parameter, value, calibrated)
    ]
    return r


def _ratios(r):
    return np.array([r["ratio_LER"], r["ratio_G"], r["ratio_CCT"]])


def test_rows_cover_every_scan_point_in_both_variants(study):
    _, _, bands, a = study
    n = len(bands.names) * (len(CENTRE_SHIFTS_NM) + len(FWHM_FACTORS))
    n += len(LEAKAGES) + len(AOI_DEG)
    assert len(a.rows) == 2 * n
    # the uncalibrated rows come first, in the order (and columns) of the
    # files written before the calibrated scan; `calibrated` is the last column
    assert not any(r["calibrated"] for r in a.rows[:n])
    assert all(r["calibrated"] for r in a.rows[n:])
    assert list(a.rows[0])[-2:] == ["within_10pct", "calibrated"]
    for r in a.rows:
        assert r["within_10pct"] == bool(np.all(_ratios(r) <= MAX_ERROR_RATIO))


def test_nominal_is_the_study_score_and_zero_deviation_gives_ratio_one(study):
    ctx, res, bands, a = study
    # the nominal MAE is what the study reports for this band set (an
    # independent path: score_design + partition_summary)
    scores = score_design(ctx, bands, res, scorer="ridge", seed=SEED)
    want = partition_summary(scores, ctx.table.classes, truth_sd(ctx.table))
    for m, v in a.summary["nominal_mae"].items():
        assert v == pytest.approx(want["mae_mean"][m], rel=1e-12)
    # no deviation: the same responses (up to from_physical's 1e-9 nudge off
    # a bound), hence the same fit when refitted: ratio 1 in both variants
    nominal = {"centre_shift_nm": 0.0, "fwhm_factor": 1.0, "leakage": 0.0,
               "aoi_deg": 0.0}  # fmt: skip
    for cal in (False, True):
        for name in (*bands.names, "all"):
            for p, v in nominal.items():
                if (name == "all") != (p in ("leakage", "aoi_deg")):
                    continue
                np.testing.assert_allclose(
                    _ratios(_row(a, name, p, v, cal)), 1.0, rtol=1e-9
                )


def test_refitting_removes_the_bias_of_a_large_deviation(study):
    """A 5 % flat floor adds the scene's whole out-of-band integral to every
    band, a bias the nominally fitted estimator never saw; refitting on the
    as-built responses learns it, leaving only the information the dilution
    lost. So at the end of the leakage (and AOI) scan the worst metric's
    ratio, the one the 10 % rule judges, is not larger calibrated.

    Not asserted, because it is not true: calibrated <= uncalibrated per
    metric (here G's uncalibrated error FALLS with leakage, a bias that
    happens to help) or at small deviations (refitting re-runs the inner-CV
    choice of feature degree and ridge strength; at 0.25 % leakage a flipped
    choice moved a metric's test MAE by 8 % on this context and by 11 % on
    the tiny preset with 4 partitions, against 1-4 % uncalibrated)."""
    _, _, _, a = study
    for p, v in (("leakage", LEAKAGES[-1]), ("aoi_deg", float(AOI_DEG[-1]))):
        unc = _ratios(_row(a, "all", p, v, False)).max()
        cal = _ratios(_row(a, "all", p, v, True)).max()
        assert cal <= unc, (p, v, cal, unc)
    # and the scan reached a deviation that matters uncalibrated
    assert _ratios(_row(a, "all", "leakage", LEAKAGES[-1], False)).max() > 1.05


OLD_KEYS = [
    "rule",
    "nominal_mae",
    "per_band",
    "leakage_interval",
    "meets_leakage_1pct",
    "aoi_interval_deg",
    "aoi_model",
    "leakage_model",
    "grid",
]
OLD_BAND_KEYS = [
    "centre_shift_interval_nm",
    "fwhm_factor_interval",
    "meets_centre_pm5nm",
    "meets_fwhm_pm10pct",
]
NEW_KEYS = [
    "leakage_interval_calibrated",
    "meets_leakage_1pct_calibrated",
    "aoi_interval_calibrated_deg",
]
NEW_BAND_KEYS = [
    "centre_shift_interval_calibrated_nm",
    "fwhm_factor_interval_calibrated",
    "meets_centre_pm5nm_calibrated",
    "meets_fwhm_pm10pct_calibrated",
]


def test_summary_has_the_old_keys_and_the_calibrated_ones(study):
    _, _, bands, a = study
    s = json.loads(json.dumps(a.summary))  # JSON-ready as it is
    assert set(s) == set(OLD_KEYS + NEW_KEYS)
    assert [k for k in s if k in OLD_KEYS] == OLD_KEYS  # old order kept
    assert list(s["per_band"]) == list(bands.names)
    for v in s["per_band"].values():
        assert set(v) == set(OLD_BAND_KEYS + NEW_BAND_KEYS)
    assert s["grid"] == {
        "centre_shift_nm": CENTRE_SHIFTS_NM.tolist(),
        "fwhm_factor": FWHM_FACTORS.tolist(),
    }
    assert "calibrated" in s["rule"] and "refitted" in s["rule"]
    # the summary's intervals are the rule applied to the rows
    for cal, suffix in ((False, ""), (True, "_calibrated")):
        assert s["leakage_interval" + suffix] == a.interval(
            "all", "leakage", calibrated=cal
        )
        assert s["aoi_interval" + suffix + "_deg"] == a.interval(
            "all", "aoi_deg", calibrated=cal
        )
        iv = s["leakage_interval" + suffix]
        assert s["meets_leakage_1pct" + suffix] == (iv is not None and iv[1] >= 0.01)
        for name, v in s["per_band"].items():
            ci = v["centre_shift_interval" + suffix + "_nm"]
            fi = v["fwhm_factor_interval" + suffix]
            assert ci == a.interval(name, "centre_shift_nm", calibrated=cal)
            assert fi == a.interval(name, "fwhm_factor", calibrated=cal)
            assert v["meets_centre_pm5nm" + suffix] == (
                ci is not None and ci[0] <= -5 and ci[1] >= 5
            )
            assert v["meets_fwhm_pm10pct" + suffix] == (
                fi is not None and fi[0] <= 0.9 and fi[1] >= 1.1
            )


def test_without_the_calibrated_scan_its_keys_are_null(study):
    ctx, res, _, _ = study
    bands = Space(1, pan="none", min_fwhm_nm=20.0, lower_nm=380.0,
                  upper_nm=900.0).band_set([560.0], [60.0])  # fmt: skip
    a = tolerance_analysis(ctx, bands, res, seed=SEED, calibrated=False)
    assert not any(r["calibrated"] for r in a.rows)
    s = a.summary
    assert set(s) == set(OLD_KEYS + NEW_KEYS)
    assert all(s[k] is None for k in NEW_KEYS)
    assert all(s["per_band"]["B1"][k] is None for k in NEW_BAND_KEYS)
    assert "not run" in s["rule"]
    assert s["leakage_interval"] is not None
