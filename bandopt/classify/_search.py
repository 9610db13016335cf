"""Band selection for classification: nlopt derivative-free global search of
the real cross-validated macro F1, and a differentiable soft-nearest-neighbour
surrogate minimised with optimistix.

Macro F1 of a KNN is piecewise constant in the band parameters (no useful
gradient), so:

(a) **nlopt** (`Johnson2007`) derivative-free global methods (`"crs2"`:
    GN_CRS2_LM, `Kaelo2006`; `"direct"`: GN_DIRECT_L, `Gablonsky2001`) on the
    unit box of centres and FWHMs, through the project's one JAX <-> nlopt
    adapter (`bandopt.search._global.global_search`): seeded, budgeted by
    objective evaluations. Objective: minus the inner-fold macro F1 of the
    KNN (best k of `K_GRID`), on photon-noisy radiance with common random
    numbers, so it is deterministic.
(b) **Soft nearest neighbours** (NCA-style, `Goldberger2004`): for a
    validation scene i, `p(c | i) = Σ_{j∈c} exp(-d_ij²/τ) / Σ_j exp(-d_ij²/τ)`
    over training scenes j (features as for the KNN), loss = class-balanced
    mean of `-log p(true class)` over the inner splits. Smooth in the band
    parameters (gradients through the slit functions, the photon model and
    the features); minimised by `optimistix.BFGS` with `max_steps` as the
    evaluation budget (`throw=False`, the outcome recorded).

Both are judged by the real F1 on the outer folds (`evaluate_band_set`).
The box is the band search's: centres and FWHMs with supports inside
380-900 nm, FWHM 15-200 nm, super-Gaussian k = 6, no panchromatic band.
"""

import dataclasses
import time
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from ..forward import ScenarioTable, radiance_from_response
from ..knn import K_GRID, features, macro_f1_int, neighbour_labels, vote_proba
from ..names import validate_method
from ..search import Space, global_search
from ..sensor import BandSet, SensorParams, slit_super_gaussian
from ._scores import class_order


@dataclasses.dataclass(frozen=True)
class SearchBox:
    """`n_bands` free bands, no panchromatic band: the search box of
    `bandopt.search.Space` with `pan="none"` (supports in [lower_nm,
    upper_nm], FWHM in [min_fwhm_nm, max_fwhm_nm], fixed shape exponent, unit
    box `u = (centre part (n), FWHM part (n))`), plus the responses, band set
    and start point the classification search needs, all as functions of the
    unit-box point `u`. [nm]"""

    n_bands: int
    lower_nm: float = 380.0
    upper_nm: float = 900.0
    min_fwhm_nm: float = 15.0
    max_fwhm_nm: float = 200.0
    shape_k: float = 6.0

    @property
    def space(self) -> Space:
        """The same box as a band-search `Space` (validates the bounds)."""
        return Space(
            self.n_bands,
            pan="none",
            lower_nm=self.lower_nm,
            upper_nm=self.upper_nm,
            min_fwhm_nm=self.min_fwhm_nm,
            max_fwhm_nm=self.max_fwhm_nm,
            shape_k=self.shape_k,
        )

    def __post_init__(self):
        self.space  # noqa: B018  (validation of the bounds)

    @property
    def dim(self) -> int:
        return self.space.dim

    def physical(self, u):
        """Unit box -> (centre_nm, fwhm_nm). [nm]"""
        return self.space.physical(u)

    def unit(self, centre_nm, fwhm_nm) -> np.ndarray:
        """Inverse of `physical` (clipped to the box)."""
        return self.space.unit(centre_nm, fwhm_nm)

    def response(self, u, wavelength_nm):
        c, f = self.physical(u)
        return slit_super_gaussian(
            jnp.asarray(wavelength_nm), c, f, jnp.full_like(c, self.shape_k)
        )

    def band_set(self, u, name: str = "classification") -> BandSet:
        c, f = (np.asarray(a, float) for a in self.physical(u))
        order = np.argsort(c)
        return BandSet.from_physical(
            c[order],
            f[order],
            self.shape_k,
            name=name,
            names=[f"C{i + 1}" for i in range(self.n_bands)],
            lower_nm=self.lower_nm - 1e-6,
            upper_nm=self.upper_nm + 1e-6,
            min_fwhm_nm=self.min_fwhm_nm - 1e-6,
        )

    def even_start(self) -> np.ndarray:
        """Evenly spaced 40 nm bands over 420-860 nm, as a unit-box point."""
        n = self.n_bands
        c = np.linspace(420.0, 860.0, n) if n > 1 else np.array([640.0])
        return np.clip(self.unit(c, np.full(n, 40.0)), 1e-3, 1 - 1e-3)


