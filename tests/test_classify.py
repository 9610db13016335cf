"""Lamp-type classification: features, dedup, KNN, metrics, folds, search, CLI."""

import itertools
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from sklearn.metrics import f1_score

from bandopt.classify import (
    SearchBox,
    SearchData,
    choose_k,
    deduplicate,
    features,
    make_classifier,
    neighbour_labels,
    nlopt_search,
    reject,
    reject_curve,
    scores,
    soft_nn_loss,
    vote_proba,
)
from bandopt.forward import radiance_from_response


# ------------------------------------------------------------------------------
# Features


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.floats(1e-3, 1e3), min_size=3, max_size=3),
    st.floats(1e-4, 1e4),
    st.sampled_from(["log_ratio", "sum_normalised"]),
)
def test_features_invariant_to_brightness(radiance, scale, kind):
    r = np.asarray(radiance)
    a = np.asarray(features(r, kind))
    b = np.asarray(features(scale * r, kind))
    # log(s r / mean(s r)) == log(r / mean(r)) up to rounding of the product
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)


def test_features_known_values():
    r = np.array([1.0, 2.0, 4.0])
    x = np.asarray(features(r, "log_ratio"))
    # centred log ratios: log r - mean(log r) (δ changes them by < 1e-6)
    np.testing.assert_allclose(x, np.log(r) - np.log(r).mean(), atol=1e-5)
    np.testing.assert_allclose(np.asarray(features(r, "sum_normalised")), r / 7.0)
    with pytest.raises(ValueError, match="log_ratio"):
        features(r, "ratios")


def test_features_dark_pixel_has_finite_gradient():
    g = jax.grad(lambda r: jnp.sum(features(r) ** 2))(jnp.zeros(3))
    assert np.all(np.isfinite(np.asarray(g)))


# ------------------------------------------------------------------------------
# De-duplication of class-scaled scenarios


def _scored_ids(n):
    from bandopt.datasets.lamps import library

    return library().select(scored_only=True).ids[:n]


def test_dedup_removes_class_scaled_copies():
    from bandopt.classify import scenario_table
    from bandopt.classify._scores import usable_rows
    from bandopt.scene import build_scenarios

    scen = build_scenarios(
        lamps=_scored_ids(4),
        surfaces=("asphalt", "grass"),
        atmospheres=("none",),
        moons=(None, "full"),
        classes=("P1", "P6", "M1"),
    )
    table = scenario_table(scen)
    from bandopt.sensor import BandSet

    bands = BandSet.from_physical([450.0, 550.0, 650.0], [40.0, 40.0, 40.0])
    x = np.asarray(features(table.band_radiance(bands)))
    keep = usable_rows(x, table, noise=False)
    # without the Moon only the class scale differs: 3 classes -> 1 row per
    # (lamp, surface); with the Moon every class gives a different colour
    no_moon = table.moon == "none"
    assert keep[no_moon].sum() == 4 * 2
    assert keep[~no_moon].sum() == (~no_moon).sum()
    # with noise nothing is removed
    assert usable_rows(x, table, noise=True).all()


def test_dedup_generic():
    x = np.array([[1.0, 2.0], [1.0, 2.0], [1.0, 2.0 + 1e-3], [1.0, 2.0]])
    groups = np.array([0, 0, 0, 1])
    np.testing.assert_array_equal(deduplicate(x, groups), [0, 2, 3])


# ------------------------------------------------------------------------------
# KNN


def _blobs(seed=0, n=40):
    rng = np.random.default_rng(seed)
    centres = np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]])
    y = np.repeat(np.arange(3), n)
    x = centres[y] + 0.3 * rng.standard_normal((3 * n, 2))
    return x, y


def test_knn_toy_answer_known():
    x, y = _blobs()
    clf = make_classifier(5).fit(x, y)
    test = np.array([[0.1, -0.2], [4.8, 0.3], [-0.2, 5.1]])
    np.testing.assert_array_equal(clf.predict(test), [0, 1, 2])


def test_fast_votes_equal_one_vs_rest():
    x, y = _blobs(1)
    rng = np.random.default_rng(2)
    test = rng.uniform(-1, 6, (200, 2))  # includes ambiguous points between blobs
    for k in (1, 5, 15):
        clf = make_classifier(k).fit(x, y)
        fast = vote_proba(neighbour_labels(x, y, test, k), k, 3)
        np.testing.assert_allclose(clf.predict_proba(test), fast, atol=1e-12)
        np.testing.assert_array_equal(clf.predict(test), np.argmax(fast, 1))


def test_choose_k_prefers_large_k_on_noisy_labels():
    x, y = _blobs(3, 60)
    rng = np.random.default_rng(4)
    flip = rng.random(len(y)) < 0.25
    y_noisy = np.where(flip, rng.integers(0, 3, len(y)), y)
    lamp = np.arange(len(y)) // 3
    lamps = np.unique(lamp)
    inner = [
        (lamps[lamps % 2 == 0], lamps[lamps % 2 == 1]),
        (lamps[lamps % 2 == 1], lamps[lamps % 2 == 0]),
    ]
    k, sc = choose_k(x, y_noisy, lamp, inner, 3, (1, 15))
    assert k == 15 and sc[15] > sc[1]


