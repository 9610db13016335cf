"""A search context whose scenes include measurement effects of each lamp's
spectrum (`bandopt.search._task.ScenePerturbations`): perturbed rows keep
their lamp's index and labels, folds stay lamp-grouped, the NIR variants move
only the modelled part, and the context records what it holds."""

import dataclasses

import numpy as np
import pytest

from bandopt.datasets.lamps import library
from bandopt.forward import dense_spectra
from bandopt.inversion import library_lamps
from bandopt.scene import build_scenarios
from bandopt.search._task import (
    KINDS,
    PRESETS,
    ScenePerturbations,
    get_context,
    perturbed_scenes,
)


ROUNDING_REL = 1e-12
"""Relative difference allowed where a perturbation must leave a spectrum
unchanged: the NIR variants are renormalised to one lumen, which moves the
visible part by float64 rounding only (about 1e-15 of the row's peak)."""

TEST_PRESET = "tiny_perturbed_test"
CONFIG = ScenePerturbations()


@pytest.fixture(scope="module")
def contexts():
    """The `tiny` context (one scene per lamp, no atmosphere) clean and with
    every kind under every scene (`CONFIG`)."""
    PRESETS[TEST_PRESET] = dict(PRESETS["tiny"], perturbations=CONFIG)
    try:
        clean = get_context("tiny", None, 0, "none")
        pert = get_context(TEST_PRESET, None, 0, "none")
    finally:
        del PRESETS[TEST_PRESET]
    return clean, pert


def test_rows_keep_lamp_index_and_labels(contexts):
    clean, pert = contexts
    n_l = clean.table.n_lamps
    q = pert.toa.shape[1]
    assert q == 1 + len(CONFIG.kinds)
    assert pert.toa.shape[0] == n_l
    np.testing.assert_array_equal(pert.table.lamp_of, np.repeat(np.arange(n_l), q))
    np.testing.assert_array_equal(pert.table.classes, clean.table.classes)
    np.testing.assert_array_equal(pert.table.truth, clean.table.truth)
    np.testing.assert_array_equal(pert.table.valid, clean.table.valid)
    assert pert.lamp_ids == clean.lamp_ids
    # each kind once per lamp, copy 0 clean and equal to the clean context
    kinds = np.asarray(KINDS)[pert.scene_kind]
    assert (kinds == np.asarray(("clean", *CONFIG.kinds))[None, :]).all()
    np.testing.assert_array_equal(pert.toa[:, 0], clean.toa[:, 0])


def test_folds_stay_lamp_grouped(contexts):
    clean, pert = contexts
    for s_clean, s in zip(clean.splits, pert.splits, strict=True):
        np.testing.assert_array_equal(s.train, s_clean.train)
        np.testing.assert_array_equal(s.test, s_clean.test)
        assert not np.intersect1d(s.train, s.test).size
        rows_test = np.isin(pert.table.lamp_of, s.test)
        rows_train = np.isin(pert.table.lamp_of, s.train)
        assert not (rows_test & rows_train).any()
        # every perturbed row of a test lamp is a test row
        kinds_test = pert.scene_kind.ravel()[rows_test]
        assert set(kinds_test) == set(range(len(KINDS)))
        per_lamp = np.bincount(pert.table.lamp_of[rows_test])
        assert set(per_lamp[per_lamp > 0]) == {pert.toa.shape[1]}


def test_nir_rows_differ_only_beyond_measured_end(contexts):
    clean, pert = contexts
    grid = pert.wavelength_nm
    recs = {r.id: r for r in library().records}
    changed = 0
    for kind in ("nir-low", "nir-high"):
        col = KINDS.index(kind)
        for i, lamp_id in enumerate(pert.lamp_ids):
            j = int(np.flatnonzero(pert.scene_kind[i] == col)[0])
            row, ref = pert.toa[i, j], clean.toa[i, 0]
            rec = recs[lamp_id]
            scale = np.abs(ref).max()
            if not rec.extended:
                np.testing.assert_array_equal(row, ref)
                continue
            end = max(float(rec.measured_range_nm[1]), 780.0)
            inside = grid <= end
            assert np.abs(row - ref)[inside].max() <= ROUNDING_REL * scale, lamp_id
            changed += bool(np.abs(row - ref)[~inside].max() > ROUNDING_REL * scale)
    assert changed > 0


