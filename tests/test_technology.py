"""`bandopt.datasets.technology`: a lamp's technology from robust spectral
features, checked on the library's own lamps clean and perturbed, and the
extension of a user's spectrum beyond its measured end."""

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter1d

from bandopt.datasets import nir, technology as tech
from bandopt.datasets.lamps import library
from bandopt.spectra import GRID_1NM


CLEAN_MIN_ACCURACY = 0.95
"""Share of the library's lamps whose top-scored technology is their own,
clean (measured: 0.98)."""

PERTURBED_MIN_ACCURACY = 0.90
"""The same under each perturbation of `PERTURBATIONS` (measured 0.93-0.99;
0.93 at 10 nm resolution, where metal halide lines blend)."""

SNR_PER_NM = 30.0
"""Spectrometer noise: Gaussian, standard deviation = mean visible level / 30
per 1 nm sample."""

BACKGROUND = 0.02
"""Flat background: 2 % of the visible power (level 0.02 x the mean)."""

PERTURBATIONS = (
    "noise",
    "background",
    "res2",
    "res5",
    "res10",
    "shift+2",
    "shift-2",
    "combined",
)


def _perturb(w, v, kind, rng):
    mean = v[(w >= 380) & (w <= 780)].mean()
    if kind == "noise":
        return v + rng.normal(0.0, mean / SNR_PER_NM, v.size)
    if kind == "background":
        return v + BACKGROUND * mean
    if kind.startswith("res"):  # Gaussian slit of that FWHM
        return gaussian_filter1d(v, float(kind[3:]) / 2.3548, mode="nearest")
    if kind.startswith("shift"):
        return np.interp(w - float(kind[5:]), w, v)
    # combined: 5 nm resolution, 1.5 nm shift, background and noise
    v = np.interp(w - 1.5, w, gaussian_filter1d(v, 5 / 2.3548, mode="nearest"))
    return v + BACKGROUND * mean + rng.normal(0.0, mean / SNR_PER_NM, v.size)


@pytest.fixture(scope="module")
def lamps():
    """(id, technology, wavelength, values) of every measured library lamp
    with a technology and a complete 380-780 nm spectrum."""
    lib = library(extend_nir=False)
    w = lib.wavelength_nm
    vis = (w >= 380) & (w <= 780)
    out = []
    for r, v in zip(lib.records, lib.values, strict=True):
        t = nir.technology_of(r.level2, r.level1)
        if t is None or r.modelled or np.isnan(v[vis]).any():
            continue
        m = ~np.isnan(v)
        out.append((r.id, t, w[m], v[m]))
    return out


def _accuracy(lamps, kind=None):
    rng = np.random.default_rng(0)
    right: dict[str, list[bool]] = {}
    for _, t, w, v in lamps:
        x = v if kind is None else _perturb(w, v, kind, rng)
        e = tech.identify_technology(w, x)
        right.setdefault(t, []).append(e.candidates[0] == t)
    overall = float(np.mean([x for r in right.values() for x in r]))
    return overall, {t: float(np.mean(r)) for t, r in right.items()}


def test_library_accuracy_clean(lamps):
    overall, per = _accuracy(lamps)
    assert set(per) == set(nir.TECHNOLOGIES)
    assert overall >= CLEAN_MIN_ACCURACY, per
    # every technology with >= 5 lamps is mostly right on its own
    assert all(per[t] >= 0.9 for t in ("led", "fluorescent", "hps", "incandescent"))


@pytest.mark.parametrize("kind", PERTURBATIONS)
def test_library_accuracy_perturbed(lamps, kind):
    overall, per = _accuracy(lamps, kind)
    assert overall >= PERTURBED_MIN_ACCURACY, (kind, per)


def _one(lamps, level_id_prefix, technology):
    return next(
        x for x in lamps if x[1] == technology and x[0].startswith(level_id_prefix)
    )


@pytest.mark.parametrize(
    ("prefix", "technology"),
    [
        ("nist_traditional_hps", "hps"),
        ("nist_traditional_mercury", "mercury"),
        ("nist_traditional_triphosphor", "fluorescent"),
        ("cie_fl2", "fluorescent"),
        ("", "lps"),
        ("", "incandescent"),
    ],
)
def test_specific_lamps(lamps, prefix, technology):
    _, t, w, v = _one(lamps, prefix, technology)
    e = tech.identify_technology(w, v)
    assert e.technology == t and not e.ambiguous, e.scores
    assert abs(sum(e.scores.values()) - 1) < 1e-9
    assert e.evidence and all(isinstance(x, str) for x in e.evidence)


