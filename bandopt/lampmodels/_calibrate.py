"""Calibration of a class's model on its measured library lamps and sampling
from it: `Calibration` (a Gaussian in z, its near-infrared block apart),
`calibrate_fits`, `calibrate`, `log_prior`, `model_spectra` and
`sample_library`, which returns modelled lamps as a `LampLibrary` for
training only. The one part that reads the library. The inversion calls
`bandopt.lampmodels.calibrate` (where tests patch it) and hands the result to
`sample_library`; `sample_library` without `calibrations` calls this module's
`calibrate`."""

import dataclasses
import functools
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..datasets import nir as nir_mod
from ..datasets.lamps import LEVEL2_PARENT, LampLibrary, LampRecord, library
from ._families import FAMILIES, Family, family_of, per_lumen, spectrum
from ._fit import Fit, fit


SHRINKAGE = 0.5
"""Calibration covariance: (1 - s) sample covariance + s its diagonal. [1]"""
Z_CLIP = 6.0
"""Fitted z are clipped to ±6 (sigmoid 0.25 % from a bound) before calibration."""


# --------------------------------------------------------------------------------------
# Calibration and sampling


@dataclasses.dataclass(frozen=True)
class Calibration:
    """Distribution of fitted parameters of one class: Gaussian in z.

    `lamps`: ids calibrated on; `mean`, `cov` in z (NIR block independent of the
    rest, from `nir_lamps` only; zero when none); `model_end_nm`: the longest
    measured wavelength among the lamps (samples stop there); `z_lamps`: the
    clipped fitted z per lamp.
    """

    level2: str
    family: str
    lamps: tuple[str, ...]
    nir_lamps: tuple[str, ...]
    mean: np.ndarray
    cov: np.ndarray
    model_end_nm: float
    z_lamps: np.ndarray


def _shrunk_cov(z: np.ndarray) -> np.ndarray:
    k = z.shape[1]
    if z.shape[0] < 2:
        return np.zeros((k, k))
    s = np.cov(z, rowvar=False, ddof=1)
    return (1 - SHRINKAGE) * s + SHRINKAGE * np.diag(np.diag(s))


def calibrate_fits(
    level2: str, fits: dict[str, Fit], measured_end_nm: dict[str, float]
) -> Calibration:
    """Calibration of `level2` from fits of its measured lamps (id -> Fit)."""
    family = family_of(level2)
    if not fits:
        raise ValueError(
            f"Class {level2!r} has no measured lamp to calibrate its model on."
        )
    ids = tuple(sorted(fits))
    z = np.clip(np.array([fits[i].z for i in ids]), -Z_CLIP, Z_CLIP)
    nmask = family.nir_mask
    nir_ids = tuple(i for i in ids if fits[i].nir_constrained)
    mean = z.mean(axis=0)
    cov = np.zeros((z.shape[1], z.shape[1]))
    vis_idx = np.flatnonzero(~nmask)
    cov[np.ix_(vis_idx, vis_idx)] = _shrunk_cov(z[:, vis_idx])
    if nmask.any() and nir_ids:
        zn = np.array([z[ids.index(i)] for i in nir_ids])[:, nmask]
        idx = np.flatnonzero(nmask)
        mean[idx] = zn.mean(axis=0)
        cov[np.ix_(idx, idx)] = _shrunk_cov(zn)
    end = max(measured_end_nm[i] for i in ids)
    return Calibration(level2, family.name, ids, nir_ids, mean, cov, end, z)


def sample_z(cal: Calibration, n: int, seed: int) -> np.ndarray:
    """`n` parameter vectors from the calibrated Gaussian (seeded)."""
    rng = np.random.default_rng(seed)
    return rng.multivariate_normal(cal.mean, cal.cov, size=n, method="eigh")


def log_prior(cal: Calibration, z: Float[ArrayLike, " k"]) -> Float[Array, ""]:
    """Gaussian log-density (up to a constant) of `z` under the calibration, for
    the inversion's prior; directions without spread get a unit-variance
    fallback (the covariance plus the identity times 1e-6 of its trace)."""
    cov = cal.cov + np.eye(cal.cov.shape[0]) * max(1e-6 * np.trace(cal.cov), 1e-9)
    prec = jnp.asarray(np.linalg.inv(cov))
    d = jnp.asarray(z) - jnp.asarray(cal.mean)
    return -0.5 * d @ prec @ d


def model_spectra(
    family: Family | str, z: Float[ArrayLike, "l k"], wavelength_nm: np.ndarray
) -> np.ndarray:
    """Model spectra (unit visible power) for a batch of z. [nm⁻¹]"""
    family = FAMILIES[family] if isinstance(family, str) else family
    return np.asarray(
        _batch_spectrum(family)(jnp.asarray(z), jnp.asarray(wavelength_nm))
    )