def test_other_kinds_change_the_visible(contexts):
    clean, pert = contexts
    vis = pert.wavelength_nm <= 780.0
    for kind in ("background-flat", "noise", "shift"):
        j = ("clean", *CONFIG.kinds).index(kind)
        d = np.abs(pert.toa[:, j, vis] - clean.toa[:, 0, vis]).max(axis=1)
        assert (d > 0).all(), kind


def test_config_records_the_perturbations(contexts):
    clean, pert = contexts
    assert clean.config["perturbations"] is None
    rec = pert.config["perturbations"]
    assert rec == CONFIG.to_dict()
    assert rec["background_fraction"] == 0.01
    assert rec["noise_snr"] == 100.0
    assert rec["shift_nm"] == 1.0
    assert rec["kinds"] == list(KINDS[1:])
    n_l = pert.table.n_lamps
    assert pert.config["rows_per_kind"] == dict.fromkeys(KINDS, n_l)
    assert pert.config["clean_scenes_per_lamp"] == 1
    assert pert.config["scenes_per_lamp"] == pert.toa.shape[1]


def test_copies_draw_distinct_kinds_and_keep_layout():
    """With fewer copies than kinds: each scene's copies differ in kind,
    every lamp gets every kind (4 scenes x 2 copies over 5 kinds), copy 0 of
    each surface block is the clean scene, and the draw is seeded."""
    grid = library().wavelength_nm
    lamps = library_lamps(grid, scored=True).take(np.arange(0, 40, 5))
    scen = build_scenarios(
        lamps=list(lamps.ids),
        surfaces=("asphalt", "grass"),
        atmospheres=("none",),
        moons=(None, "full"),
        classes=("P4",),
    )
    cfg = ScenePerturbations(copies=2, seed=3)
    toa, kind = perturbed_scenes(scen, lamps, cfg)
    n_l, n_s, n_m = len(lamps.ids), 2, 2
    assert toa.shape[:2] == (n_l, n_s * 3 * n_m)
    k = kind.reshape(n_l, n_s, 3, n_m)
    assert (k[:, :, 0] == 0).all()
    assert (k[:, :, 1] != k[:, :, 2]).all() and (k[:, :, 1:] > 0).all()
    for i in range(n_l):
        assert set(k[i, :, 1:].ravel()) == set(range(1, len(KINDS)))
    ref = np.asarray(dense_spectra(scen)).reshape(n_l, n_s, n_m, -1)
    np.testing.assert_array_equal(toa.reshape(n_l, n_s, 3, n_m, -1)[:, :, 0], ref)
    toa2, kind2 = perturbed_scenes(scen, lamps, cfg)
    np.testing.assert_array_equal(kind2, kind)
    np.testing.assert_array_equal(toa2, toa)
    _, kind3 = perturbed_scenes(scen, lamps, dataclasses.replace(cfg, seed=4))
    assert (kind3 != kind).any()


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"copies": 0}, "copies"),
        ({"copies": 6}, "copies"),
        ({"background_fraction": 0.0}, "background_fraction"),
        ({"noise_snr": -1.0}, "noise_snr"),
        ({"shift_nm": 0.0}, "shift_nm"),
        (
            {
                "nir_error": False,
                "background_fraction": None,
                "noise_snr": None,
                "shift_nm": None,
            },
            "every effect is off",
        ),
    ],
)
def test_bad_settings_are_refused(kw, match):
    with pytest.raises(ValueError, match=match):
        ScenePerturbations(**kw)


def test_kinds_follow_the_switches():
    cfg = ScenePerturbations(nir_error=False, noise_snr=None, copies=1)
    assert cfg.kinds == ("background-flat", "shift")
    assert cfg.n_copies == 1
    assert ScenePerturbations().n_copies == len(KINDS) - 1
