"""Lamp-type classification with the physics-based inversion
(`bandopt.classify.evaluate_inversion`, `bandopt classify --estimator`): the
KNN's folds and scores, hierarchical types, the reject option."""

import dataclasses
import itertools
import json

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.classify import (
    REJECT_THRESHOLD,
    UNKNOWN,
    evaluate_band_set,
    hierarchical_types,
    inversion_conditions,
    outer_splits,
    scenario_table,
    summary,
    table_lamps,
    withhold,
)
from bandopt.datasets.lamps import LEVEL2_PARENT, library
from bandopt.scene import build_scenarios
from bandopt.sensor import load_band_set
from tests._inversion import patch_inversion


LAMPS_PER_CLASS = 4
"""Lamps of each scored level-2 class in the small table (3 outer x 2 inner
folds need at least 3)."""


def _small_ids():
    lib = library().select(scored_only=True)
    per: dict[str, list[str]] = {}
    for r in lib.records:
        per.setdefault(r.level2, []).append(r.id)
    return [i for c in sorted(per) for i in per[c][:LAMPS_PER_CLASS]]


@pytest.fixture(scope="module")
def table():
    return scenario_table(
        build_scenarios(
            lamps=_small_ids(),
            surfaces=("asphalt", "grass"),
            atmospheres=("none",),
            moons=(None,),
            classes=("P4",),
        )
    )


@pytest.fixture(scope="module")
def bands():
    return load_band_set("sdgsat-1")


@pytest.fixture(scope="module")
def result(table, bands):
    return evaluate_band_set(
        table, bands, noise=True, estimator="inversion", keep_rows=True
    )


def test_scores_are_valid_and_shaped_like_the_knn(result, table):
    d = result.to_dict()
    json.dumps(d)  # JSON-ready
    assert list(d) == ["level1", "level2", "config"]
    for level in ("level1", "level2"):
        r = d[level]
        classes = list(dict.fromkeys(table.lamp_classes(level)))
        assert set(r["f1"]) == set(classes)
        assert all(0.0 <= v <= 1.0 for v in r["f1"].values())
        assert r["macro_f1"] == pytest.approx(np.mean(list(r["f1"].values())))
        assert 0.0 <= r["accuracy"] <= 1.0 and 0.0 <= r["mean_lamp_accuracy"] <= 1.0
        # every test pixel is in the confusion matrix exactly once (predictions of
        # prior-only classes such as lps have their own columns)
        cm = np.asarray(r["confusion"])
        assert cm.sum() == r["n_test_rows"] == table.n_rows
        assert r["confusion_columns"][: cm.shape[0]] == r["labels"]
        assert r["confusion_columns"][-1] == UNKNOWN
        assert cm[:, -1].sum() == 0  # no reject without the reject option
        assert set(r["lamp_accuracy"]) == set(table.lamp_ids)
        assert {f["outer"] for f in r["folds"]} == {0, 1, 2}
        assert all(f["sigma_rel"] in inv_mod.SIGMA_REL_GRID for f in r["folds"])
    s = summary(result)
    assert len(s["level2"]["sigma_rel"]) == 3 and "k" not in s["level2"]
    assert set(s["level2"]["reject"]) == {
        "threshold",
        "coverage",
        "accuracy",
        "macro_f1",
        "unexplained",
    }
    assert result.config["estimator"] == "inversion"


def test_level2_hit_implies_level1_hit_per_pixel(result):
    i1, t1, p1 = result.level1.rows
    i2, t2, p2 = result.level2.rows
    np.testing.assert_array_equal(i1, i2)  # the same pixels in the same order
    # hierarchical: the level-2 class lies inside the predicted level-1 family
    assert all(LEVEL2_PARENT[c] == f for c, f in zip(p2, p1, strict=True))
    hit2 = p2 == t2
    assert np.all((p1 == t1)[hit2])
    assert result.level1.accuracy >= result.level2.accuracy


