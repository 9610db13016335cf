"""Influence of the conditions and the band-count choice (the classification
study, `bandopt.studies.classification`, builds on them)."""

import numpy as np
import pytest

from bandopt.classify import (
    choose_band_count,
    class_order,
    evaluate_band_set,
    influence,
    scores,
)
from bandopt.datasets.lamps import library
from bandopt.forward import scenario_table
from bandopt.scene import build_scenarios
from bandopt.sensor import reference_sensor


def test_choose_band_count_rule():
    f1 = {5: 0.81, 2: 0.70, 4: 0.80, 3: 0.79}
    c = choose_band_count(f1)
    assert c.n_bands == 3 and c.best_f1 == 0.81 and list(c.f1_by_n) == [2, 3, 4, 5]
    assert choose_band_count(f1, tolerance=0.0).n_bands == 5
    assert choose_band_count(f1, tolerance=0.2).n_bands == 2
    with pytest.raises(ValueError, match="empty"):
        choose_band_count({})


@pytest.fixture(scope="module")
def table():
    lib = library().select(scored_only=True)
    ids = []
    for cls in ("hps", "metal_halide", "led_amber"):
        ids += [r.id for r in lib.records if r.level2 == cls][:6]
    return scenario_table(
        build_scenarios(
            lamps=tuple(ids),
            surfaces=("asphalt", "grass"),
            atmospheres=("none",),
            moons=(None,),
            classes=("P6",),
        )
    )


def test_influence_of_the_surface(table):
    bands = reference_sensor("aerocube")
    res = influence(table, bands, ("surface", "moon"), noise_seed=1, fold_seed=0)
    # moon has one value here: skipped; one row per surface
    assert [(r.factor, r.train_on) for r in res.identification] == [
        ("surface", "asphalt"),
        ("surface", "grass"),
    ]
    assert [r.train_on for r in res.estimates] == ["asphalt", "grass"]
    for r in res.identification:
        for f in (r.macro_f1_same, r.macro_f1_others):
            assert 0.0 <= f <= 1.0
        assert r.as_dict()["f1_drop"] == pytest.approx(
            r.macro_f1_same - r.macro_f1_others
        )
    # "trained on all, tested on this value" = the classifier of every scene
    # scored on that value's test rows
    rad = table.band_radiance(bands, noise=True, seed=1)
    for r in res.identification:
        rows = table.surface == r.train_on
        ev = evaluate_band_set(
            table, bands, radiance=rad, test_rows=rows, keep_rows=True,
            levels=("level2",),
        )  # fmt: skip
        _, yt, yp = ev.level2.rows
        ref = scores(yt, yp, class_order("level2", table.level2))["macro_f1"]
        assert r.macro_f1_trained_on_all_tested_on_this == pytest.approx(ref)
    for r in res.estimates:
        assert np.all(np.isfinite(r.mae_same)) and np.all(np.asarray(r.mae_same) >= 0)
        assert np.all(np.isfinite(r.mae_others))
    with pytest.raises(ValueError, match="Unknown factor"):
        influence(table, bands, ("weather",))


def test_evaluate_band_set_returns_typed_scores_with_the_old_json(table):
    """`evaluate_band_set` returns frozen `BandSetScores`; `to_dict()` is the
    dict it returned before (same keys in the same order, checked byte for
    byte against the old code when the class was introduced)."""
    import dataclasses
    import json

    from bandopt.classify import BandSetScores, LevelScores, summary

    res = evaluate_band_set(table, reference_sensor("aerocube"), seed=1)
    assert isinstance(res, BandSetScores) and isinstance(res.level2, LevelScores)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.level2 = None
    d = res.to_dict()
    assert list(d) == ["level1", "level2", "config"]
    assert list(d["level2"]) == [
        "labels", "f1", "precision", "recall", "support", "macro_f1", "accuracy",
        "coverage", "confusion", "confusion_columns", "lamp_accuracy",
        "lamp_accuracy_by_class", "mean_lamp_accuracy", "reject", "folds",
        "macro_f1_fold_mean", "macro_f1_fold_sd", "n_test_rows",
    ]  # fmt: skip
    assert list(d["config"]) == ["noise", "seed", "fold_seed", "features", "k_grid",
                                 "dedup", "n_outer", "n_inner"]  # fmt: skip
    json.dumps(d)  # JSON-ready
    for lv in ("level1", "level2"):
        s = res.level(lv)
        assert d[lv]["macro_f1"] == s.macro_f1 and d[lv]["f1"] == s.f1
        assert summary(res)[lv]["macro_f1"] == s.macro_f1
        assert summary(res)[lv]["k"] == [f["k"] for f in s.folds]
    # macro F1 is the mean of the per-class F1 (the scores function's rule)
    assert res.level2.macro_f1 == pytest.approx(np.mean(list(res.level2.f1.values())))
    only2 = evaluate_band_set(table, reference_sensor("aerocube"), seed=1,
                              levels=("level2",), keep_rows=True)  # fmt: skip
    assert only2.level1 is None and list(only2.to_dict()) == ["level2", "config"]
    assert "rows" not in only2.to_dict()["level2"]
    idx, yt, yp = only2.to_dict(rows=True)["level2"]["rows"]
    assert len(idx) == len(yt) == len(yp) == only2.level2.n_test_rows
    with pytest.raises(ValueError, match="'level1' was not evaluated"):
        only2.level("level1")
