"""Modelled training lamps and surface knowledge in lamp-type classification
(`bandopt.classify.evaluate_band_set(modelled_per_class=, surface_mode=)`,
`bandopt classify --modelled-per-class --surface-knowledge`; issues 11 b, 12).

A small case: the 4 measured mercury lamps and 3 lamps of four other scored
classes, on asphalt and grass, no atmosphere, no Moon, classes P1 and P6;
only the mercury model is sampled (its lamps fit in ~10 s, once per
process). With 3 outer x 2 inner folds an outer training set holds 2-3
mercury lamps and an inner one 1-2, so some inner sets get no model (fewer
than `MIN_CALIBRATION_LAMPS`): both paths run."""

import json

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bandopt import inversion as inv_mod, lampmodels
from bandopt.classify import (
    evaluate_band_set,
    neighbour_labels,
    outer_splits,
    scenario_table,
)
from bandopt.classify._inversion import surface_types
from bandopt.classify._modelled import modelled_noise_key, modelled_rows
from bandopt.datasets.lamps import library
from bandopt.forward import noise_draws
from bandopt.knn import features
from bandopt.scene import build_scenarios
from tests._bands import FIVE


CLASSES = ("hps", "led_warm", "led_cool", "fluorescent_linear", "mercury")
MODELLED = ("mercury",)
N_MODEL = 3
BANDS = FIVE


def _ids():
    lib = library().select(scored_only=True)
    out = []
    for c in CLASSES:
        ids = [r.id for r in lib.records if r.level2 == c]
        out += ids if c == "mercury" else ids[:3]
    return out


@pytest.fixture(scope="module")
def table():
    return scenario_table(
        build_scenarios(
            lamps=_ids(),
            surfaces=("asphalt", "grass"),
            atmospheres=("none",),
            moons=(None,),
            classes=("P1", "P6"),
        )
    )


def _spied(fn):
    """Run `fn()` recording every `lampmodels.calibrate` call (the real
    function runs): (result, [(class, train lamps, calibrated lamps)])."""
    calls = []
    real = lampmodels.calibrate

    def spy(level2, train_lamps=None):
        cal = real(level2, train_lamps)
        calls.append((level2, tuple(train_lamps), tuple(cal.lamps)))
        return cal

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(lampmodels, "calibrate", spy)
        return fn(), calls


@pytest.fixture(scope="module")
def knn(table):
    """The KNN without and with modelled lamps, k fixed to 1 (so a test
    row's class is its nearest training row's), and the calibrations."""
    kw = dict(noise=True, seed=0, k_grid=(1,), keep_rows=True)
    plain = evaluate_band_set(table, BANDS, **kw)
    models, calls = _spied(
        lambda: evaluate_band_set(
            table,
            BANDS,
            modelled_per_class=N_MODEL,
            modelled_classes=MODELLED,
            **kw,
        )
    )
    return plain, models, calls


def _fold_sets(table):
    """Per outer fold: (test ids, allowed training-id sets: outer + inner)."""
    ids = np.asarray(table.lamp_ids, dtype=object)
    return [
        (set(ids[s.test]), [set(ids[s.train])] + [set(ids[tr]) for tr, _ in s.inner])
        for s in outer_splits(table, 0)
    ]


def _check_calibrations(table, calls):
    """Every model was calibrated on the measured training lamps of one
    outer or inner training set, never on a lamp of that fold's test set."""
    assert calls, "no model was calibrated"
    folds = _fold_sets(table)
    # the inversion's priors also hold the never-scored measured lamps
    always = set(inv_mod.library_lamps(table.wavelength_nm, scored=False).ids)
    for level2, train_lamps, cal_lamps in calls:
        assert level2 in MODELLED
        measured = set(train_lamps) - always
        owners = [(test, ok) for test, ok in folds if measured in ok]
        assert owners, train_lamps
        for test, _ in owners:
            assert not set(train_lamps) & test
            assert not set(cal_lamps) & test
        assert set(cal_lamps) <= set(train_lamps)


