"""The band-search problem: scenario spectra, lamp-grouped splits and one loss.

A `Problem` holds, for a SMALL search set of N lamp scenes, the top-of-atmosphere
spectral radiance of every scene `(N, w)` (built once from the factorised scene
model, `scenario_spectra`), the per-scene truth and the class-balanced
(train, validation) weights of lamp-grouped splits. Band radiance for a band
set is then one dense matmul `toa @ weightsᵀ` (measured faster than the
factorised contraction for these sizes, see `results/bench/search.json`).

The loss of a band set is the cross-validated ridge loss of `bandopt.estimate`
(variable projection: the ridge weights are solved in closed form inside it),
so centres and FWHMs are the only free variables. With several metrics
(target `all`) each metric's squared error is divided by its class-balanced
variance over the search lamps ("spread", stated in every output), i.e. the
joint loss is the sum of the three normalised MSEs.

Parametrisations of the free bands (shape k fixed, 6 by default):

- unit box `u ∈ [0, 1]^{2n}` for nlopt: `fwhm = min + (max - min)·u_f`,
  `centre = lower + fwhm/2 + (span - fwhm)·u_c` (supports stay inside
  `[lower_nm, upper_nm]`);
- `BandSet` raw leaves (sigmoids, bounds built in) for optimistix.
"""

import dataclasses
import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..estimate import (
    SEARCH_LAMBDA,
    LampTable,
    cv_residuals,
    log_ratio_features,
    metric_mask,
    resolve_target,
)
from ..forward import dense_spectra, noise_draws, radiance_from_response
from ..sensor import BandSet, SensorParams, slit_super_gaussian


PAN_EDGES_NM = (400.0, 880.0)
"""Default fixed panchromatic band: 50 % points 400 and 880 nm (k = 6, so its
support spans about the whole 380-900 nm data range). [nm]"""

PAN_MODES = ("none", "fixed", "free")


