"""Wavelength-shifted copies of direct-emission LEDs in the inversion's prior
(`direct_emitters`, `shifted_lamps`, `fit_inversion(peak_shifts=)`,
estimator `inversion-moon-mix-metric-narrow-shift`): which lamps are shifted
(one narrow band only), what a shifted copy is (the same band moved by δ,
one lumen, its LER recomputed independently with colour-science), that the
copies come from each prior's own lamps only, and that a new amber LED whose
band lies beyond the training LEDs' is estimated far better with them."""

import colour
import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.estimate import lamp_truth
from tests._bands import GRID
from tests.test_inversion_mixtures import spy_priors
from tests.test_inversion_models import _case, _pixels


def _band(centre_nm, fwhm_nm):
    sd = fwhm_nm / (2.0 * np.sqrt(2.0 * np.log(2.0)))
    return np.exp(-0.5 * ((GRID - centre_nm) / sd) ** 2)


def _set(*spectra, level2="led_amber"):
    n = len(spectra)
    return inv_mod.LampSet(
        tuple(f"s{i}" for i in range(n)),
        np.array(spectra, float),
        ("led",) * n,
        (level2,) * n,
    )


def _lumen(spectrum):
    """683 ∫ V S dλ over 380-780 nm with colour-science's CIE 1924 V."""
    v = colour.SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    vis = GRID <= 780.0
    return 683.0 * np.trapezoid(spectrum[vis] * v[GRID[vis]], GRID[vis])


def test_only_one_narrow_band_is_a_direct_emitter():
    lamps = _set(
        _band(595.0, 18.0),  # a direct amber LED
        _band(610.0, 80.0),  # a phosphor band: too wide
        _band(450.0, 20.0) + 0.8 * _band(600.0, 20.0),  # two bands
        _band(530.0, 35.0),  # narrow enough
    )
    assert inv_mod.direct_emitters(lamps, GRID).tolist() == [0, 3]


def test_library_direct_emitters_are_the_narrow_amber_leds():
    """Of the library's measured lamps, only the four direct amber LEDs
    (half-maximum width 13-20 nm) are shifted: not the phosphor-converted
    amber LEDs, nor the warm white LEDs whose blue pump is weak."""
    lib = inv_mod.library_lamps(GRID, scored=True)
    picked = inv_mod.direct_emitters(lib, GRID)
    assert {lib.level2[i] for i in picked} == {"led_amber"}
    assert len(picked) == 4
    assert not any("pc_amber" in lib.ids[i] for i in picked)


def test_a_shifted_copy_is_the_band_moved_at_one_lumen():
    base = _band(595.0, 18.0)
    lamps = _set(base / _lumen(base))
    sh = inv_mod.shifted_lamps(lamps, GRID, (-5.0, 2.5, 10.0))
    assert sh.ids == ("shift:s0@-5nm", "shift:s0@+2.5nm", "shift:s0@+10nm")
    assert sh.level1 == ("led",) * 3 and sh.level2 == ("led_amber",) * 3
    truth, valid = lamp_truth(sh.spectra, GRID)
    for k, d in enumerate((-5.0, 2.5, 10.0)):
        s = sh.spectra[k]
        assert _lumen(s) == pytest.approx(1.0, rel=1e-6)
        # the band's centre of mass moved by d, its shape did not
        com = np.sum(GRID * s) / np.sum(s)
        assert com == pytest.approx(595.0 + d, abs=0.05)
        moved = _band(595.0 + d, 18.0)
        np.testing.assert_allclose(s / s.max(), moved / moved.max(), atol=2e-3)
        # LER from colour-science, independently of bandopt.photometry
        vis = GRID <= 780.0
        sd = colour.SpectralDistribution(dict(zip(GRID[vis], s[vis], strict=True)))
        ler = colour.luminous_efficacy(sd)
        assert valid[k, 0] and truth[k, 0] == pytest.approx(ler, rel=1e-3)
    # a longer wavelength is less efficacious beyond V's 555 nm peak
    assert truth[0, 0] > truth[1, 0] > truth[2, 0]


