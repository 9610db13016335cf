"""The regression baselines' out-of-library check (`bandopt.novelty`): lamp
pixels of known types are flagged at about its nominal rate, a spectrum
unlike every lamp (a narrow line) is flagged, and `bandopt evaluate` gives
no type for a flagged pixel."""

import numpy as np
import pytest

from bandopt import novelty
from bandopt.search import get_context


@pytest.fixture(scope="module")
def setup():
    from bandopt.sensor.reference import resolve_band_set

    ctx = get_context("tiny", None, 0, "none")
    bands = resolve_band_set("results/search/recommended_bands.json").bands
    return ctx, bands, ctx.radiance(bands)


def test_known_lamps_are_flagged_near_the_nominal_rate(setup):
    ctx, _, rad = setup
    s = ctx.splits[0]
    chk = novelty.fit_ratio_novelty(rad, ctx.table, s.train, s.inner)
    assert chk.rows > 0 and chk.threshold > 0
    # held-out lamps of known types, class-balanced: about 1 - QUANTILE
    rows = np.isin(ctx.table.lamp_of, s.test)
    w = ctx.table.scenario_weights(s.test)[rows]
    rate = float(np.sum(w * chk.flags(rad[rows])) / w.sum())
    assert rate < 3 * (1 - novelty.QUANTILE)
    # the training pixels themselves are at distance 0
    train_rows = np.isin(ctx.table.lamp_of, s.train)
    assert not chk.flags(rad[train_rows]).any()


def test_a_narrow_line_a_dark_band_and_nan_are_flagged(setup):
    ctx, bands, rad = setup
    chk = novelty.fit_ratio_novelty(
        rad, ctx.table, np.arange(ctx.table.n_lamps),
        ctx.folds.outer(),
    )  # fmt: skip
    grid = np.asarray(ctx.wavelength_nm, float)
    line = np.exp(-0.5 * ((grid - 450.0) / 2.0) ** 2)
    resp = np.asarray(bands.response(grid))
    band = resp @ line
    assert chk.flags((band + 1e-12 * band.max())[None])[0]
    dark = np.asarray(rad[:1]).copy()
    dark[0, 0] = 0.0  # a band with no light at all
    assert chk.flags(dark)[0] and not chk.flags(np.asarray(rad[:1]))[0]
    bad = np.asarray(rad[:1]).copy()
    bad[0, 0] = np.nan  # no number: never unflagged
    assert chk.distance(bad)[0] == np.inf and chk.flags(bad)[0]


def test_bad_arguments_are_refused(setup):
    ctx, _, rad = setup
    s = ctx.splits[0]
    with pytest.raises(ValueError, match="quantile"):
        novelty.fit_ratio_novelty(rad, ctx.table, s.train, s.inner, quantile=1.0)
    with pytest.raises(ValueError, match="inner"):
        novelty.fit_ratio_novelty(rad, ctx.table, s.train, [])
