"""The estimator contract, checked on every registered estimator (after
scikit-learn's `estimator_checks`): a frozen configuration found by name,
`fit` on a context's lamps, `predict` returning an `Estimates` record whose
values are physical or null with a reason, inside their intervals, with
types and probabilities that agree, deterministic and JSON-ready; and
`bandopt evaluate` offers exactly the registered estimators."""

import dataclasses
import json

import numpy as np
import pytest
from scipy.stats import spearmanr

from bandopt import inversion as inv_mod
from bandopt.datasets.lamps import LEVEL1, LEVEL2_PARENT
from bandopt.estimate import METRICS
from bandopt.estimators import (
    ESTIMATORS,
    Estimates,
    Fitted,
    Surface,
    configure,
    options_of,
    owners_of,
)
from bandopt.estimators._contract import no_report
from bandopt.search import get_context
from bandopt.sensor import BandSet


BANDS = BandSet.contiguous(8)
"""Contiguous bands tiling 380-780 nm: a band set every estimator takes (the
direct estimate needs a tiling)."""

SMALL = {
    "inversion": dict(
        mixtures=0,
        cross_mixtures=0,
        peak_shifts_nm=(),
        planck=False,
        calibration="lamps",
        interval_offsets=(0.0,),
        sigma_rule="error",
        floor_grid=(inv_mod.SIGMA_FLOOR,),
    )
}
"""Options that make a fit quick on the tiny scenario set (the contract, not
the defaults' accuracy, is checked here; `evaluate`'s defaults are tested
through the CLI)."""


@pytest.fixture(scope="module")
def ctx():
    return get_context("tiny", None, 0, "none")


@pytest.fixture(scope="module")
def fitted(ctx):
    return {
        name: configure(name, **SMALL.get(name, {})).fit(
            ctx, BANDS, surface_mode="unknown"
        )
        for name in ESTIMATORS
    }


@pytest.fixture(scope="module")
def pixels(ctx):
    """Every third pixel of the tiny set (asphalt, no atmosphere, no Moon:
    evaluate's scene), the surface unknown to the estimator, and the truth."""
    rows = np.arange(0, ctx.table.lamp_of.size, 3)
    refl = inv_mod.surface_basis(ctx.wavelength_nm).mean
    truth = np.asarray(ctx.table.truth)[np.asarray(ctx.table.lamp_of)[rows]]
    level1 = [
        LEVEL2_PARENT.get(c, c) for c in ctx.table.classes[ctx.table.lamp_of[rows]]
    ]
    return ctx.radiance(BANDS)[rows], Surface("unknown", None, refl), truth, level1


def test_registry_holds_frozen_configurations_found_by_any_spelling():
    assert set(ESTIMATORS) == {"inversion", "ridge", "kernel", "direct"}
    for name, cls in ESTIMATORS.items():
        assert cls.name == name and ESTIMATORS[name.upper()] is cls
        config = cls()
        with pytest.raises(dataclasses.FrozenInstanceError):
            config.x = 1
        hash(config)  # frozen configurations are hashable
        assert isinstance(cls.own_lamps, bool) and isinstance(cls.needs_surface, bool)
    with pytest.raises(ValueError, match=r"Unknown estimator 'knn'.*inversion"):
        ESTIMATORS.resolve("knn")


def test_configure_refuses_an_option_and_names_who_has_it():
    assert owners_of("mixtures") == ("inversion",)
    assert configure("Inversion", mixtures=7).mixtures == 7
    with pytest.raises(ValueError, match=r"'mixtures'.*ridge.*belongs to inversion"):
        configure("ridge", mixtures=7)
    with pytest.raises(ValueError, match="no registered estimator has it"):
        configure("inversion", no_such_option=1)
    assert "calibrate_probabilities" in options_of("inversion")


