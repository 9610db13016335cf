"""Measurement effects on lamp spectra: what a field or lab spectrum holds
beyond the lamp.

Each function takes lamp spectra `(l, w)` on a uniform 1 nm grid (the
library's 380-900 nm) and returns perturbed spectra of the same shape; none
changes its input, and the random ones take a seed. They model what a
spectrum measured outside a laboratory carries, so a robustness study can
ask whether an estimate made from such a spectrum's pixels still holds:

- `add_flat_background`: a constant offset (stray light, an unsubtracted dark
  level) at a given fraction of the lamp's visible power;
- `add_skyglow`: the sky glow of a city, the spectrum of its lamp mix
  (`skyglow_spectrum`, `CITY_MIX`), at a given fraction of the visible power;
- `add_spectrometer_noise`: additive Gaussian noise at a given signal-to-noise
  ratio per nm (`SNR` against the mean visible level, the same σ at every
  wavelength);
- `degrade_resolution`: a Gaussian slit of a given FWHM;
- `shift_wavelength`: a wavelength-calibration error;
- `truncate_and_extend`: a spectrum measured only up to a cut, extended
  beyond it by a given rule (the product's own extension of a user spectrum);
- `mix_lamps`: another lamp's light in the same pixel at a given share of the
  luminous flux.

Visible power is `∫_380^780 S dλ` and luminous flux `683 ∫_380^780 V S dλ`
(trapezoid on the grid, CIE 1924 V), the library's conventions.
"""

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from jaxtyping import ArrayLike, Float

from ._photometry_tables import observer_tables
from .photometry import K_M_LM_PER_W, VISIBLE_END_NM, VISIBLE_START_NM


GRID_STEP_NM = 1.0
"""The grid step every function here expects: the library's 1 nm grid (the
noise is defined per nm and the shift and slit in samples of it)."""

GRID_TOLERANCE_NM = 1e-6
"""How far a grid step may be from `GRID_STEP_NM` (floating-point rounding of
a grid built with `np.arange`)."""

CITY_MIX = {"hps": 0.5, "led_warm": 0.2, "led_cool": 0.2, "metal_halide": 0.1}
"""Shares of a city's luminous flux by level-2 lamp class for the sky-glow
spectrum: an assumption, not a survey, describing a European city part-way
through its conversion from high-pressure sodium to white LEDs (half the
light still HPS, two fifths white LED split evenly between warm and cool,
the rest metal halide). A study that needs another city gives its own."""

SLIT_TRUNCATE_SIGMAS = 5.0
"""The Gaussian slit is sampled to ± this many standard deviations (the
weight beyond is below 1e-6 of the total) and normalised to unit sum."""

FWHM_PER_SIGMA = 2.0 * np.sqrt(2.0 * np.log(2.0))
"""FWHM of a Gaussian in units of its standard deviation."""


def _check(spectra, wavelength_nm) -> tuple[np.ndarray, np.ndarray]:
    """Spectra as (l, w) floats and the grid, checked: 1-D, uniform 1 nm,
    covering the visible range, matching the spectra's last axis."""
    w = np.asarray(wavelength_nm, float)
    s = np.asarray(spectra, float)
    if w.ndim != 1 or w.size < 2:
        raise ValueError("wavelength_nm: need a 1-D grid of at least 2 samples.")
    if np.any(np.abs(np.diff(w) - GRID_STEP_NM) > GRID_TOLERANCE_NM):
        raise ValueError(f"wavelength_nm: need a uniform {GRID_STEP_NM:g} nm grid.")
    if w[0] > VISIBLE_START_NM or w[-1] < VISIBLE_END_NM:
        raise ValueError(
            f"wavelength_nm: covers {w[0]:g}-{w[-1]:g} nm; need "
            f"{VISIBLE_START_NM}-{VISIBLE_END_NM} nm."
        )
    if s.ndim != 2 or s.shape[1] != w.size:
        raise ValueError(
            f"spectra: expected shape (lamps, {w.size}) on the grid, got {s.shape}."
        )
    return s, w


def _visible(w: np.ndarray) -> np.ndarray:
    return (w >= VISIBLE_START_NM) & (w <= VISIBLE_END_NM)


def visible_power(
    spectra: Float[ArrayLike, "l w"], wavelength_nm: Float[ArrayLike, " w"]
) -> np.ndarray:
    """Visible power `∫_380^780 S dλ` per lamp (trapezoid), (l,). [W lm⁻¹ for
    per-lumen spectra]"""
    s, w = _check(spectra, wavelength_nm)
    vis = _visible(w)
    return np.trapezoid(s[:, vis], w[vis], axis=1)