# ------------------------------------------------------------------------------
# KNN


def test_knn_modelled_rows_train_but_never_test(table, knn):
    plain, models, calls = knn
    _check_calibrations(table, calls)
    # the inner folds that choose k have their own models (module docstring)
    inner_sets = [ok[1:] for _, ok in _fold_sets(table)]
    assert any(set(c[1]) in sets for c in calls for sets in inner_sets)
    cfg = models.config
    assert cfg["modelled_per_class"] == N_MODEL
    assert cfg["modelled_lamps"]["classes"] == list(MODELLED)
    test_ids = dict(enumerate(t for t, _ in _fold_sets(table)))
    for rec in cfg["modelled_lamps"]["per_fold"]:
        cal = rec["calibration_lamps"].get("mercury", [])
        assert not set(cal) & test_ids[rec["outer"]]
        assert set(rec["added"]) | set(rec["skipped"]) == {"mercury"}
    for level in ("level1", "level2"):
        p, m = plain.level(level), models.level(level)
        # the same measured test rows, each once; no modelled lamp scored
        np.testing.assert_array_equal(p.rows[0], m.rows[0])
        np.testing.assert_array_equal(np.sort(m.rows[0]), np.arange(table.n_rows))
        assert set(m.lamp_accuracy) == set(table.lamp_ids)
        assert m.n_test_rows == table.n_rows
        added = 0
        for fp, fm, rec in zip(
            p.folds, m.folds, cfg["modelled_lamps"]["per_fold"], strict=True
        ):
            assert fm["n_train_rows"] == fp["n_train_rows"]  # measured rows
            assert fm["modelled_added"] == rec["added"]
            n_scenes = table.n_rows // len(table.lamp_ids)
            assert fm["n_modelled_train_rows"] == n_scenes * sum(rec["added"].values())
            added += sum(rec["added"].values())
        assert added > 0  # at least one fold trained on modelled lamps


def test_knn_votes_include_the_documented_modelled_rows(table, knn):
    """k = 1: every test row takes the class of its nearest row among the
    outer fold's measured training rows and the modelled rows of stream
    `outer * (n_inner + 1) + n_inner` (module docstring of `_evaluate`)."""
    _, models, _ = knn
    x = np.asarray(features(table.band_radiance(BANDS, noise=True, seed=0)))
    cls = list(models.level2.labels)
    y = np.array([cls.index(c) for c in table.labels("level2")])
    rows, _, pred = models.level2.rows
    pred_of = dict(zip(rows.tolist(), pred, strict=True))
    changed = 0
    for s in outer_splits(table, 0):
        n_inner = len(s.inner)
        m = modelled_rows(
            table, s.train, BANDS, N_MODEL, classes=MODELLED, seed=0,
            stream=s.outer * (n_inner + 1) + n_inner,
        )  # fmt: skip
        tr = table.rows_of_lamps(s.train)
        te = np.flatnonzero(table.rows_of_lamps(s.test))
        xt, yt = x[tr], y[tr]
        if m.n_rows:
            xm = np.asarray(features(m.radiance))
            xt = np.vstack([xt, xm])
            yt = np.concatenate([yt, [cls.index(c) for c in m.labels("level2")]])
            changed += 1
        nn = neighbour_labels(xt, yt, x[te], 1)[:, 0]
        assert [pred_of[i] for i in te] == [cls[j] for j in nn]
    assert changed


def test_knn_default_is_measured_only_and_says_so(table, knn):
    plain, _, _ = knn
    assert "modelled_per_class" not in plain.config  # as before the option
    assert "modelled_lamps" not in plain.config
    assert all("n_modelled_train_rows" not in f for f in plain.level2.folds)
    again = evaluate_band_set(
        table, BANDS, noise=True, seed=0, k_grid=(1,), modelled_per_class=0
    )
    assert again.to_dict() == plain.to_dict()