def test_evaluate_offers_exactly_the_registered_estimators():
    import argparse

    from bandopt.cli import _cmd_evaluate

    parser = argparse.ArgumentParser()
    _cmd_evaluate.register(parser.add_subparsers())
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    (est,) = [a for a in sub.choices["evaluate"]._actions if a.dest == "estimator"]
    assert tuple(est.choices) == tuple(ESTIMATORS)
    fields = {f for n in ESTIMATORS for f in options_of(n)}
    for flag, _, field, _ in _cmd_evaluate.OPTIONS.values():
        assert field in fields, f"{flag} sets {field}, which no estimator has"


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_predict_keeps_the_contract(name, fitted, pixels):
    model = fitted[name]
    rad, surface, _, _ = pixels
    assert isinstance(model, Fitted)
    assert isinstance(model.description, str) and len(model.description) > 40
    assert set(model.report()) == set(no_report())
    est = model.predict(rad, surface)
    assert isinstance(est, Estimates) and len(est) == len(rad)
    for m, metric in enumerate(METRICS):
        lo_phys, hi_phys = inv_mod.PHYSICAL_RANGE[metric]
        v, iv = est.values[:, m], est.interval90[:, m]
        null = ~np.isfinite(v)
        for i in np.flatnonzero(null):  # null, with a reason
            assert est.null_reasons[i].get(metric), (name, metric, i)
        ok = ~null
        assert np.all((v[ok] >= lo_phys) & (v[ok] <= hi_phys)), (name, metric)
        assert np.all(np.isfinite(iv[ok])), (name, metric)
        assert np.all(iv[ok, 0] <= iv[ok, 1])
        assert np.all((iv[ok, 0] >= lo_phys) & (iv[ok, 1] <= hi_phys))
    for i in range(len(est)):
        p = est.level1_probabilities[i]
        if est.unexplained[i]:  # flagged, not guessed
            assert est.level1[i] is None and est.level2[i] is None
        if p is not None:
            assert set(p) <= set(LEVEL1)
            assert sum(p.values()) == pytest.approx(1.0, abs=1e-9)
            if est.level1[i] is not None:
                assert est.level1[i] == max(p, key=p.get)
        row = est.row(i)
        json.dumps(row, allow_nan=False)  # null, never NaN
        assert Estimates.from_rows([row]).row(0) == row
    again = model.predict(rad, surface)
    np.testing.assert_array_equal(again.values, est.values)
    assert again.level1 == est.level1 and again.unexplained == est.unexplained


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_estimates_follow_the_truth_on_the_lamps_it_knows(name, fitted, pixels):
    """On pixels of lamps it was fitted to, every estimator's LER ranks the
    lamps as the truth does and names most level-1 families: an estimator
    that ignores its input fails here."""
    rad, surface, truth, true_level1 = pixels
    est = fitted[name].predict(rad, surface)
    ok = np.isfinite(est.values[:, 0]) & np.isfinite(truth[:, 0])
    assert ok.sum() > 0.5 * len(ok)
    rho = spearmanr(est.values[ok, 0], truth[ok, 0]).statistic
    assert rho > 0.7, (name, rho)
    named = [(a, b) for a, b in zip(est.level1, true_level1, strict=True) if a]
    assert np.mean([a == b for a, b in named]) > 0.6, name


def test_each_named_variant_is_the_options_its_name_lists():
    """`inversion.LABELLED`: every token of a variant's name sets exactly
    its option, and no option is set without its token."""
    for name, opts in inv_mod.LABELLED.items():
        tokens = set(name.split("-")[1:])
        assert opts.moon_told == ("moon" in tokens), name
        assert (opts.mixtures == inv_mod.MIX_PAIRS) == ("mix" in tokens), name
        assert (opts.sigma_rule == "per-metric") == ("metric" in tokens), name
        assert (opts.sigma_rule == "evidence") == ("evidence" in tokens), name
        grid = tuple(opts.interval_offsets) == inv_mod.INTERVAL_OFFSET_GRID
        assert grid == ("narrow" in tokens), name
        assert bool(opts.peak_shifts_nm) == ("shift" in tokens), name
        assert opts.planck == ("planck" in tokens), name
        assert opts.tm30 == ("tm30" in tokens), name
        assert (opts.calibration == "classes") == ("loco" in tokens), name
        assert opts.cross_mixtures == 0 and not opts.nir_error, name


def test_the_studies_default_variant_differs_from_evaluates_only_where_said():
    """The studies' `DEFAULT_ESTIMATOR` and the shipped estimator
    (`InversionConfig()`) differ in the options added after those studies
    ran, and in nothing else."""
    from bandopt.estimators import InversionConfig

    study = inv_mod.LABELLED[inv_mod.DEFAULT_ESTIMATOR]
    shipped = InversionConfig()
    differ = {
        f.name
        for f in dataclasses.fields(shipped)
        if getattr(shipped, f.name) != getattr(study, f.name)
    }
    assert differ == {
        "cross_mixtures",
        "calibration",
        "nir_error",
        "calibrate_probabilities",
    }