def luminous_flux_lm(
    spectra: Float[ArrayLike, "l w"], wavelength_nm: Float[ArrayLike, " w"]
) -> np.ndarray:
    """Luminous flux `683 ∫_380^780 V S dλ` per lamp (trapezoid, CIE 1924 V),
    (l,); 1 for the library's per-lumen spectra. [lm per unit of S·nm/W]"""
    s, w = _check(spectra, wavelength_nm)
    vis = _visible(w)
    obs_w, v, _ = observer_tables()
    v_on = np.interp(w[vis], obs_w, v)
    return K_M_LM_PER_W * np.trapezoid(s[:, vis] * v_on, w[vis], axis=1)


def add_flat_background(
    spectra: Float[ArrayLike, "l w"],
    wavelength_nm: Float[ArrayLike, " w"],
    fraction: float,
) -> np.ndarray:
    """Each spectrum plus a constant over the whole grid whose visible power
    is `fraction` of the spectrum's own (`visible_power`): stray light or an
    unsubtracted dark level, flat in wavelength. [same unit as `spectra`]"""
    s, w = _check(spectra, wavelength_nm)
    if not fraction >= 0:
        raise ValueError(f"fraction {fraction!r}: need a value >= 0.")
    width = VISIBLE_END_NM - VISIBLE_START_NM  # ∫ 1 dλ over the visible grid
    level = fraction * visible_power(s, w) / width
    return s + level[:, None]


def skyglow_spectrum(
    spectra: Float[ArrayLike, "l w"],
    level2: Sequence[str],
    wavelength_nm: Float[ArrayLike, " w"],
    shares: Mapping[str, float] = CITY_MIX,
) -> np.ndarray:
    """The sky glow of a city lit by the lamp mix `shares` (level-2 class ->
    share of the city's luminous flux; normalised to sum 1), (w,): the
    flux-weighted sum of each class's mean per-lumen spectrum among
    `spectra` (whose level-2 classes are `level2`), scaled to unit visible
    power. The atmosphere's wavelength dependence of scattering is left out:
    the shape is that of the light sent up. [nm⁻¹]"""
    s, w = _check(spectra, wavelength_nm)
    l2 = np.asarray(level2, dtype=object)
    if l2.shape != (s.shape[0],):
        raise ValueError(f"level2: need {s.shape[0]} labels, got {l2.shape}.")
    total = float(sum(shares.values()))
    if not shares or total <= 0 or any(v < 0 for v in shares.values()):
        raise ValueError(f"shares {dict(shares)!r}: need shares >= 0, sum > 0.")
    missing = sorted(c for c in shares if not np.any(l2 == c))
    if missing:
        raise ValueError(
            f"shares: classes {missing} have no lamp among the spectra "
            f"(classes present: {sorted(set(l2))})."
        )
    per_lumen = s / luminous_flux_lm(s, w)[:, None]
    sky = sum(v / total * per_lumen[l2 == c].mean(axis=0) for c, v in shares.items())
    return sky / visible_power(sky[None], w)[0]


def add_skyglow(
    spectra: Float[ArrayLike, "l w"],
    wavelength_nm: Float[ArrayLike, " w"],
    fraction: float,
    sky: Float[ArrayLike, " w"],
) -> np.ndarray:
    """Each spectrum plus the sky-glow spectrum `sky` (`skyglow_spectrum`)
    scaled so that its visible power is `fraction` of the spectrum's own.
    [same unit as `spectra`]"""
    s, w = _check(spectra, wavelength_nm)
    g = np.asarray(sky, float)
    if g.shape != w.shape:
        raise ValueError(f"sky: need shape {w.shape}, got {g.shape}.")
    if not fraction >= 0:
        raise ValueError(f"fraction {fraction!r}: need a value >= 0.")
    p_sky = visible_power(g[None], w)[0]
    if not p_sky > 0:
        raise ValueError("sky: its visible power must be > 0.")
    return s + (fraction * visible_power(s, w) / p_sky)[:, None] * g[None]


def add_spectrometer_noise(
    spectra: Float[ArrayLike, "l w"],
    wavelength_nm: Float[ArrayLike, " w"],
    snr: float,
    *,
    seed: int,
) -> np.ndarray:
    """Each spectrum plus independent Gaussian noise at every grid sample
    (per nm) with `σ = mean(S over 380-780 nm) / snr`, the same σ at every
    wavelength (a detector's additive noise does not follow the peaks), so
    `snr` is the signal-to-noise ratio of the mean visible level. Values may
    go below 0, as a dark-subtracted measurement does. `seed`: NumPy
    generator seed. [same unit as `spectra`]"""
    s, w = _check(spectra, wavelength_nm)
    if not snr > 0:
        raise ValueError(f"snr {snr!r}: need a value > 0.")
    sigma = s[:, _visible(w)].mean(axis=1) / snr
    rng = np.random.default_rng(seed)
    return s + sigma[:, None] * rng.standard_normal(s.shape)