def test_reject_is_unexplained_or_below_threshold(result):
    for level in ("level1", "level2"):
        r = result.to_dict(rows=True)[level]
        _, truth, pred = r["rows"]
        conf, unexplained = r["reject_rows"]
        assert np.all((conf > 0) & (conf <= 1 + 1e-12))
        rejected = unexplained | (conf < REJECT_THRESHOLD)
        acc = ~rejected
        rej = r["reject"]
        assert rej["coverage"] == pytest.approx(acc.mean())
        assert rej["unexplained"] == pytest.approx(unexplained.mean())
        # accuracy with rejects counted as misses, and on the accepted pixels
        assert rej["accuracy"] == pytest.approx(np.mean(acc & (pred == truth)))
        (at,) = [c for c in rej["curve"] if c["threshold"] == REJECT_THRESHOLD]
        assert at["coverage"] == pytest.approx(acc.mean())
        assert at["accuracy_accepted"] == pytest.approx(
            np.mean(pred[acc] == truth[acc])
        )
        cov = [c["coverage"] for c in rej["curve"]]
        assert all(b <= a for a, b in itertools.pairwise(cov))


def test_known_type_p_value_ranks_held_out_lamps_like_a_conformal_test(table, bands):
    """The flag's p-value (`Inversion.known_type_p_value`): each inner fold's
    held-out rows, ranked by their own fold, fall below α at most at rate α
    (class-balanced), as a conformal test must; without the inner folds the
    p-value is NaN and the threshold rule decides; `restricted` to every entry
    changes nothing."""
    from bandopt.classify._inversion import _surface_basis

    s = outer_splits(table, 0)[0]
    lamps, always = table_lamps(table)
    rad = table.band_radiance(bands, noise=True)
    w = inv_mod.band_weights_on(bands, table.wavelength_nm)
    inv = inv_mod.fit_inversion(
        rad, table.lamp, lamps, s.train, s.inner, w, inversion_conditions(table),
        basis=_surface_basis(table.wavelength_nm), always=always,
    )  # fmt: skip
    assert len(inv.flag_folds) == len(s.inner) and inv.flag_level == pytest.approx(
        1 - inv_mod.UNEXPLAINED_QUANTILE
    )
    for fold, (_, va) in zip(inv.flag_folds, s.inner, strict=True):
        rows = np.flatnonzero(np.isin(table.lamp, va))
        one = dataclasses.replace(inv, flag_folds=(fold,))
        p = one.known_type_p_value(rad[rows])
        assert np.all((p > 0) & (p <= 1))
        assert np.sum(fold.weights * (p < one.flag_level)) <= (
            one.flag_level * fold.weights.sum() + 1e-12
        )
        # the fold's scores are its held-out rows' misfits under its own prior
        _, mis = fold.model.posterior(
            rad[rows], None, [inv.flag_noise[0]], floors=[inv.flag_noise[1]]
        )
        np.testing.assert_allclose(mis[:, 0], fold.scores, rtol=1e-9)
    bare = dataclasses.replace(inv, flag_folds=())
    assert np.all(np.isnan(bare.known_type_p_value(rad[:3])))
    same = inv.restricted(np.ones(len(inv.prior.ids), bool))
    a, b = inv.predict(rad[:20]), same.predict(rad[:20])
    np.testing.assert_allclose(a.estimate, b.estimate, rtol=1e-12, equal_nan=True)
    np.testing.assert_array_equal(a.unexplained, b.unexplained)