def test_reject_coverage_monotone():
    x, y = _blobs(5)
    rng = np.random.default_rng(6)
    test = rng.uniform(-1, 6, (300, 2))
    proba = make_classifier(9).fit(x, y).predict_proba(test)
    truth = np.asarray(["a", "b", "c"], object)[rng.integers(0, 3, 300)]
    curve = reject_curve(truth, proba, ["a", "b", "c"], np.linspace(0, 1, 11))
    cov = [c["coverage"] for c in curve]
    assert cov[0] == 1.0 and all(b <= a for a, b in itertools.pairwise(cov))
    lab = reject(proba, ["a", "b", "c"], 0.99)
    assert set(lab[proba.max(1) < 0.99]) <= {"unknown"}


# ------------------------------------------------------------------------------
# Metrics against scikit-learn


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 10_000))
def test_f1_matches_sklearn(seed):
    rng = np.random.default_rng(seed)
    labels = ["a", "b", "c", "d"]
    yt = np.asarray(labels, object)[rng.integers(0, 4, 60)]
    yp = np.asarray([*labels, "unknown"], object)[rng.integers(0, 5, 60)]
    s = scores(yt, yp, labels)
    ref = f1_score(yt, yp, labels=labels, average=None, zero_division=0)
    np.testing.assert_allclose([s["f1"][c] for c in labels], ref, atol=1e-12)
    np.testing.assert_allclose(
        s["macro_f1"],
        f1_score(yt, yp, labels=labels, average="macro", zero_division=0),
        atol=1e-12,
    )
    assert s["accuracy"] == pytest.approx(np.mean(yt == yp))


# ------------------------------------------------------------------------------
# Folds never leak lamps


def test_outer_and_inner_folds_never_share_lamps():
    from bandopt.classify import outer_splits

    table = _small_table()
    splits = outer_splits(table, 0)
    tested = np.concatenate([s.test for s in splits])
    assert sorted(tested.tolist()) == list(range(len(table.lamp_ids)))
    for s in splits:
        assert not set(s.train) & set(s.test)
        for tr, va in s.inner:
            assert not set(tr) & set(va)
            assert set(tr) | set(va) == set(s.train)
        # every scored level-2 class is on both sides
        assert set(table.level2[s.train]) == set(table.level2[s.test])
        # rows of a test lamp never sit in training rows
        assert not (table.rows_of_lamps(s.train) & table.rows_of_lamps(s.test)).any()


def _small_table():
    from bandopt.classify import scenario_table
    from bandopt.scene import build_scenarios

    return scenario_table(
        build_scenarios(
            scored_only=True,
            surfaces=("asphalt",),
            atmospheres=("none",),
            moons=(None,),
            classes=("P4",),
        )
    )


def test_band_radiance_matches_forward_simulate():
    from bandopt.forward import simulate
    from bandopt.scene import build_scenarios
    from bandopt.sensor import BandSet

    scen = build_scenarios(
        lamps=_scored_ids(3),
        surfaces=("asphalt",),
        atmospheres=("none",),
        moons=(None, "full"),
        classes=("P4",),
    )
    from bandopt.classify import scenario_table

    table = scenario_table(scen)
    bands = BandSet.from_physical([480.0, 600.0], [30.0, 60.0])
    ref = simulate(scen, bands, crop=False).radiance.reshape(-1, 2)
    np.testing.assert_allclose(table.band_radiance(bands), ref, rtol=1e-10)


# ------------------------------------------------------------------------------
# Searches


def _toy_search_data(n_bands=2, noise=True):
    """Three 'lamp types' with Gaussian emission lines at 450, 600, 800 nm on a
    flat background; 4 lamps each with shifted lines."""
    w = np.arange(400.0, 900.0, 2.0)
    rng = np.random.default_rng(0)
    toa, y, lamp = [], [], []
    for c, line in enumerate((450.0, 600.0, 800.0)):
        for j in range(4):
            centre = line + rng.uniform(-8, 8)
            spec = 0.2 + np.exp(-0.5 * ((w - centre) / 10.0) ** 2)
            for s in (0.5, 1.0, 2.0):
                toa.append(1e-6 * s * spec)
                y.append(c)
                lamp.append(4 * c + j)
    y, lamp = np.asarray(y), np.asarray(lamp)
    ev, od = np.flatnonzero(lamp % 2 == 0), np.flatnonzero(lamp % 2 == 1)
    z = rng.standard_normal((len(y), n_bands)) if noise else None
    return SearchData(np.asarray(toa), w, y, lamp, 3, ((ev, od), (od, ev)), z, None)


