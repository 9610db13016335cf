"""Tolerance analysis (issue 13): the specification-interval rule on hand-made
rows, and on a small real study context (tiny preset, one lamp partition,
photon noise) the nominal score, both variants (estimator fitted to the
nominal bands; its coefficients refitted on the perturbed ones with the
nominal hyper-parameters) and the JSON schema."""

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
from bandopt.search._study import get_scorer, score_design
from bandopt.search._tolerance import (
    AOI_DEG,
    CALIBRATION_FIXED,
    CENTRE_SHIFTS_NM,
    FWHM_FACTORS,
    LEAKAGES,
    perturbed_bands,
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
    # one metric at a time: the ratio of that metric alone decides
    for r, ratio in zip(leak, (1.0, 1.05, 1.2), strict=True):
        r["ratio_LER"], r["ratio_G"] = ratio, 1.0
    assert specification_interval(
        leak, "all", "leakage", 0.0, metric="LER"
    ) == [0.0, 0.0025]
    assert specification_interval(
        leak, "all", "leakage", 0.0, metric="G"
    ) == [0.0, 0.005]
    with pytest.raises(ValueError, match="metric 'X'"):
        specification_interval(leak, "all", "leakage", 0.0, metric="X")


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


def test_the_calibrated_refit_keeps_the_nominal_hyper_parameters(study):
    """The scorer's refit with `hyper` of the nominal fit on the same outer
    training set skips the inner CV: it reports the nominal choices, with the
    nominal responses it reproduces the nominal predictions exactly, and
    with perturbed ones it keeps the choices where a re-run inner CV does not
    (5 % leakage: every resample of this context chooses differently)."""
    ctx, res, bands, _ = study
    fit = get_scorer("ridge")
    rad0 = ctx.radiance(bands, seed=SEED)
    leaky = perturbed_bands(bands, leakage=LEAKAGES[-1])
    rad = ctx.radiance(leaky, seed=SEED)
    flips = 0
    for r in res:
        nominal = fit(ctx, bands, rad0, r.train, list(r.inner))
        assert set(nominal.hyper) == {"degree", "lam"}
        same = fit(ctx, bands, rad0, r.train, [], hyper=nominal.hyper)  # no CV
        assert same.hyper == nominal.hyper
        np.testing.assert_array_equal(same(rad0), nominal(rad0))
        refit = fit(ctx, leaky, rad, r.train, [], hyper=nominal.hyper)
        assert refit.hyper == nominal.hyper
        assert not np.array_equal(refit(rad), nominal(rad))  # coefficients moved
        flips += fit(ctx, leaky, rad, r.train, list(r.inner)).hyper != nominal.hyper
    assert flips > 0  # so fixing them is not a no-op here


def test_the_inversion_refit_keeps_sigma_rel(study):
    """The inversion scorer's `hyper` is its sigma_rel: given back, it is
    used as is (one resample: the inversion is slower)."""
    ctx, res, bands, _ = study
    fit = get_scorer("inversion")
    rad0 = ctx.radiance(bands, seed=SEED)
    r = res[0]
    nominal = fit(ctx, bands, rad0, r.train, list(r.inner))
    same = fit(ctx, bands, rad0, r.train, list(r.inner), hyper=nominal.hyper)
    assert same.hyper == nominal.hyper
    np.testing.assert_array_equal(same(rad0), nominal(rad0))
    other = 0.003 if nominal.hyper["sigma_rel"] != 0.003 else 0.3
    forced = fit(ctx, bands, rad0, r.train, list(r.inner), hyper={"sigma_rel": other})
    assert forced.hyper == {"sigma_rel": other}


def _smallest_steps(bands):
    """(band, parameter, value) of the smallest non-zero step of every smooth
    deviation (leakage is not smooth at 0, see below)."""
    out = [("all", "aoi_deg", float(AOI_DEG[1]))]
    for name in bands.names:
        out += [(name, "centre_shift_nm", v) for v in (-1.0, 1.0)]
        out += [(name, "fwhm_factor", v) for v in (0.98, 1.02)]
    return out


def test_calibrated_ratios_are_continuous_and_refitting_removes_large_biases(study):
    """With the estimator's hyper-parameters fixed at the nominal fit, the
    calibrated refit changes only coefficients, which follow the responses
    smoothly. Measured on this context (1 partition x 3 folds):

    - at the smallest step of every smooth deviation (centre +/-1 nm, FWHM
      x0.98/1.02, AOI 2 deg) calibrated and uncalibrated ratios differ by at
      most 0.008 (asserted: 0.015) and the calibrated ones stay within
      1 +/- 0.025 (asserted: 0.03). With the inner CV re-run in the refit
      (before fixing the hyper-parameters) a flipped choice at a 1 nm shift
      moved G by 2.8 % against the uncalibrated ratio (B2 +1 nm: 1.035 against
      1.007), failing the first bound;
    - at the end of the leakage and AOI scans the worst metric's ratio, the
      one the 10 % rule judges, is not larger calibrated (5 % leakage: 1.15
      against 1.26; 20 deg: 1.150 against 1.157): a 5 % floor adds the
      scene's whole out-of-band integral to every band, a bias the nominally
      fitted estimator never saw and the refit learns.

    Not asserted, because it is not true even with the hyper-parameters
    fixed: calibrated <= uncalibrated over the whole leakage scan, or a
    calibrated leakage interval at least as wide. At 0.25-2 % leakage the
    calibrated worst ratio is 1.08-1.11 against 1.03-1.07, so the calibrated
    leakage interval is [0, 0.005] against [0, 0.02] (AOI: [0, 14] against
    [0, 16] deg: LER 0.8-1.5 % higher calibrated at 8-18 deg). The cause is not
    hyper-parameter choice but dark bands: the 820 nm band of lamps without
    near-infrared emission is at or below the feature floor (LOG_FLOOR) in
    16 % of the rows (photon noise vanishes with the signal), and any leakage
    lifts it by orders of magnitude: at 1e-6 leakage 4.5 % of the rows move by
    more than 1 in a log-ratio feature and the ratios move by 1-4 % (LER
    1.020 uncalibrated, 1.036 calibrated), rising with log(leakage).
    Per metric calibrated <= uncalibrated fails too (G's uncalibrated error
    falls with leakage, a bias that happens to help).

    On the search context (291 lamps x 8 scenes, 6S, 4 partitions; the
    recommended 4 bands + PAN) the stronger property does hold: calibrated
    ratios <= 1.001 over the whole leakage and AOI scans, intervals [0, 0.05]
    and [0, 20] deg against [0, 0.0025] and [0, 18] uncalibrated; smallest
    steps: |calibrated - uncalibrated| <= 0.031 (0.100 with the inner CV
    re-run). There a band's calibrated centre interval can be the narrower
    one (B3: [-10, 7] against [-9, 10]; LER rises smoothly to 1.10 from +8 nm
    calibrated, 1.01 uncalibrated), a trend, not selection noise."""
    _, _, bands, a = study
    for key in _smallest_steps(bands):
        unc = _ratios(_row(a, *key, False))
        cal = _ratios(_row(a, *key, True))
        assert np.all(np.abs(cal - unc) <= 0.015), (key, cal, unc)
        assert np.all(np.abs(cal - 1.0) <= 0.03), (key, cal)
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
    "leakage_interval_by_metric",
    "leakage_interval_by_metric_calibrated",
    "aoi_interval_by_metric_deg",
    "aoi_interval_by_metric_calibrated_deg",
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
    assert "hyper-parameters fixed at the nominal fit" in s["rule"]
    assert CALIBRATION_FIXED["ridge"] in s["rule"]
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
        for key, parameter in (
            ("leakage_interval_by_metric" + suffix, "leakage"),
            ("aoi_interval_by_metric" + suffix + "_deg", "aoi_deg"),
        ):
            per = s[key]
            assert set(per) == {"LER", "G", "CCT"}
            for m, v in per.items():
                assert v == a.interval("all", parameter, calibrated=cal, metric=m)
            # the joint interval is the narrowest of the per-metric ones
            joint = a.interval("all", parameter, calibrated=cal)
            assert joint[1] == min(v[1] for v in per.values())
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
    calibrated_keys = [k for k in NEW_KEYS if "calibrated" in k]
    assert all(s[k] is None for k in calibrated_keys)
    assert s["leakage_interval_by_metric"] is not None  # uncalibrated: scanned
    assert all(s["per_band"]["B1"][k] is None for k in NEW_BAND_KEYS)
    assert "not run" in s["rule"]
    assert s["leakage_interval"] is not None