def test_bad_shifts_are_refused_and_no_led_gives_none():
    lamps = _set(_band(595.0, 18.0))
    for bad in ((0.0,), (5.0, 5.0), (float("nan"),)):
        with pytest.raises(ValueError, match="peak shifts"):
            inv_mod.shifted_lamps(lamps, GRID, bad)
    wide = _set(_band(600.0, 90.0))
    out = inv_mod.shifted_lamps(wide, GRID)
    assert out.ids == () and out.spectra.shape == (0, GRID.size)


@pytest.fixture(scope="module")
def case():
    return _case()


def _amber_case(case):
    """The small case's lamps plus the library's four direct amber LEDs; the
    test lamp is the 600 nm one (peak 605 nm, LER 399 lm/W), the three
    others peak at 594-596 nm (LER 459-489)."""
    lib = inv_mod.library_lamps(GRID, scored=True)
    amber = [lib.ids.index(i) for i in (
        "photobiology_agilent_hlmp_dl32",
        "photobiology_epileds_3w_590nm",
        "photobiology_osram_ly5436",
        "photobiology_epileds_3w_600nm",
    )]  # fmt: skip
    lamps = case[0] + lib.take(amber)
    return (lamps, *_pixels(lamps))


def test_an_amber_led_beyond_the_training_peaks_is_found_with_shifts(case):
    lamps, row_lamp, rad, w = _amber_case(case)
    test = len(lamps.ids) - 1
    train = lamps.take(np.arange(test))
    cond = inv_mod.Conditions.clear(GRID)
    basis = inv_mod._basis(GRID)
    truth, _ = lamp_truth(lamps.spectra[test:], GRID)
    rows = row_lamp == test
    errs = {}
    for shifts in ((), inv_mod.PEAK_SHIFTS_NM):
        prior = train + inv_mod.shifted_lamps(train, GRID, shifts) if shifts else train
        inv = inv_mod.build_inversion(prior, w, cond, basis, "unknown", 0.003)
        est = inv.predict(rad[rows]).estimate
        errs[bool(shifts)] = np.abs(est[:, 0] - truth[0, 0]).mean()
    assert errs[False] > 40.0  # lm/W: the nearest training LED's LER is 60 off
    assert errs[True] < 0.25 * errs[False]


def test_fit_shifts_its_own_priors_leds_only(case, monkeypatch):
    """Every prior the fit builds holds shifted copies of its own direct
    LEDs only; the diagnostics say how many the final prior holds; the
    scored-lamp guard catches a shifted copy of a test lamp."""
    lamps, row_lamp, rad, w = _amber_case(case)
    test = np.array([len(lamps.ids) - 1])
    train = np.arange(len(lamps.ids) - 1)
    l2 = np.asarray(lamps.level2, object)
    inner = [(np.setdiff1d(train, v), v) for v in (train[::2], train[1::2])]
    built = spy_priors(monkeypatch)
    inv = inv_mod.fit_inversion(
        rad, row_lamp, lamps, train, inner, w, inv_mod.Conditions.clear(GRID),
        basis=inv_mod._basis(GRID), peak_shifts=(-5.0, 5.0),
    )  # fmt: skip
    assert len(built) == len(inner) + 1
    for ids, allowed in zip(built, [tr for tr, _ in inner] + [train], strict=True):
        ok = {lamps.ids[i] for i in allowed}
        src = {i[6:].rsplit("@", 1)[0] for i in ids if i.startswith("shift:")}
        assert src <= ok
        assert all(l2[lamps.ids.index(x)] == "led_amber" for x in src)
    d = inv.diagnostics["peak_shifts"]
    assert d["shifts_nm"] == [-5.0, 5.0]
    assert d["n"] == 2 * 3  # three direct amber LEDs train, two shifts each
    assert sum(i.startswith("shift:") for i in inv.prior.ids) == d["n"]
    inv_mod._check_never_scored(inv, [lamps.ids[i] for i in test])
    with pytest.raises(RuntimeError, match="shifted copies of scored lamps"):
        inv_mod._check_never_scored(inv, ["photobiology_osram_ly5436"])
    # the default builds none
    plain = inv_mod.fit_inversion(
        rad, row_lamp, lamps, train, inner, w, inv_mod.Conditions.clear(GRID),
        basis=inv_mod._basis(GRID),
    )  # fmt: skip
    assert plain.diagnostics["peak_shifts"]["n"] == 0
    assert not any(i.startswith("shift:") for i in plain.prior.ids)