@functools.cache
def _batch_spectrum(family: Family):
    """`spectrum` vmapped over z and jitted, once per family (a fold's
    sampling calls it per class and fit)."""
    return jax.jit(jax.vmap(lambda zz, w: spectrum(family, zz, w), in_axes=(0, None)))


# --------------------------------------------------------------------------------------
# Library interface


def _measured(lib, classes):
    return [
        (i, r)
        for i, r in enumerate(lib.records)
        if not r.modelled and r.excluded is None and r.level2 in classes
    ]


@functools.cache
def _fit_library_lamp(lamp_id: str) -> tuple[Fit, float]:
    lib = library()
    i = lib.index(lamp_id)
    r = lib.records[i]
    end = min(r.measured_range_nm[1], float(lib.wavelength_nm[-1]))
    return fit(
        family_of(r.level2), lib.wavelength_nm, lib.values[i], measured_end_nm=end
    ), end


def fit_library_lamp(lamp_id: str) -> Fit:
    """Fit (cached per process) the model of its class to a measured library lamp,
    over its measured range only."""
    return _fit_library_lamp(lamp_id)[0]


def calibrate(level2: str, train_lamps: Sequence[str] | None = None) -> Calibration:
    """Calibrate the model of `level2` on its measured lamps among `train_lamps`
    (default: every measured, non-excluded lamp of the class in `library()`)."""
    family_of(level2)
    lib = library()
    members = [r.id for _, r in _measured(lib, (level2,))]
    if train_lamps is not None:
        train = set(train_lamps)
        members = [m for m in members if m in train]
    fits, ends = {}, {}
    for m in members:
        fits[m], ends[m] = _fit_library_lamp(m)
    return calibrate_fits(level2, fits, ends)


def sample_library(
    classes: Sequence[str],
    n_per_class: int,
    seed: int,
    *,
    train_lamps: Sequence[str] | None = None,
    extend_nir: bool = True,
    calibrations: dict[str, Calibration] | None = None,
):
    """Modelled lamps: `n_per_class` spectra per level-2 class, from the model
    calibrated ONLY on the measured lamps in `train_lamps` (default: all).

    Returns a `bandopt.datasets.lamps.LampLibrary` on the library's grid in its
    units (W nm⁻¹ lm⁻¹, one lumen), records `modelled=True`,
    `source="bandopt lamp model <class>"`, `source_set="bandopt_lampmodels"`.
    Beyond the longest measured wavelength of the calibration lamps the values
    are the library's NIR extension (`extended=True`) or NaN
    (`extend_nir=False`). For training only: never score on them.
    `calibrations` (level-2 class -> `Calibration`) skips the calibration of
    the classes it lists (e.g. calibrations made once per cross-validation
    fold).
    """
    if n_per_class < 1:
        raise ValueError(f"n_per_class must be >= 1 (got {n_per_class}).")
    lib = library()
    w = lib.wavelength_nm
    rows, records = [], []
    for k, level2 in enumerate(classes):
        family = family_of(level2)
        cal = (calibrations or {}).get(level2) or calibrate(level2, train_lamps)
        if cal.level2 != level2:
            raise ValueError(
                f"calibrations[{level2!r}] is a calibration of {cal.level2!r}."
            )
        z = sample_z(cal, n_per_class, seed + 7919 * k)
        spectra = np.array(model_spectra(family, z, w))  # writable: NIR filled below
        end = cal.model_end_nm
        beyond = w > end
        level1 = LEVEL2_PARENT[level2]
        validated = None
        if beyond.any():
            if extend_nir:
                tech = nir_mod.technology_of(level2, level1)
                inside = ~beyond
                for j in range(n_per_class):
                    spectra[j, beyond] = nir_mod.extend_spectrum(
                        w[inside], spectra[j, inside], tech, w[beyond]
                    )
                validated = nir_mod.VALIDATED.get(tech, False)
            else:
                spectra[:, beyond] = np.nan
        vis = (w >= 380.0) & (w <= 780.0)
        spectra = np.where(np.isfinite(spectra), spectra, np.nan)
        out = np.full_like(spectra, np.nan)
        out[:, :] = spectra
        out = per_lumen(w, np.where(vis | np.isfinite(out), out, np.nan))
        for j in range(n_per_class):
            rows.append(out[j])
            records.append(
                LampRecord(
                    id=f"model_{level2}_{seed}_{j:04d}",
                    name=f"{family.name} model sample {j} ({level2})",
                    level1=level1,
                    level2=level2,
                    source=f"bandopt lamp model {level2}",
                    source_set="bandopt_lampmodels",
                    unit="W nm-1 lm-1",
                    measured_range_nm=(float(w[0]), float(min(end, w[-1]))),
                    extended=bool(beyond.any() and extend_nir),
                    extension_validated=validated,
                    modelled=True,
                    cie_typical=False,
                    excluded=None,
                )
            )
    values = np.asarray(rows)
    values.setflags(write=False)
    return LampLibrary(w, values, tuple(records), (), ())