def degrade_resolution(
    spectra: Float[ArrayLike, "l w"],
    wavelength_nm: Float[ArrayLike, " w"],
    fwhm_nm: float,
) -> np.ndarray:
    """Each spectrum convolved with a Gaussian slit of `fwhm_nm` (sampled on
    the grid, `SLIT_TRUNCATE_SIGMAS`, unit sum). At the grid's ends the
    spectrum is mirrored about its last sample (`reflect`), which keeps the
    power over the whole grid exactly. The result's resolution is that of
    the measured spectrum combined with the slit (widths add in quadrature).
    [same unit as `spectra`]"""
    s, w = _check(spectra, wavelength_nm)
    if not fwhm_nm > 0:
        raise ValueError(f"fwhm_nm {fwhm_nm!r}: need a value > 0.")
    sigma = fwhm_nm / FWHM_PER_SIGMA / GRID_STEP_NM
    half = int(np.ceil(SLIT_TRUNCATE_SIGMAS * sigma))
    if half >= w.size:
        raise ValueError(f"fwhm_nm {fwhm_nm!r}: the slit is wider than the grid.")
    x = np.arange(-half, half + 1, dtype=float)
    kernel = np.exp(-0.5 * (x / sigma) ** 2)
    kernel /= kernel.sum()
    padded = np.pad(s, ((0, 0), (half, half)), mode="symmetric")
    return np.stack([np.convolve(row, kernel, mode="valid") for row in padded])


def shift_wavelength(
    spectra: Float[ArrayLike, "l w"],
    wavelength_nm: Float[ArrayLike, " w"],
    shift_nm: float,
) -> np.ndarray:
    """Each spectrum moved by `shift_nm` along the wavelength axis,
    `S'(λ) = S(λ - shift_nm)` by linear interpolation (a line at λ₀ appears at
    λ₀ + shift_nm); where `λ - shift_nm` leaves the grid the nearest end
    sample is held. [same unit as `spectra`]"""
    s, w = _check(spectra, wavelength_nm)
    if not np.isfinite(shift_nm):
        raise ValueError(f"shift_nm {shift_nm!r}: need a finite value.")
    return np.stack([np.interp(w - shift_nm, w, row) for row in s])


Extension = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""An extension rule: `(wavelength_nm (k,), values (k,))` of a spectrum
measured up to some wavelength -> its values on the full grid `(w,)`."""


def truncate_and_extend(
    spectra: Float[ArrayLike, "l w"],
    wavelength_nm: Float[ArrayLike, " w"],
    cut_nm: float,
    extend: Extension,
) -> np.ndarray:
    """Each spectrum as if measured only up to `cut_nm` (inclusive) and
    extended beyond it by `extend` (`Extension`; e.g. the product's own
    extension of a user's spectrum): the samples up to the cut are kept
    exactly, those beyond are `extend`'s. `cut_nm` must leave the visible
    range measured. [same unit as `spectra`]"""
    s, w = _check(spectra, wavelength_nm)
    if not VISIBLE_END_NM <= cut_nm < w[-1]:
        raise ValueError(
            f"cut_nm {cut_nm!r}: need {VISIBLE_END_NM} <= cut_nm < {w[-1]:g} nm."
        )
    keep = w <= cut_nm + GRID_TOLERANCE_NM
    out = s.copy()
    for i, row in enumerate(s):
        ext = np.asarray(extend(w[keep], row[keep]), float)
        if ext.shape != w.shape or not np.all(np.isfinite(ext[~keep])):
            raise ValueError(
                f"extend: returned shape {ext.shape} or non-finite values; need "
                f"finite values on the grid {w.shape}."
            )
        out[i, ~keep] = ext[~keep]
    return out


def mix_lamps(
    spectra: Float[ArrayLike, "l w"],
    others: Float[ArrayLike, "l w"],
    wavelength_nm: Float[ArrayLike, " w"],
    share: float,
) -> np.ndarray:
    """Each spectrum with the light of the matching row of `others` in the
    same pixel: `Φ · [(1 - share) S / Φ_S + share O / Φ_O]`, `Φ` luminous
    flux (`luminous_flux_lm`), so `others` give exactly `share` of the
    result's luminous flux and the total flux is the spectrum's own.
    [same unit as `spectra`]"""
    s, w = _check(spectra, wavelength_nm)
    o, _ = _check(others, wavelength_nm)
    if o.shape != s.shape:
        raise ValueError(f"others: need shape {s.shape}, got {o.shape}.")
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"share {share!r}: need a value in [0, 1].")
    fs, fo = luminous_flux_lm(s, w), luminous_flux_lm(o, w)
    if np.any(fs <= 0) or np.any(fo <= 0):
        raise ValueError("spectra and others: need a luminous flux > 0.")
    return fs[:, None] * ((1.0 - share) * s / fs[:, None] + share * o / fo[:, None])