@dataclasses.dataclass(frozen=True)
class SearchData:
    """Rows of the scenes used in a search and their inner splits.

    `toa (n, w)`, `y (n,)` integer classes, `lamp (n,)`, `splits`:
    (train row indices, validation row indices) pairs; `noise_z (n, n_bands)`
    or None; `params` the sensor."""

    toa: np.ndarray
    wavelength_nm: np.ndarray
    y: np.ndarray
    lamp: np.ndarray
    n_classes: int
    splits: tuple[tuple[np.ndarray, np.ndarray], ...]
    noise_z: np.ndarray | None
    params: SensorParams | None
    kind: str = "log_ratio"


def search_data(
    table: ScenarioTable,
    level: str,
    lamp_splits,
    *,
    n_bands: int,
    noise: bool = True,
    seed: int = 0,
    params: SensorParams | None = None,
    kind: str = "log_ratio",
) -> SearchData:
    """Search rows: the lamps of `lamp_splits` ((train lamps, validation lamps)
    pairs, lamp indices of `table`)."""
    lamps = np.unique(np.concatenate([np.concatenate(s) for s in lamp_splits]))
    rows = np.flatnonzero(table.rows_of_lamps(lamps))
    classes = class_order(level, table.lamp_classes(level))
    cidx = {c: i for i, c in enumerate(classes)}
    y = np.asarray([cidx[c] for c in table.labels(level)[rows]])
    lamp = table.lamp[rows]
    splits = tuple(
        (np.flatnonzero(np.isin(lamp, tr)), np.flatnonzero(np.isin(lamp, va)))
        for tr, va in lamp_splits
    )
    z = table.noise_z(n_bands, seed)[rows] if noise else None
    return SearchData(
        table.toa[rows],
        table.wavelength_nm,
        y,
        lamp,
        len(classes),
        splits,
        z,
        SensorParams() if params is None else params,
        kind,
    )


def _features_for(data: SearchData, response):
    z = None if data.noise_z is None else jnp.asarray(data.noise_z)
    rad = radiance_from_response(
        jnp.asarray(data.toa), jnp.asarray(data.wavelength_nm), response, z, data.params
    )
    return features(rad, data.kind)


def cv_macro_f1(
    data: SearchData, response, k_grid: Sequence[int] | np.ndarray = K_GRID
) -> float:
    """Inner-split mean macro F1 of the KNN for band responses `(b, w)`, best k."""
    x = np.asarray(_features_for(data, jnp.asarray(response)))
    total = np.zeros(len(k_grid))
    for tr, va in data.splits:
        nbr = neighbour_labels(x[tr], data.y[tr], x[va], max(k_grid))
        present = np.unique(data.y[va])
        for i, k in enumerate(k_grid):
            pred = np.argmax(vote_proba(nbr, k, data.n_classes), axis=1)
            total[i] += macro_f1_int(data.y[va], pred, present)
    return float(np.max(total) / len(data.splits))


def nlopt_search(
    data: SearchData,
    box: SearchBox,
    *,
    algorithm: str = "crs2",
    max_evals: int = 200,
    seed: int = 0,
) -> dict:
    """Maximise `cv_macro_f1` over the box with an nlopt derivative-free
    global method. Returns the best point, its unit-box `u`, inner macro F1,
    evaluations, status and the improvement trace."""
    algorithm = validate_method(
        algorithm, ("crs2", "direct"), "derivative-free algorithm"
    )
    w = np.asarray(data.wavelength_nm)

    def value(u):
        return -cv_macro_f1(data, box.response(u, w))

    def no_gradient(u):  # derivative-free algorithms never ask for a gradient
        raise RuntimeError("macro F1 has no gradient")

    res = global_search(
        value, no_gradient, box.dim, algorithm=algorithm, max_evals=max_evals, seed=seed
    )
    c, f = (np.asarray(a, float).tolist() for a in box.physical(np.asarray(res.x)))
    return {
        "method": f"nlopt-{res.algorithm}",
        "u": res.x,
        "centre_nm": c,
        "fwhm_nm": f,
        "inner_macro_f1": -res.loss,
        "n_evals": res.n_evals,
        "status": res.status,
        "wall_s": res.wall_s,
        "seed": seed,
        "trace": [(i, -v) for i, v in res.trace],
    }