def test_types_follow_the_inversion_and_unexplained_pixels_are_rejected(table, bands):
    """One outer fold fitted directly with `bandopt.inversion`: the classifier's
    types are the inversion's own (where it types the pixel), and a pixel no
    lamp explains (two narrow lines) is rejected whatever its confidence."""
    from bandopt.classify._inversion import _surface_basis  # cached (its SVD is slow)

    s = outer_splits(table, 0)[0]
    lamps, always = table_lamps(table)
    rad = table.band_radiance(bands, noise=True)  # the fixture's pixels
    w = inv_mod.band_weights_on(bands, table.wavelength_nm)
    inv = inv_mod.fit_inversion(
        rad,
        table.lamp,
        lamps,
        s.train,
        s.inner,
        w,
        inversion_conditions(table),
        basis=_surface_basis(table.wavelength_nm),
        always=always,
    )
    grid = table.wavelength_nm
    weird = np.exp(-0.5 * ((grid - 450) / 3) ** 2) + np.exp(
        -0.5 * ((grid - 820) / 3) ** 2
    )
    test = np.vstack([rad[table.rows_of_lamps(s.test)], (w @ (0.1 * weird))[None]])
    res = inv.predict(test)
    assert res.unexplained[-1] and not res.unexplained[:-1].all()
    t1, c1, t2, c2 = hierarchical_types(res)
    ok = ~res.unexplained
    np.testing.assert_array_equal(t1[ok], np.asarray(res.level1, object)[ok])
    np.testing.assert_array_equal(t2[ok], np.asarray(res.level2, object)[ok])
    # confidences are the posterior probabilities of the predicted classes
    np.testing.assert_allclose(
        c1,
        [
            p[res.level1_labels.index(c)]
            for p, c in zip(res.level1_probabilities, t1, strict=True)
        ],
    )
    np.testing.assert_allclose(
        c2,
        [
            p[res.level2_labels.index(c)]
            for p, c in zip(res.level2_probabilities, t2, strict=True)
        ],
    )
    out = withhold(t2, c2, REJECT_THRESHOLD, unexplained=res.unexplained)
    assert out[-1] == UNKNOWN
    expect = np.where(res.unexplained | (c2 < REJECT_THRESHOLD), UNKNOWN, t2)
    np.testing.assert_array_equal(out, expect)
    # above 0.5 the top level-2 class inside the family is the top one overall
    top = res.level2_probabilities.max(axis=1)
    np.testing.assert_array_equal(c2 >= REJECT_THRESHOLD, top >= REJECT_THRESHOLD)


def test_conditions_rebuilt_from_the_table_config():
    scen = build_scenarios(
        lamps=_small_ids()[:2],
        surfaces=("asphalt", "grass"),
        atmospheres=("none",),
        moons=(None, "full"),
        classes=("P4", "M3"),
    )
    ref = inv_mod.Conditions.from_scenarios(scen)
    got = inversion_conditions(scenario_table(scen))
    assert got.labels == ref.labels
    assert ref.moon is not None  # the full Moon's terms are compared
    for name in ("wavelength_nm", "t_up", "moon", "path", "lamp_transmittance"):
        a, b = getattr(got, name), getattr(ref, name)
        if b is None:
            assert a is None, name
        else:
            np.testing.assert_allclose(a, b, rtol=1e-12, err_msg=name)


def test_folds_are_the_search_contexts():
    """The classifier's outer and inner lamp splits are those of the band
    search's context for the same fold seed (same lamps, same order)."""
    from bandopt.search import get_context

    ctx = get_context("tiny", None, 0, "none")
    sc = ctx.config["scenarios"]
    full = scenario_table(
        build_scenarios(
            scored_only=True,
            surfaces=sc["surfaces"],
            atmospheres=sc["atmospheres"],
            moons=tuple(sc["moons"]),
            classes=sc["classes"],
        )
    )
    assert full.lamp_ids == tuple(ctx.lamp_ids)
    for a, b in zip(outer_splits(full, 0), ctx.splits, strict=True):
        np.testing.assert_array_equal(a.test, b.test)
        for (at, av), (bt, bv) in zip(a.inner, b.inner, strict=True):
            np.testing.assert_array_equal(at, bt)
            np.testing.assert_array_equal(av, bv)