def test_mercury_evidence_names_its_lines(lamps):
    _, _, w, v = _one(lamps, "", "mercury")
    e = tech.identify_technology(w, v)
    text = " ".join(e.evidence)
    assert "Hg 436 nm line, prominence" in text and "Hg 546 nm line" in text


def test_noisy_led_to_798_nm_is_led_and_keeps_its_data(lamps):
    """The case the nearest-lamp rule got wrong: a cool white LED measured to
    798 nm with spectrometer noise is an LED; its 780-798 nm data are kept and
    its extension is an LED tail, not fluorescent lines."""
    rng = np.random.default_rng(3)
    cool = [x for x in lamps if x[1] == "led" and x[0].startswith("photobiology")]
    for _, _, w, v in cool[:5]:
        m = w <= 798
        x = v[m] + rng.normal(0.0, v[m & (w <= 780)].mean() / SNR_PER_NM, m.sum())
        ext = tech.extend_user_spectrum(w[m], x)
        assert ext.technologies == ("led",), ext.identification.scores
        grid = np.asarray(GRID_1NM)
        kept = (grid > 780) & (grid <= 798)
        np.testing.assert_allclose(ext.spectra[0, kept], np.interp(grid[kept], w[m], x))
        assert ext.note["nir_extension"] == "led"


def test_extension_options(lamps):
    _, _, w, v = _one(lamps, "color_pollution_hps", "hps")  # measured to 900 nm
    m = w <= 790
    grid = np.asarray(GRID_1NM)
    beyond = grid > 790
    none = tech.extend_user_spectrum(w[m], v[m], "none")
    assert none.spectra.shape == (1, grid.size) and none.technologies == (None,)
    assert np.all(none.spectra[0, beyond] == 0) and "zeros" in none.note["policy"]
    forced = tech.extend_user_spectrum(w[m], v[m], "Fluorescent")
    assert (
        forced.technologies == ("fluorescent",) and "as asked" in forced.note["policy"]
    )
    own = tech.extend_user_spectrum(w[m], v[m], (grid, np.full(grid.size, 7.0)))
    assert np.all(own.spectra[0, beyond] == 7.0) and own.nir == "user"
    auto = tech.extend_user_spectrum(w[m], v[m])
    assert auto.technologies == ("hps",)
    na = (grid >= 815) & (grid <= 823)
    assert auto.spectra[0, na].max() > auto.spectra[0, (grid > 840)].max()
    full = tech.extend_user_spectrum(w, v)  # measured to 900 nm: resampled only
    assert full.note is None and full.nir == "measured"
    with pytest.raises(ValueError, match="auto"):
        tech.extend_user_spectrum(w[m], v[m], "foo")
    with pytest.raises(ValueError, match="must cover"):
        tech.extend_user_spectrum(w[m], v[m], (grid[:450], np.ones(450)))
    with pytest.raises(ValueError, match="380-780"):
        tech.extend_user_spectrum(w[w <= 700], v[w <= 700])


def test_ambiguous_evidence_gives_every_candidate():
    """A mercury lamp's lines diluted by an LED's continuum (flux ratio
    1.25) are a mercury lamp's or a fluorescent lamp's: one extension per
    candidate, best first."""
    lib = library(extend_nir=False)
    w = lib.wavelength_nm
    ids = [r.id for r in lib.records]
    led = lib.values[ids.index("photobiology_airam_led_11w_4000k")]
    hg = lib.values[ids.index("nist_traditional_mercury")]
    vis = (w >= 380) & (w <= 780)
    mix = led / led[vis].mean() + 1.25 * hg / hg[vis].mean()
    e = tech.identify_technology(w[vis], mix[vis])
    ext = tech.extend_user_spectrum(w[vis], mix[vis])
    assert e.ambiguous and e.technology is None
    assert set(e.candidates) == {"mercury", "fluorescent"}
    second = e.scores[e.candidates[1]]
    assert second >= tech.AMBIGUITY_RATIO * e.scores[e.candidates[0]]
    assert ext.technologies == e.candidates and ext.spectra.shape[0] == len(
        e.candidates
    )


def test_fast():
    """Pure and fast enough for a robustness study: < 20 ms a spectrum."""
    import time

    w = np.arange(380.0, 799.0)
    v = np.exp(-0.5 * ((w - 450) / 10) ** 2) + np.exp(-0.5 * ((w - 600) / 50) ** 2)
    tech.extend_user_spectrum(w, v)  # calibrates the NIR model once
    t0 = time.perf_counter()
    for _ in range(20):
        tech.extend_user_spectrum(w, v)
    assert (time.perf_counter() - t0) / 20 < 0.02