def test_surrogate_gradient_matches_finite_differences():
    data = _toy_search_data(2)
    box = SearchBox(
        2, lower_nm=400.0, upper_nm=898.0, min_fwhm_nm=15.0, max_fwhm_nm=150.0
    )
    raw = jnp.asarray([-0.3, 0.4, 0.2, -0.5])

    @jax.jit
    def loss(r):
        return soft_nn_loss(r, data, box)

    g = np.asarray(jax.grad(loss)(raw))
    assert np.all(np.isfinite(g)) and np.any(g != 0)
    h = 1e-5
    for i in range(4):
        e = jnp.zeros(4).at[i].set(h)
        fd = (float(loss(raw + e)) - float(loss(raw - e))) / (2 * h)
        # central differences in float64: error O(h^2) plus rounding ~1e-9
        assert g[i] == pytest.approx(fd, rel=1e-4, abs=1e-7)


def test_nlopt_search_seeded_reproducible_and_finds_lines():
    data = _toy_search_data(2, noise=False)
    box = SearchBox(
        2, lower_nm=400.0, upper_nm=898.0, min_fwhm_nm=15.0, max_fwhm_nm=150.0
    )
    a = nlopt_search(data, box, max_evals=60, seed=3)
    b = nlopt_search(data, box, max_evals=60, seed=3)
    assert a["u"] == b["u"] and a["inner_macro_f1"] == b["inner_macro_f1"]
    assert a["n_evals"] <= 60
    # two bands suffice to tell three separated lines apart
    assert a["inner_macro_f1"] > 0.9


def test_noise_free_radiance_is_linear_in_spectra():
    data = _toy_search_data(2, noise=False)
    box = SearchBox(2, lower_nm=400.0, upper_nm=898.0)
    resp = box.response(box.even_start(), data.wavelength_nm)
    r1 = radiance_from_response(
        jnp.asarray(data.toa), jnp.asarray(data.wavelength_nm), resp
    )
    r2 = radiance_from_response(
        3.0 * jnp.asarray(data.toa), jnp.asarray(data.wavelength_nm), resp
    )
    np.testing.assert_allclose(np.asarray(r2), 3.0 * np.asarray(r1), rtol=1e-12)


# ------------------------------------------------------------------------------
# CLI


def test_cli_json_schema(capsys):
    from bandopt.cli import main

    rc = main(
        [
            "classify",
            "--bands",
            "iss-dslr",
            "viirs-dnb",
            "--scenarios",
            "quick",
            "--atmospheres",
            "none",
            "--json",
        ]
    )
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["config"]["estimator"] == "knn"  # the default
    assert [b["source"] for b in out["band_sets"]] == ["iss-dslr", "viirs-dnb"]
    from bandopt.datasets.lamps import library

    lib = library()
    scored = [r for r in lib.records if lib.is_scored(r)]
    n_classes = {
        "level1": len({r.level1 for r in scored}),
        "level2": len({r.level2 for r in scored}),
    }  # every scored class of the library is present in the quick scenario set
    for b in out["band_sets"]:
        for level, n_cls in n_classes.items():
            s = b[level]
            assert len(s["f1"]) == n_cls
            assert 0.0 <= s["macro_f1"] <= 1.0
            assert s["macro_f1"] == pytest.approx(np.mean(list(s["f1"].values())))
            assert 0.0 <= s["reject"]["coverage"] <= 1.0
    # a single broad band has no colour: one log ratio is always 0
    assert (
        out["band_sets"][1]["level2"]["macro_f1"]
        < out["band_sets"][0]["level2"]["macro_f1"]
    )


def test_cli_bad_band_name(capsys):
    from bandopt.cli import main

    assert main(["classify", "--bands", "no-such-sensor", "--scenarios", "quick"]) == 2
    assert "no-such-sensor" in capsys.readouterr().err


def test_equidistant_training_rows_vote_by_class_frequency():
    """A one-band sensor's features are all 0: every training row is equally
    near, and the vote follows the class frequencies (to one vote) instead of
    the kd-tree's order; distinct features still use the kd-tree."""
    from bandopt.classify import neighbour_labels, vote_proba

    rng = np.random.default_rng(0)
    y = rng.choice(3, size=600, p=[0.6, 0.3, 0.1])
    x = np.zeros((600, 1))
    nbr = neighbour_labels(x, y, np.zeros((7, 1)), 50)
    assert nbr.shape == (7, 50) and np.all(nbr == nbr[:1])
    freq = np.bincount(y, minlength=3) / len(y)
    for k in (1, 5, 10, 50):
        p = vote_proba(nbr, k, 3)[0]
        assert np.all(np.abs(p - freq) <= 1.0 / k + 1e-12), (k, p, freq)
    # distinct features: the true nearest neighbours
    xs = np.arange(600, dtype=float)[:, None]
    got = neighbour_labels(xs, y, np.array([[10.2]]), 3)
    np.testing.assert_array_equal(got[0], y[[10, 11, 9]])
