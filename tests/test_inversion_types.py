"""The inversion's type probabilities: calibrated by temperature on held-out
lamps of known types (held-out types reported and left to the flag;
`fit_inversion(calibrate_probabilities=True)`), the top two named when the
call is close, and NIR variants that share their lamp's prior mass
(`lamp_prior`, `nir_variants`)."""

import dataclasses

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.calibration import brier_score
from tests._bands import GRID
from tests.test_inversion_models import _case


@pytest.fixture(scope="module")
def case():
    return _case()


@pytest.fixture(scope="module")
def fits(case):
    """The same fit with and without calibrated probabilities."""
    lamps, row_lamp, rad, train, _test, inner, w = case
    cond = inv_mod.Conditions.clear(GRID)
    kw = dict(basis=inv_mod._basis(GRID), calibration="classes")
    plain = inv_mod.fit_inversion(rad, row_lamp, lamps, train, inner, w, cond, **kw)
    cal = inv_mod.fit_inversion(
        rad, row_lamp, lamps, train, inner, w, cond, calibrate_probabilities=True, **kw
    )
    return plain, cal


def test_calibration_changes_confidence_not_answers(case, fits):
    _lamps, row_lamp, rad, _train, test, *_ = case
    plain, cal = fits
    assert plain.level1_temperature == 1.0 and plain.temperature_slope == (0.0, 0.0)
    rows = np.flatnonzero(np.isin(row_lamp, test))
    # a sharp posterior made softer by a temperature growing with the misfit
    soft = dataclasses.replace(
        cal,
        level1_temperature=5.0,
        level2_temperature=5.0,
        temperature_slope=(1.0, 1.0),
    )
    a, b = (x.predict(rad[rows]) for x in (plain, cal))
    assert a.level1 == b.level1 and a.level2 == b.level2
    np.testing.assert_array_equal(a.estimate, b.estimate)
    np.testing.assert_allclose(b.level1_probabilities.sum(axis=1), 1.0)
    # a posterior spread over the prior's lamps: softer, more so at a larger
    # misfit, the same order
    k = len(soft.prior.ids)
    post = np.random.default_rng(0).dirichlet(np.full(k, 0.3), size=2)
    sharp = inv_mod._result(plain, post, np.array([0.5, 4.0]))
    low = inv_mod._result(soft, post, np.array([0.5, 4.0]))
    p0, p1 = sharp.level1_probabilities, low.level1_probabilities
    np.testing.assert_allclose(p1.sum(axis=1), 1.0)
    assert np.array_equal(p0.argmax(axis=1), p1.argmax(axis=1))
    assert np.all(p1.max(axis=1) < p0.max(axis=1))
    assert sharp.level1 == low.level1 and sharp.level2 == low.level2


def test_calibration_diagnostics_cover_both_groups(fits):
    _, cal = fits
    d = cal.diagnostics["probabilities"]
    assert d["calibrated"] and set(d["groups"]) == {"known_types", "left_out_types"}
    for g in d["groups"].values():
        assert g["rows"] > 0 and 0.0 <= g["unexplained_rate"] <= 1.0
        assert 0.0 <= g["ece_level1_after"] <= 1.0
    # the Brier score the temperature minimises does not get worse than T = 1
    assert d["level1"]["brier_after"] <= d["level1"]["brier_before"] + 1e-12
    assert fits[0].diagnostics["probabilities"] == {"calibrated": False}


def test_temperature_is_fitted_on_known_types_only(fits):
    """The temperature is the one fitted on the known types' held-out rows
    alone (their row count), and the flag's threshold is the known rows'
    weighted 95th percentile, so about 5 % of them are flagged."""
    _, cal = fits
    d = cal.diagnostics["probabilities"]
    known = d["groups"]["known_types"]
    assert d["fitted_on"] == "known_types"
    assert d["level1"]["n_rows"] == known["rows"]
    assert d["level1"]["n_rows"] < known["rows"] + d["groups"]["left_out_types"]["rows"]
    rate = 1.0 - inv_mod.UNEXPLAINED_QUANTILE
    assert d["unexplained_false_flag_rate"] == pytest.approx(rate)
    assert known["unexplained_rate"] == pytest.approx(rate, abs=0.03)


def test_left_out_types_cannot_be_named_so_they_soften_the_answer():
    """Rows of a class the prior lacks are always wrong: the fitted
    temperature lowers the confidence the uncalibrated posterior gave them."""
    post = np.array([[0.98, 0.02, 0.0]] * 10 + [[0.99, 0.01, 0.0]] * 10)
    labels = np.r_[np.zeros(10, int), np.full(10, 2)]  # half: class 2, unseen
    from bandopt.calibration import fit_temperature, temper

    t = fit_temperature(post, labels)
    assert t.value > 1.0
    assert brier_score(temper(post, t.value), labels) < brier_score(post, labels)


def _result(p1):
    p1 = np.asarray(p1, float)
    n = p1.shape[0]
    return inv_mod.InversionResult(
        estimate=np.zeros((n, 3)),
        interval90=np.zeros((n, 3, 2)),
        cct_probability=np.ones(n),
        unexplained=np.zeros(n, bool),
        misfit=np.zeros(n),
        level1_labels=("led", "hid", "fluorescent"),
        level1_probabilities=p1,
        level2_labels=(),
        level2_probabilities=np.zeros((n, 0)),
        level1=("led",) * n,
        level2=(None,) * n,
        testable=True,
    )