def test_knn_refuses_what_it_cannot_do(table):
    with pytest.raises(ValueError, match=r"surface_mode 'class'.*KNN"):
        evaluate_band_set(table, BANDS, surface_mode="class")
    with pytest.raises(ValueError, match="surface_mode"):
        evaluate_band_set(table, BANDS, surface_mode="daylight")
    with pytest.raises(ValueError, match="modelled_per_class must be >= 0"):
        evaluate_band_set(table, BANDS, modelled_per_class=-1)
    with pytest.raises(ValueError, match="train_rows"):
        evaluate_band_set(
            table, BANDS, modelled_per_class=2, train_rows=np.ones(table.n_rows, bool)
        )
    import dataclasses

    bare = dataclasses.replace(table, scenarios=None)
    with pytest.raises(ValueError, match="no scenario set behind it"):
        modelled_rows(bare, [0, 1], BANDS, 2, classes=MODELLED)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(0, 50))
def test_modelled_noise_is_never_a_measured_rows_noise(seed, stream):
    """The modelled rows' draws differ from the measured rows' draws of the
    same seed and of the next seeds (the documented separate stream)."""
    z_m = np.asarray(noise_draws(modelled_noise_key(seed, stream), 6, 3))
    for other in (seed, seed + stream, seed + 1):
        z = np.asarray(noise_draws(other, 6, 3))
        assert not np.any(np.isclose(z_m, z, rtol=0, atol=1e-12))
    z_next = np.asarray(noise_draws(modelled_noise_key(seed, stream + 1), 6, 3))
    assert not np.any(np.isclose(z_m, z_next, rtol=0, atol=1e-12))


def test_modelled_rows_are_the_scenes_of_the_table(table):
    """Noise-free modelled rows are the table's scenes lit by the modelled
    spectra (same surfaces, classes; linear in the lamp), labelled with the
    model's class; the noisy ones use the stream's draws."""
    s = outer_splits(table, 0)[0]
    m = modelled_rows(table, s.train, BANDS, 2, classes=MODELLED, noise=False)
    assert m.table is not None and m.table.lamp_ids == tuple(
        inv_mod.modelled_lamps(
            [table.lamp_ids[i] for i in s.train], table.wavelength_nm, 2,
            classes=MODELLED,
        )[0].ids
    )  # fmt: skip
    n_scenes = table.n_rows // len(table.lamp_ids)
    assert m.n_rows == 2 * n_scenes
    np.testing.assert_array_equal(m.table.surface[:n_scenes], table.surface[:n_scenes])
    assert set(m.labels("level2")) == {"mercury"}
    noisy = modelled_rows(table, s.train, BANDS, 2, classes=MODELLED, stream=4)
    z = np.asarray(noise_draws(modelled_noise_key(0, 4), m.n_rows, len(BANDS)))
    from bandopt.forward import band_radiance

    ref = band_radiance(m.table, BANDS, noise=z)
    np.testing.assert_allclose(noisy.radiance, np.asarray(ref), rtol=1e-12)
    assert not np.allclose(noisy.radiance, m.radiance)


# ------------------------------------------------------------------------------
# inversion


def test_inversion_modelled_lamps_in_the_prior_only(table):
    plain = evaluate_band_set(table, BANDS, estimator="inversion")
    models, calls = _spied(
        lambda: evaluate_band_set(
            table,
            BANDS,
            estimator="inversion",
            modelled_per_class=N_MODEL,
            modelled_classes=MODELLED,
        )
    )
    _check_calibrations(table, calls)
    cfg = models.config
    assert cfg["modelled_per_class"] == N_MODEL
    assert "modelled_per_class" not in plain.config
    assert cfg["surface"] == "unknown"
    for fp, fm, (test, _) in zip(
        plain.level2.folds, models.level2.folds, _fold_sets(table), strict=True
    ):
        n_added = sum(fm["modelled_added"].values())
        assert fm["n_prior_lamps"] == fp["n_prior_lamps"] + n_added
        for cal in fm["modelled_calibration_lamps"].values():
            assert not set(cal) & test
        assert fm["n_test_rows"] == fp["n_test_rows"]
    assert any(sum(f["modelled_added"].values()) for f in models.level2.folds)
    assert set(models.level2.lamp_accuracy) == set(table.lamp_ids)
    assert models.level2.n_test_rows == table.n_rows
    json.dumps(models.to_dict())


