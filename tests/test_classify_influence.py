"""Influence of the conditions and the band-count choice (library logic of
experiments/classify.py)."""

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
        _, yt, yp = ev["level2"]["rows"]
        ref = scores(yt, yp, class_order("level2", table.level2))["macro_f1"]
        assert r.macro_f1_trained_on_all_tested_on_this == pytest.approx(ref)
    for r in res.estimates:
        assert np.all(np.isfinite(r.mae_same)) and np.all(np.asarray(r.mae_same) >= 0)
        assert np.all(np.isfinite(r.mae_others))
    with pytest.raises(ValueError, match="Unknown factor"):
        influence(table, bands, ("weather",))