def test_top_two_and_close_calls():
    res = _result([[0.6, 0.1, 0.3], [0.9, 0.06, 0.04]])
    close = res.row(0)["level1_top2"]
    assert close["close"] and [t["type"] for t in close["types"]] == [
        "led",
        "fluorescent",
    ]
    assert close["types"][1]["probability"] == pytest.approx(0.3)
    clear = res.top2(1)
    assert not clear["close"] and clear["types"][0]["type"] == "led"


def test_variants_share_their_lamps_prior_mass():
    spectra = np.ones((5, GRID.size))
    ids = ("a", "nir-low:a", "nir-high:a", "b", "c")
    l2 = ("led_warm", "led_warm", "led_warm", "led_warm", "hps")
    l1 = ("led", "led", "led", "led", "hid")
    prior = inv_mod.lamp_prior(ids, spectra, l1, l2, GRID)
    w = np.exp(prior.log_prior)
    np.testing.assert_allclose(w, [1 / 12, 1 / 12, 1 / 12, 1 / 4, 1 / 2])
    assert inv_mod.variant_base("nir-high:a") == "a"
    assert inv_mod.variant_base("mix:a+b@0.5") == "mix:a+b@0.5"


def test_nir_variants_scale_only_the_modelled_part():
    from bandopt.datasets.lamps import library
    from bandopt.datasets.nir import extension_error, technology_of

    lamps = inv_mod.library_lamps(GRID, scored=True)
    recs = {r.id: r for r in library().records}
    ext = [i for i, x in enumerate(lamps.ids) if recs[x].extended][:3]
    meas = [i for i, x in enumerate(lamps.ids) if recs[x].nir_measured][:2]
    sub = lamps.take(ext + meas)
    var = inv_mod.nir_variants(sub, GRID)
    assert len(var.ids) == 2 * len(ext)  # measured NIR: no variants
    for j, i in enumerate(ext):
        rec = recs[lamps.ids[i]]
        err = extension_error(rec.level2, technology_of(rec.level2, rec.level1))
        beyond = GRID > max(rec.measured_range_nm[1], 780.0)
        for k, f in enumerate((err.low, err.high)):
            row = var.spectra[2 * j + k]
            assert var.ids[2 * j + k].endswith(":" + lamps.ids[i])
            np.testing.assert_allclose(
                row[~beyond], lamps.spectra[i][~beyond], rtol=1e-9
            )
            np.testing.assert_allclose(
                row[beyond], max(1 + f, 0) * lamps.spectra[i][beyond], rtol=1e-9
            )


def test_candidate_extensions_merge_their_top_two():
    """`bandopt evaluate` averages the candidates' level-1 probabilities and
    names the top two of the average."""
    from bandopt.cli._cmd_evaluate import merge_candidates

    def row(p):
        return {
            "interval90": {"LER": [100.0, 120.0]},
            "level1_probabilities": p,
            "predicted_level1": max(p, key=p.get),
        }

    out = merge_candidates(
        [row({"led": 0.9, "fluorescent": 0.1}), row({"led": 0.2, "fluorescent": 0.8})]
    )
    assert out["predicted_level1"] == "led"  # 0.55 against 0.45
    assert out["level1_top2"]["close"]
    assert [t["type"] for t in out["level1_top2"]["types"]] == ["led", "fluorescent"]
    assert inv_mod.top_two({"a": 0.8, "b": 0.15, "c": 0.05})["close"] is False


def test_evaluate_describes_the_calibration_it_has(fits):
    """The JSON description names the known-type fit and the held-out types'
    ECE and flag rate from the fit's own diagnostics."""
    from bandopt.estimators._inversion import _probability_text

    _, cal = fits
    g = cal.diagnostics["probabilities"]["groups"]
    text = _probability_text(cal)
    assert "fitted on held-out lamps of known types" in text
    assert f"ECE there {g['known_types']['ece_level1_after']:.2f}" in text
    assert f"unexplained {g['left_out_types']['unexplained_rate']:.2f}" in text
    assert "uncalibrated" in _probability_text(fits[0])


def test_merged_candidates_are_unexplained_only_when_every_one_is():
    from bandopt.cli._cmd_evaluate import merge_candidates

    def row(flag, l2):
        return {
            "interval90": {"LER": [100.0, 120.0]},
            "level1_probabilities": {"led": 0.7, "hid": 0.3},
            "predicted_level1": None if flag else "led",
            "predicted_level2": None if flag else l2,
            "null_reasons": {"type": "unexplained"} if flag else {},
            "unexplained": flag,
        }

    both = merge_candidates([row(True, "led_cool"), row(True, "led_warm")])
    assert both["unexplained"] and both["predicted_level1"] is None
    assert both["predicted_level2"] is None
    one = merge_candidates([row(True, "led_cool"), row(False, "led_warm")])
    assert not one["unexplained"]
    assert (one["predicted_level1"], one["predicted_level2"]) == ("led", "led_warm")
    assert one["null_reasons"] == {}