def test_inversion_rejects_knn_only_options(table, bands):
    with pytest.raises(ValueError, match="k_grid"):
        evaluate_band_set(table, bands, estimator="inversion", k_grid=(1, 3))
    with pytest.raises(ValueError, match="estimator"):
        evaluate_band_set(table, bands, estimator="forest")


def test_table_lamps_refuses_lamps_outside_the_scored_library(table):
    import dataclasses

    bad = dataclasses.replace(table, lamp_ids=("no_such_lamp", *table.lamp_ids[1:]))
    with pytest.raises(ValueError, match="no_such_lamp"):
        table_lamps(bad)


# ------------------------------------------------------------------------------
# CLI


def test_cli_inversion_json_and_plot(capsys, tmp_path):
    from bandopt.cli import main

    png = tmp_path / "c.png"
    argv = ["classify", "--bands", "sdgsat-1", "--scenarios", "quick",
            "--atmospheres", "none", "--estimator", "inversion", "--json",
            "--plot", str(png)]  # fmt: skip
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["config"]["estimator"] == "inversion"
    assert out["config"]["features"] is None
    (b,) = out["band_sets"]
    lib = library()
    scored = [r for r in lib.records if lib.is_scored(r)]
    for level, n_cls in (
        ("level1", len({r.level1 for r in scored})),
        ("level2", len({r.level2 for r in scored})),
    ):
        s = b[level]
        assert len(s["f1"]) == n_cls
        assert 0.0 <= s["macro_f1"] <= 1.0
        assert s["macro_f1"] == pytest.approx(np.mean(list(s["f1"].values())))
        assert len(s["sigma_rel"]) == 3
        rej = s["reject"]
        assert 0.0 <= rej["coverage"] <= 1.0 and 0.0 <= rej["unexplained"] <= 1.0
        assert rej["threshold"] == REJECT_THRESHOLD
    assert b["level1"]["accuracy"] >= b["level2"]["accuracy"]
    assert png.is_file() and png.stat().st_size < 300_000