@dataclasses.dataclass(frozen=True)
class Space:
    """The search box of `n_bands` free bands (plus a panchromatic band).

    - `pan`: `"none"`, `"fixed"` (edges `pan_edges_nm`) or `"free"` (one more
      free band whose FWHM ranges from `max_fwhm_nm` to the whole span).
    - `lower_nm`, `upper_nm`: supports stay inside. [nm]
    - `min_fwhm_nm`, `max_fwhm_nm`: FWHM range of the free bands. [nm]
    - `shape_k`: fixed super-Gaussian exponent. [1]
    """

    n_bands: int
    pan: str = "fixed"
    pan_edges_nm: tuple[float, float] = PAN_EDGES_NM
    lower_nm: float = 380.0
    upper_nm: float = 900.0
    min_fwhm_nm: float = 15.0
    max_fwhm_nm: float = 200.0
    shape_k: float = 6.0

    def __post_init__(self):
        if self.pan not in PAN_MODES:
            raise ValueError(
                f"Unknown pan={self.pan!r}; expected one of {list(PAN_MODES)}."
            )
        if not (isinstance(self.n_bands, int) and self.n_bands >= 1):
            raise ValueError(f"n_bands must be an int >= 1, got {self.n_bands!r}.")
        if not 0 < self.min_fwhm_nm < self.max_fwhm_nm <= self.upper_nm - self.lower_nm:
            raise ValueError(
                "Need 0 < min_fwhm_nm < max_fwhm_nm <= upper_nm - lower_nm."
            )

    @property
    def n_free(self) -> int:
        """Free bands (the free pan counts)."""
        return self.n_bands + (self.pan == "free")

    @property
    def dim(self) -> int:
        return 2 * self.n_free

    @property
    def band_names(self) -> tuple[str, ...]:
        names = tuple(f"B{i + 1}" for i in range(self.n_bands))
        return (*names, "PAN") if self.pan != "none" else names

    def fwhm_range(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.full(self.n_free, self.min_fwhm_nm)
        hi = np.full(self.n_free, self.max_fwhm_nm)
        if self.pan == "free":
            lo[-1], hi[-1] = self.max_fwhm_nm, self.upper_nm - self.lower_nm - 1e-6
        return lo, hi

    def physical(self, u: Float[ArrayLike, " d"]) -> tuple[Array, Array]:
        """Unit box -> (centre_nm, fwhm_nm) of the free bands. [nm]"""
        u = jnp.asarray(u).reshape(2, self.n_free)
        lo, hi = self.fwhm_range()
        fwhm = lo + (hi - lo) * u[1]
        span = self.upper_nm - self.lower_nm
        centre = self.lower_nm + 0.5 * fwhm + (span - fwhm) * u[0]
        return centre, fwhm

    def unit(self, centre_nm, fwhm_nm) -> np.ndarray:
        """Inverse of `physical` (clipped to the box)."""
        c, f = np.asarray(centre_nm, float), np.asarray(fwhm_nm, float)
        lo, hi = self.fwhm_range()
        uf = (f - lo) / (hi - lo)
        span = self.upper_nm - self.lower_nm
        uc = (c - self.lower_nm - 0.5 * f) / np.maximum(span - f, 1e-12)
        return np.clip(np.concatenate([uc, uf]), 0.0, 1.0)

    def fixed_bands(self) -> BandSet | None:
        if self.pan != "fixed":
            return None
        return BandSet.from_edges(
            [self.pan_edges_nm],
            self.shape_k,
            names=["PAN"],
            lower_nm=self.lower_nm,
            upper_nm=self.upper_nm,
        )

    def band_set(self, centre_nm, fwhm_nm, name: str = "optimised") -> BandSet:
        """The full band set (free bands, then the pan band) as a `BandSet`."""
        c, f = list(np.asarray(centre_nm, float)), list(np.asarray(fwhm_nm, float))
        fixed = self.fixed_bands()
        if fixed is not None:
            c.append(float(fixed.centre_nm[0]))
            f.append(float(fixed.fwhm_nm[0]))
        # tiny margin: the unit box reaches the bounds exactly
        lo = self.lower_nm - 1e-6
        hi = self.upper_nm + 1e-6
        return BandSet.from_physical(
            c,
            f,
            self.shape_k,
            names=list(self.band_names),
            name=name,
            lower_nm=lo,
            upper_nm=hi,
            min_fwhm_nm=min(self.min_fwhm_nm, min(f)) - 1e-6,
        )

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


class Problem(eqx.Module):
    """Arrays of one band search (see module docstring).

    - `wavelength_nm` (w,), `toa` (N, w) [W m⁻² sr⁻¹ nm⁻¹]
    - `y`, `valid` (N, 3): truth in model space (mired), validity
    - `train_w`, `val_w` (S, N): class-balanced split weights
    - `spread` (3,): class-balanced SD of each metric (model space)
    - `metric_weight` (3,): 1 for scored metrics, 0 otherwise
    - `fixed_response` (f, w) or None: response of fixed (pan) bands
    - `noise_z` (N, b) or None: standard normal draws for photon noise
      (common random numbers: the loss stays deterministic)
    """

    wavelength_nm: Float[Array, " w"]
    toa: Float[Array, "n w"]
    y: Float[Array, "n 3"]
    valid: Array
    train_w: Float[Array, "s n"]
    val_w: Float[Array, "s n"]
    spread: Float[Array, " 3"]
    metric_weight: Float[Array, " 3"]
    fixed_response: Float[Array, "f w"] | None
    noise_z: Float[Array, "n b"] | None
    sensor: SensorParams | None
    shape_k: float = eqx.field(static=True, default=6.0)
    degree: int = eqx.field(static=True, default=1)
    lam: float = eqx.field(static=True, default=SEARCH_LAMBDA)

    # -- physics ---------------------------------------------------------------
    def response(self, centre_nm, fwhm_nm, shape_k=None) -> Float[Array, "b w"]:
        k = jnp.full_like(centre_nm, self.shape_k) if shape_k is None else shape_k
        r = slit_super_gaussian(self.wavelength_nm, centre_nm, fwhm_nm, k)
        if self.fixed_response is not None:
            r = jnp.concatenate([r, self.fixed_response], axis=0)
        return r

    def radiance_from_response(
        self, response: Float[Array, "b w"]
    ) -> Float[Array, "n b"]:
        """Band-averaged radiance of every scene (noisy if the problem has noise)."""
        return radiance_from_response(
            self.toa, self.wavelength_nm, response, self.noise_z, self.sensor
        )

    def radiance(self, centre_nm, fwhm_nm, shape_k=None) -> Float[Array, "n b"]:
        return self.radiance_from_response(self.response(centre_nm, fwhm_nm, shape_k))

    # -- losses ----------------------------------------------------------------
    def residuals(self, centre_nm, fwhm_nm, shape_k=None) -> Float[Array, " r"]:
        x = log_ratio_features(self.radiance(centre_nm, fwhm_nm, shape_k), self.degree)
        res = cv_residuals(
            x,
            self.y,
            self.valid,
            self.train_w,
            self.val_w,
            self.spread,
            self.metric_weight,
            self.lam,
        )
        return res.reshape(-1)

    def loss(self, centre_nm, fwhm_nm, shape_k=None) -> Float[Array, ""]:
        return jnp.sum(self.residuals(centre_nm, fwhm_nm, shape_k) ** 2)


def scenario_spectra(scen) -> np.ndarray:
    """TOA spectral radiance of every lamp scene, `(l, q, w)` with `q` the
    scenes per lamp (surface x atmosphere x Moon x class, C order):
    `bandopt.forward.dense_spectra` grouped by lamp; only for small search
    sets."""
    out = dense_spectra(scen)  # (l, s, a, m, c, w)
    return np.asarray(out).reshape(out.shape[0], -1, out.shape[-1])


NOISE_SCALE_NOTE = (
    "noise LEVEL: an EN 13201 class name (scenes lit to that class only) or a "
    "mean spectral radiance 400-900 nm [W m-2 sr-1 nm-1] every scene is scaled to; "
    "photon noise of the thesis Table 2.3 sensor (shot noise only), one seeded "
    "normal draw per scene and band (common random numbers)."
)


def make_problem(
    toa_lamp: np.ndarray,
    wavelength_nm: np.ndarray,
    table: LampTable,
    lamps: np.ndarray,
    splits,
    *,
    target: str,
    space: Space,
    degree: int = 1,
    lam: float = SEARCH_LAMBDA,
    noise_radiance: float | None = None,
    noise: bool = False,
    seed: int = 0,
    sensor: SensorParams | None = None,
    pad_to: int | None = None,
) -> Problem:
    """A `Problem` over the scenes of `lamps` (global lamp indices into `table`)
    with `splits` [(train, validation) lamp indices, also global].

    `toa_lamp` is `(l, q, w)` from `scenario_spectra`. Lamps outside `lamps`
    are dropped before anything is computed, so a held-out lamp cannot leak
    into the search. `noise`: photon noise (`sensor`, default Table 2.3);
    `noise_radiance` rescales every scene to that mean radiance first; the
    draws are `bandopt.forward.noise_draws(seed, ...)` over all scenes of
    `toa_lamp`, so a scene's draw does not depend on which lamps are used.
    `pad_to`: append zero-weight zero rows up to this many scenes, so problems
    of different folds share one compiled loss.
    """
    lamps = np.asarray(lamps, int)
    used = set(lamps.tolist())
    for tr, va in splits:
        if not (set(np.asarray(tr).tolist()) | set(np.asarray(va).tolist())) <= used:
            raise ValueError("splits use lamps outside `lamps`.")
        if set(np.asarray(tr).tolist()) & set(np.asarray(va).tolist()):
            raise ValueError("a split has a lamp on both sides.")
    q = toa_lamp.shape[1]
    toa = np.asarray(toa_lamp)[lamps].reshape(-1, toa_lamp.shape[-1])
    n_real = toa.shape[0]
    pad = 0 if pad_to is None else max(int(pad_to) - n_real, 0)
    if noise_radiance is not None:
        w = np.asarray(wavelength_nm)
        band = (w >= 400) & (w <= 900)
        toa = toa * (noise_radiance / toa[:, band].mean(axis=1))[:, None]
    remap = -np.ones(table.n_lamps, int)
    remap[lamps] = np.arange(lamps.size)
    sub = LampTable(
        np.repeat(np.arange(lamps.size), q),
        table.classes[lamps],
        table.truth[lamps],
        table.valid[lamps],
    )
    local_splits = [(remap[np.asarray(tr)], remap[np.asarray(va)]) for tr, va in splits]
    tr_w, va_w = sub.split_weights(local_splits)
    y, valid = sub.scenario_truth()
    if pad:  # zero rows with zero weight: one compiled shape for every fold
        toa = np.concatenate([toa, np.zeros((pad, toa.shape[1]))])
        tr_w, va_w = (np.pad(a, ((0, 0), (0, pad))) for a in (tr_w, va_w))
        y = np.pad(y, ((0, pad), (0, 0)))
        valid = np.pad(valid, ((0, pad), (0, 0)))
    spread = sub.spread()
    resolve_target(target)
    fixed = space.fixed_bands()
    wl = jnp.asarray(wavelength_nm, float)
    n_b = space.n_free + (fixed is not None)
    z = None
    if noise:
        # draws of every scene of toa_lamp, then the used lamps' rows: a scene
        # sees the same draw here as in every other caller with this seed
        n_l = toa_lamp.shape[0]
        z = noise_draws(seed, n_l * q, n_b).reshape(n_l, q, n_b)[lamps]
        z = jnp.pad(z.reshape(-1, n_b), ((0, pad), (0, 0)))
        sensor = SensorParams() if sensor is None else sensor
    return Problem(
        wavelength_nm=wl,
        toa=jnp.asarray(toa),
        y=jnp.asarray(y),
        valid=jnp.asarray(valid),
        train_w=jnp.asarray(tr_w),
        val_w=jnp.asarray(va_w),
        spread=jnp.asarray(spread),
        metric_weight=jnp.asarray(metric_mask(target), dtype=float),
        fixed_response=None if fixed is None else fixed.response(wl),
        noise_z=z,
        sensor=sensor if noise else None,
        shape_k=space.shape_k,
        degree=degree,
        lam=lam,
    )


def unit_loss(problem: Problem, space: Space):
    """`loss(u)` on the unit box (not jitted; see `jitted_losses`)."""

    def f(u):
        c, w = space.physical(u)
        return problem.loss(c, w)

    return f


def jitted_losses(problem: Problem, space: Space):
    """`(value, value_and_grad, batch_value)` on the unit box. Jitted once per
    `space` (the problem's arrays are arguments, not constants, so problems
    of the same shapes reuse the compilation)."""
    value, vg, batch = _compiled(space)
    return (
        lambda u: value(problem, u),
        lambda u: vg(problem, u),
        lambda us: batch(problem, us),
    )


@functools.lru_cache(maxsize=64)
def _compiled(space: Space):
    def f(p, u):
        c, w = space.physical(u)
        return p.loss(c, w)

    return (
        jax.jit(f),
        jax.jit(jax.value_and_grad(f, argnums=1)),
        jax.jit(jax.vmap(f, in_axes=(None, 0))),
    )
