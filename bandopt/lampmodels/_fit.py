"""Fitting one model family to one measured spectrum: the sampling step of a
spectrum interpolated onto the library grid (`native_step_nm`), the
instrument operator that shows the model as that spectrum was sampled
(`sampling_matrix`), and `fit`, Levenberg-Marquardt from `N_STARTS` starts with
a small pull towards the default (`RIDGE`). Apart from the calibration because
it works on any spectrum, not only the library's."""

import dataclasses
import functools
import itertools

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from ..datasets import nir as nir_mod
from ._families import FAMILIES, Family, spectrum, to_values, visible_normalised


NIR_MEASURED_NM = 830.0
"""A lamp constrains the near-infrared parameters when measured this far. [nm]"""
RIDGE = 1e-3
"""Weight of the pull of z towards the default start in every fit. [1]"""
N_STARTS = 4
MAX_STEPS = 300


# --------------------------------------------------------------------------------------
# Fitting


def native_step_nm(wavelength_nm: np.ndarray, values: np.ndarray, end_nm: float) -> int:
    """Sampling step of a spectrum that was linearly interpolated onto a 1 nm grid:
    the largest of 10, 5, 2 nm (knots at 380 + k·step) on which it is exactly
    piecewise linear over 380-`end_nm`; 1 otherwise. [nm]"""
    m = (wavelength_nm >= 380.0) & (wavelength_nm <= end_nm)
    w, v = wavelength_nm[m], values[m]
    if np.any(np.abs(np.diff(w) - 1.0) > 1e-9):
        return 1
    d2 = np.abs(np.diff(v, 2))
    scale = np.max(np.abs(v)) + 1e-300
    for step in (10, 5, 2):
        interior = (np.round(w[1:-1] - 380.0) % step) != 0
        if np.all(d2[interior] < 1e-9 * scale):
            return step
    return 1


def sampling_matrix(
    wavelength_nm: np.ndarray, step_nm: int, end_nm: float
) -> np.ndarray:
    """Instrument operator `P` for a spectrum sampled every `step_nm` from 380 nm
    to `end_nm` and linearly interpolated onto the 1 nm grid: `P @ s` is `s`
    seen through a triangular bandpass of FWHM `step_nm` at each knot (the usual
    bandwidth of a scanning spectroradiometer reporting at that step; the
    triangles sum to one, so line power is kept), then interpolated linearly
    between knots. Identity for `step_nm` 1 and beyond `end_nm`."""
    w = np.asarray(wavelength_nm, float)
    n = w.size
    if step_nm == 1:
        return np.eye(n)
    if np.any(np.abs(np.diff(w) - 1.0) > 1e-9):
        raise ValueError("sampling_matrix needs a 1 nm grid.")
    knots = np.searchsorted(w, np.arange(380.0, end_nm + 1e-9, step_nm))
    bandpass = np.maximum(0.0, 1.0 - np.abs(w[knots][:, None] - w[None, :]) / step_nm)
    bandpass /= bandpass.sum(axis=1, keepdims=True)
    p = np.eye(n)
    for j, (a, b) in enumerate(itertools.pairwise(knots)):
        t = (w[a : b + 1] - w[a]) / (w[b] - w[a])
        p[a : b + 1] = (1 - t)[:, None] * bandpass[j] + t[:, None] * bandpass[j + 1]
    return p


@dataclasses.dataclass(frozen=True)
class Fit:
    """A fitted lamp: unconstrained `z`, physical `values`, the model spectrum
    (unit visible power, on the library grid, as the instrument would sample it:
    `fitted`), the pure model `model`, the fit range mask, normalised RMS
    (RMS residual / mean measured value over the fit range), whether the NIR
    parameters were constrained, and the solver outcome of the best start."""

    family: str
    z: np.ndarray
    values: dict
    fitted: np.ndarray
    model: np.ndarray
    mask: np.ndarray
    nrms: float
    nir_constrained: bool
    step_nm: int
    converged: bool