def test_cli_bad_estimator_is_a_usage_error(capsys):
    from bandopt.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["classify", "--bands", "sdgsat-1", "--estimator", "forest"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "forest" in err and "knn" in err and "inversion" in err


# ------------------------------------------------------------------------------
# Defaults unchanged by the modelled-lamp and surface-knowledge options


def test_defaults_use_none_of_the_options(result, table, bands):
    """Default `modelled_per_class=0` and `surface_mode="unknown"`: no
    modelled-lamp or mixture keys in the config (none was used), and the
    KNN's scores with the defaults equal those with the options given as
    their defaults."""
    assert "modelled_per_class" not in result.config
    assert result.config["surface"] == "unknown"
    assert all("modelled_added" not in f for f in result.level2.folds)
    knn = evaluate_band_set(table, bands, noise=True)
    explicit = evaluate_band_set(table, bands, noise=True, modelled_per_class=0)
    assert knn.level2.confusion == explicit.level2.confusion
    assert sum(map(sum, knn.level2.confusion)) == knn.level2.n_test_rows
    assert [f["k"] for f in knn.level2.folds] == [3, 3, 3]
    assert "modelled_per_class" not in knn.config
    assert "mixtures" not in result.config


def test_mixtures_reach_every_fold_and_the_config(table, bands, monkeypatch):
    """`mixtures=N` puts same-class blends into every outer fold's inversion
    (never of its test lamps: `_never_scored` and the fit's own checks), and
    the config says N; the KNN refuses it."""
    seen = []
    real = inv_mod.fit_inversion

    def spy(*a, **kw):
        inv = real(*a, **kw)
        seen.append((kw["mixtures"], inv.diagnostics["mixtures"]["n"]))
        return inv

    patch_inversion(monkeypatch, "fit_inversion", spy)
    res = evaluate_band_set(table, bands, noise=True, estimator="inversion", mixtures=2)
    assert res.config["mixtures"] == 2
    assert len(seen) == 3 and all(m == 2 and n > 0 for m, n in seen)
    assert 0.0 <= res.level2.macro_f1 <= 1.0
    with pytest.raises(ValueError, match="mixtures"):
        evaluate_band_set(table, bands, noise=True, mixtures=2)


def test_planck_and_shifts_reach_every_fold_and_the_config(table, bands, monkeypatch):
    """`planck=True` and `peak_shifts` (`bandopt evaluate`'s defaults) put the
    library's Planck spectra and shifted copies of the training direct LEDs
    into every outer fold's prior, the config says so, the scored pixels are
    still measured lamps' only; the KNN refuses both."""
    seen = []
    real = inv_mod.fit_inversion

    def spy(*a, **kw):
        inv = real(*a, **kw)
        seen.append((kw["peak_shifts"], inv.prior.ids))
        return inv

    patch_inversion(monkeypatch, "fit_inversion", spy)
    res = evaluate_band_set(
        table, bands, noise=True, estimator="inversion", planck=True,
        peak_shifts=(-5.0, 5.0),
    )
    planck = [i for i in inv_mod.planck_lamps(table.wavelength_nm).ids]
    assert res.config["modelled_in_prior"] == planck and len(planck) == 5
    assert res.config["peak_shifts_nm"] == [-5.0, 5.0]
    assert len(seen) == 3
    for shifts, ids in seen:
        assert shifts == (-5.0, 5.0)
        assert set(planck) <= set(ids)
        # each shifted copy is of a lamp in that fold's own prior
        moved = [i for i in ids if i.startswith("shift:")]
        assert all(i.split(":")[1].split("@")[0] in ids for i in moved)
    assert any(i.startswith("shift:") for _, ids in seen for i in ids)
    assert 0.0 <= res.level2.macro_f1 <= 1.0
    for kw in ({"planck": True}, {"peak_shifts": (5.0,)}):
        with pytest.raises(ValueError, match="planck, peak_shifts"):
            evaluate_band_set(table, bands, noise=True, **kw)


def test_cli_planck_and_shifts_are_for_the_inversion_only(capsys):
    from bandopt.cli import main

    argv = ["classify", "--bands", "sdgsat-1", "--scenarios", "quick"]
    for flag in ("--planck", "--peak-shifts"):
        assert main([*argv, flag, "on"]) == 2
        assert f"{flag} on: only the prior of --estimator inversion" in (
            capsys.readouterr().err
        )


@pytest.mark.parametrize("on", [True, False])
def test_cli_passes_planck_and_shifts_through(on, monkeypatch, capsys):
    """`bandopt classify --estimator inversion --planck on --peak-shifts on`
    asks `evaluate_band_set` for the Planck spectra and the shifted LEDs of
    `PEAK_SHIFTS_NM`; off (the default), for neither."""
    import bandopt.classify
    from bandopt.cli import main

    asked = {}

    def spy(*a, **kw):
        asked.update(kw)
        raise ValueError("spied")

    monkeypatch.setattr(bandopt.classify, "evaluate_band_set", spy)
    argv = ["classify", "--bands", "sdgsat-1", "--scenarios", "quick"]
    argv += ["--estimator", "inversion", "--atmospheres", "none"]
    if on:
        argv += ["--planck", "on", "--peak-shifts", "on"]
    assert main(argv) == 2 and "spied" in capsys.readouterr().err
    assert asked["planck"] is on
    assert tuple(asked["peak_shifts"]) == (inv_mod.PEAK_SHIFTS_NM if on else ())


def test_cli_mixtures_is_for_the_inversion_only(capsys):
    from bandopt.cli import main

    argv = ["classify", "--bands", "sdgsat-1", "--scenarios", "quick"]
    assert main([*argv, "--mixtures", "3"]) == 2
    assert "--estimator inversion only" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:  # a usage error, refused by the parser
        main([*argv, "--estimator", "inversion", "--mixtures", "-1"])
    assert e.value.code == 2
    assert "--mixtures: -1 is outside [0, inf]" in capsys.readouterr().err