# ------------------------------------------------------------------------------
# Differentiable surrogate

SOFT_TEMPERATURE = 1.0
"""τ of the soft nearest neighbours, in squared feature units (a log-ratio
distance of 1 weighs e⁻¹ of a copy). Chosen from 0.05, 0.2, 1 on one inner
split of outer fold 0 (inner macro F1 0.55, 0.58, 0.72 after 40 steps). [1]"""


def soft_nn_loss(
    raw: jax.Array,
    data: SearchData,
    box: SearchBox,
    temperature: float = SOFT_TEMPERATURE,
) -> jax.Array:
    """Class-balanced soft-nearest-neighbour cross-entropy over the inner
    splits, as a function of unconstrained band parameters `raw (2n,)`
    (`u = sigmoid(raw)`). [1]"""
    u = jax.nn.sigmoid(raw)
    x = _features_for(data, box.response(u, data.wavelength_nm))
    onehot = jax.nn.one_hot(jnp.asarray(data.y), data.n_classes, dtype=x.dtype)
    total = 0.0
    for tr, va in data.splits:
        xt, xv = x[tr], x[va]
        d2 = (
            jnp.sum(xv**2, 1)[:, None]
            + jnp.sum(xt**2, 1)[None, :]
            - 2.0 * jnp.matmul(xv, xt.T, precision="highest")
        )
        logits = -jnp.maximum(d2, 0.0) / temperature
        norm = jax.nn.logsumexp(logits, axis=1)
        own = onehot[va] @ onehot[tr].T  # (v, t): same class
        log_p = jax.nn.logsumexp(logits, axis=1, b=own) - norm
        yv = onehot[va]
        per_class = jnp.sum(yv * (-log_p)[:, None], 0) / jnp.maximum(
            jnp.sum(yv, 0), 1.0
        )
        present = jnp.sum(yv, 0) > 0
        total = total + jnp.sum(jnp.where(present, per_class, 0.0)) / jnp.sum(present)
    return total / len(data.splits)


def surrogate_search(
    data: SearchData,
    box: SearchBox,
    *,
    max_steps: int = 40,
    start: np.ndarray | None = None,
    temperature: float = SOFT_TEMPERATURE,
) -> dict:
    """Minimise `soft_nn_loss` with `optimistix.BFGS` from `start` (unit box;
    default `box.even_start()`), at most `max_steps` steps (one loss and
    gradient each). The result's inner macro F1 is the real KNN score."""
    u0 = (
        box.even_start()
        if start is None
        else np.clip(np.asarray(start, float), 1e-3, 1 - 1e-3)
    )
    raw0 = jnp.asarray(np.log(u0) - np.log1p(-u0))

    @eqx.filter_jit
    def fn(raw, _):
        return soft_nn_loss(raw, data, box, temperature)

    t0 = time.perf_counter()
    loss0 = float(fn(raw0, None))
    sol = optx.minimise(
        fn, optx.BFGS(rtol=1e-6, atol=1e-6), raw0, max_steps=max_steps, throw=False
    )
    u = np.asarray(jax.nn.sigmoid(sol.value))
    loss = float(fn(sol.value, None))
    c, f = (np.asarray(a, float).tolist() for a in box.physical(u))
    n_steps = int(sol.stats["num_steps"])
    if n_steps >= max_steps:
        result = "max_steps_reached (budget used; not converged)"
    elif sol.result == optx.RESULTS.successful:
        result = "successful"
    else:
        result = "failed: " + str(optx.RESULTS[sol.result])[:120]
    return {
        "method": "surrogate-softnn-bfgs",
        "u": u.tolist(),
        "centre_nm": c,
        "fwhm_nm": f,
        "loss_start": loss0,
        "loss": loss,
        "inner_macro_f1": cv_macro_f1(data, box.response(u, data.wavelength_nm)),
        "n_steps": n_steps,
        "max_steps": max_steps,
        "status": result,
        "wall_s": time.perf_counter() - t0,
        "temperature": temperature,
    }