@functools.cache
def _solver(family_name: str, n: int, m: int):
    family = FAMILIES[family_name]
    z_ref = jnp.asarray(family.z_init())

    def residual(z, args):
        w, y, mask, p, scale, free = args
        m = p @ spectrum(family, z, w)
        r = jnp.where(mask, m - y, 0.0) * scale
        return r, jnp.sqrt(RIDGE) * (z - z_ref) * jnp.where(free, 1.0, 10.0)

    solver = optx.LevenbergMarquardt(rtol=1e-8, atol=1e-10)

    def one(z0, args):
        sol = optx.least_squares(
            residual, solver, z0, args=args, max_steps=MAX_STEPS, throw=False
        )
        r, reg = residual(sol.value, args)
        return (
            sol.value,
            jnp.sum(r**2) + jnp.sum(reg**2),
            sol.result == optx.RESULTS.successful,
        )

    return jax.jit(jax.vmap(one, in_axes=(0, None)))


def _starts(family: Family, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    z0 = family.z_init()
    pert = rng.normal(0.0, 1.0, (N_STARTS - 1, z0.size))
    return np.vstack([z0, z0 + pert])


def fit(
    family: Family | str,
    wavelength_nm: np.ndarray,
    values: np.ndarray,
    *,
    measured_end_nm: float | None = None,
    step_nm: int | None = None,
    seed: int = 0,
) -> Fit:
    """Fit a model family to one spectrum (any units; only its shape matters).

    Fitted over 380 nm to `measured_end_nm` (default: the last finite sample).
    `step_nm`: the spectrum's original sampling (default: detected by
    `native_step_nm`); the model is compared after the same sampling.
    """
    family = FAMILIES[family] if isinstance(family, str) else family
    w = np.asarray(wavelength_nm, float)
    v = np.asarray(values, float)
    if w.ndim != 1 or v.shape != w.shape:
        raise ValueError("fit: `values` must be one spectrum on `wavelength_nm`.")
    finite = np.isfinite(v)
    if measured_end_nm is None:
        measured_end_nm = float(w[finite][-1])
    mask = (w >= 380.0) & (w <= measured_end_nm) & finite
    vis = mask & (w <= 780.0)
    # a library spectrum cut where its data stop being evidence (down to
    # nir.CUT_MIN_NM) is fitted over what is measured
    span = (w >= 380.0) & (w <= min(measured_end_nm, 780.0))
    if measured_end_nm < nir_mod.CUT_MIN_NM or vis.sum() < 0.9 * span.sum():
        raise ValueError(
            "fit: the spectrum must be measured and finite from 380 nm to at least "
            f"{nir_mod.CUT_MIN_NM:g} nm."
        )
    y = visible_normalised(w, np.where(finite, v, 0.0))
    if step_nm is None:
        step_nm = native_step_nm(w, y, min(measured_end_nm, 780.0))
    end_vis = min(measured_end_nm, 780.0)
    p = sampling_matrix(w, step_nm, end_vis)
    scale = 1.0 / np.mean(y[vis])
    nir = measured_end_nm >= NIR_MEASURED_NM
    free = ~family.nir_mask | nir
    # Observations: the instrument's own samples (the knots of a coarser
    # sampling, where the interpolated value is the measured one; every 1 nm
    # sample elsewhere), padded with empty rows to a multiple of 64 so that a
    # few compiled solvers serve every lamp.
    knot = (np.round(w - 380.0) % step_nm == 0) | (w > end_vis)
    rows = np.flatnonzero(mask & knot)
    m = 64 * -(-rows.size // 64)
    obs = np.zeros((m, w.size))
    obs[: rows.size] = p[rows]
    y_obs = np.zeros(m)
    y_obs[: rows.size] = y[rows]
    ok_obs = np.arange(m) < rows.size
    args = tuple(map(jnp.asarray, (w, y_obs, ok_obs, obs, scale, free)))
    zs, losses, ok = _solver(family.name, w.size, m)(
        jnp.asarray(_starts(family, seed)), args
    )
    best = int(np.nanargmin(np.asarray(losses)))
    z = np.asarray(zs[best])
    model = np.asarray(spectrum(family, z, w))
    fitted = p @ model
    res = np.where(mask, fitted - y, 0.0)
    nrms = float(np.sqrt(np.sum(res**2) / mask.sum()) / np.mean(y[mask]))
    vals = dict(
        zip(family.names, np.asarray(to_values(family, z)).tolist(), strict=True)
    )
    return Fit(
        family.name,
        z,
        vals,
        fitted,
        model,
        mask,
        nrms,
        bool(nir),
        int(step_nm),
        bool(ok[best]),
    )
