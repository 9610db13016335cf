"""Modelled incandescent spectra (Planck's law) in the inversion's prior
(`planck_lamps`, `leave_one_class_out(planck=True)`, estimator
`inversion-moon-mix-metric-narrow-planck`): what they are (one lumen, the
shape of colour-science's blackbody at their temperature), that they train
and never score and every record says so, and that a halogen lamp no
measured incandescent lamp trains for is named `incandescent` with them and
not without."""

import colour
import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.estimate import lamp_truth
from tests._bands import FIVE, GRID
from tests._inversion import patch_inversion
from tests.test_inversion_mixtures import spy_priors
from tests.test_inversion_models import _case, _fake_context, _pixels, patch_case


def test_planck_lamps_are_one_lumen_radiators_at_their_temperature():
    p = inv_mod.planck_lamps(GRID)
    assert p.ids == tuple(f"planck_incandescent_{t}k" for t in range(2400, 3201, 200))
    assert set(p.level1) == {"incandescent"}
    assert set(p.level2) == {"incandescent_halogen"}
    v = colour.SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    vis = GRID <= 780.0
    for pid, s in zip(p.ids, p.spectra, strict=True):
        lum = 683.0 * np.trapezoid(s[vis] * v[GRID[vis]], GRID[vis])
        assert lum == pytest.approx(1.0, rel=1e-3)
        # the shape of colour-science's blackbody at the same temperature
        t = float(pid.split("_")[-1][:-1])
        bb = colour.sd_blackbody(t, colour.SpectralShape(380, 900, 1)).values
        np.testing.assert_allclose(s / s.max(), bb / bb.max(), rtol=1e-3)


@pytest.fixture(scope="module")
def halogen_case():
    """The small case's lamps (no incandescent) plus three measured halogen
    lamps: the class held out."""
    lamps = _case()[0]
    lib = inv_mod.library_lamps(GRID, scored=True)
    hal = [i for i, c in enumerate(lib.level2) if c == "incandescent_halogen"][:3]
    lamps = lamps + lib.take(hal)
    row_lamp, rad, w = _pixels(lamps)
    return lamps, row_lamp, rad, w


def _unseen(halogen_case, monkeypatch, planck):
    lamps, row_lamp, rad, _ = halogen_case
    setup = (lamps, None, inv_mod.Conditions.clear(GRID), ["asphalt"] * len(row_lamp))
    patch_inversion(monkeypatch, "context_setup", lambda c: setup)
    truth, valid = lamp_truth(lamps.spectra, GRID)
    import types

    ctx = types.SimpleNamespace(
        wavelength_nm=GRID,
        radiance=lambda bands: rad,
        table=types.SimpleNamespace(lamp_of=row_lamp, truth=truth, valid=valid),
    )
    built = spy_priors(monkeypatch)
    recs = inv_mod.leave_one_class_out(ctx, FIVE, planck=planck)
    return [r for r in recs if r["held_out_class"] == "incandescent_halogen"], built


def test_a_held_out_halogen_is_named_incandescent_only_with_planck(
    halogen_case, monkeypatch
):
    without, built0 = _unseen(halogen_case, monkeypatch, False)
    assert {r["level1_in_prior"] for r in without} == {False}
    assert np.mean([r["level1_correct"] for r in without]) == 0.0
    assert not any(i.startswith("planck_") for ids in built0 for i in ids)
    assert not any("modelled_in_prior" in r for r in without)
    with pytest.MonkeyPatch.context() as mp:
        found, built1 = _unseen(halogen_case, mp, True)
    assert {r["level1_in_prior"] for r in found} == {True}
    assert np.mean([r["level1_correct"] for r in found]) > 0.9
    planck = set(inv_mod.planck_lamps(GRID).ids)
    assert all(planck <= set(ids) for ids in built1)  # in every prior built
    for r in found:
        assert r["modelled_in_prior"] == sorted(planck)
        assert not r["lamp"].startswith("planck_")  # measured lamps only score


def test_cross_validate_planck_rows_say_so_and_score_measured_lamps(monkeypatch):
    case = _case()
    lamps = case[0]
    patch_case(monkeypatch, case)
    ctx = _fake_context(case)
    both = (inv_mod.PLANCK_ESTIMATOR, inv_mod.DEFAULT_ESTIMATOR)
    recs = inv_mod.cross_validate(ctx, FIVE, estimators=both, folds=[0])
    assert recs and {r.estimator for r in recs} == set(both)
    assert {r.lamp for r in recs} <= set(lamps.ids)
    for r in recs:
        assert r.modelled_in_prior == list(inv_mod.planck_lamps(GRID).ids)
        assert r.out_of_range == 0