@pytest.mark.parametrize("mode", ["class", "measured"])
def test_inversion_surface_knowledge_reaches_the_fit(table, mode):
    """The classifier's types for fold 0 are those of `fit_inversion` +
    `predict` given the same per-row surface knowledge (noise-free: the
    deduplicated rows, so a misaligned row index would show), and the record
    says the mode."""
    from bandopt.classify import hierarchical_types, inversion_conditions, table_lamps
    from bandopt.classify._inversion import _surface_basis
    from bandopt.classify._scores import usable_rows

    res = evaluate_band_set(
        table, BANDS, estimator="inversion", surface_mode=mode, noise=False,
        keep_rows=True, seed=5,
    )  # fmt: skip
    assert res.config["surface"] == mode and res.config["seed"] == 5
    rad = table.band_radiance(BANDS)
    keep = usable_rows(np.asarray(features(rad)), table, False)
    assert not keep.all()  # deduplication happened: indices matter
    basis = _surface_basis(table.wavelength_nm)
    types = surface_types(table)
    know = types if mode == "class" else inv_mod.measured_surfaces(types, basis, seed=5)

    def pick(mask):
        idx = np.flatnonzero(mask)
        return know[idx] if mode == "measured" else [know[i] for i in idx]

    lamps, always = table_lamps(table)
    s = outer_splits(table, 0)[0]
    inv = inv_mod.fit_inversion(
        rad[keep], table.lamp[keep], lamps, s.train, s.inner,
        inv_mod.band_weights_on(BANDS, table.wavelength_nm),
        inversion_conditions(table), basis=basis, surface_mode=mode,
        row_surface=pick(keep), always=always,
    )  # fmt: skip
    te = keep & table.rows_of_lamps(s.test)
    want = hierarchical_types(inv.predict(rad[te], pick(te)))[2]
    rows, _, pred = res.level2.rows
    got = dict(zip(rows.tolist(), pred, strict=True))
    assert [got[i] for i in np.flatnonzero(te)] == list(want)
    assert res.level2.folds[0]["sigma_rel"] == inv.sigma_rel


def test_surface_types_of_samples_and_mixes():
    t = scenario_table(
        build_scenarios(
            lamps=_ids()[:1], surfaces=("asphalt",), surface_samples=2,
            atmospheres=("none",), moons=(None,), classes=("P4",),
        )
    )  # fmt: skip
    assert list(t.surface) == ["asphalt#0", "asphalt#1"]
    assert surface_types(t) == ["asphalt", "asphalt"]
    mix = scenario_table(
        build_scenarios(
            lamps=_ids()[:1], surfaces=(("asphalt", "grass", 0.5),),
            atmospheres=("none",), moons=(None,), classes=("P4",),
        )
    )  # fmt: skip
    with pytest.raises(ValueError, match="mix of two types"):
        surface_types(mix)


# ------------------------------------------------------------------------------
# CLI


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--surface-knowledge", "class"], ["--surface-knowledge", "inversion"]),
        (["--modelled-per-class", "-1"], ["--modelled-per-class", "outside [0, inf]"]),
    ],
)
def test_cli_refuses_bad_combinations(capsys, argv, words):
    from bandopt.cli import main

    try:
        rc = main(["classify", "--bands", "sdgsat-1", "--scenarios", "quick", *argv])
    except SystemExit as e:  # a number out of range is the parser's usage error
        rc = e.code
    assert rc == 2
    err = capsys.readouterr().err
    assert all(w in err for w in words), err


def test_cli_help_gives_defaults(capsys):
    from bandopt.cli import main

    with pytest.raises(SystemExit):
        main(["classify", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "--modelled-per-class N" in out and "Default 0" in out
    assert "--surface-knowledge {unknown,class,measured}" in out
