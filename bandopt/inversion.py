"""Physics-based inversion: band radiances -> lamp spectrum, surface, metrics.

A pixel's band radiance is modelled as the forward model builds it
(`bandopt.scene`): lamp spectrum x surface reflectance x upward transmittance,
plus moonlight on the same surface and the Moon's path radiance,

    y_b = α Σ_λ W_bλ T_e(λ) ρ(λ) S(λ)/π + β Σ_λ W_bλ [T ρ M/π + P](λ),  α, β ≥ 0,

with `W` the band weights (`scene.band_weights`), `T` the upward transmittance,
`T_e = T_dir + k T_dif` the lamp light's transmittance in the scenes'
neighbourhood (`scene.Factors.emission_transmittance`; `T_e = T` for a uniform
neighbourhood), `S` a lamp spectrum per
lumen, `M`, `P` the Moon's ground irradiance and path radiance, `α` the
illuminance and `β` the Moon's brightness. Nothing is assumed about the
pixel's brightness: `α` and `β` are solved for in closed form.

**Priors (learned from training lamps and surfaces only).**
- Lamp: a class-balanced mixture over the training lamps (each level-2 class
  the same prior mass, each lamp the same within its class) — the sparse
  non-negative mixture of issue 12 in its one-component limit, so the posterior
  is a weighted set of real, measured spectra. Measured lamps of classes too
  small to be scored (e.g. low-pressure sodium) always belong to the prior:
  they are never scored, so they cannot leak. Optionally
  (`modelled_per_class > 0`, default 0: measured lamps only) the prior also
  holds modelled lamps of rare classes (`modelled_lamps`): spectra of the
  physical lamp models (`bandopt.lampmodels`) calibrated on that fit's
  measured training lamps only, labelled with their class, in the prior and
  the type posteriors but never scored. Optionally (`mixtures > 0`; the
  default of `bandopt evaluate`, estimator `inversion-moon-mix`) the prior
  also holds pairwise blends of two of its own lamps of one class
  (`mixture_lamps`): a new lamp usually lies between the library's lamps,
  and with the test lamp itself in the prior the error is ~0, so the
  prior's coverage of lamp space, not the scene, is what limits it.
- Surface: a low-rank basis (weighted PCA, each surface type the same weight)
  of the library reflectances (`bandopt.datasets.surfaces`), with candidate
  surfaces given by what is known (`SURFACE_MODES`): nothing (the mean of
  every road-scene surface type), the surface class (its mean and measured
  samples), or a daytime Sentinel-2 MSI measurement (`ESA2017`) with the
  L2A accuracy specification `σ = 0.05 ρ + 0.005` (`Doxani2018`) inverted to
  basis coefficients by regularised least squares.
- Atmosphere: the training atmospheres, equally likely.

**Estimates.** Each candidate (lamp, surface, atmosphere) is scored by its
weighted least-squares misfit χ² with the relative band error `σ_rel`
(chosen on inner folds); the posterior over lamps is `∝ prior · Σ exp(-χ²/2)`.
LER, G and CCT are posterior means of the candidates' metrics, computed from
their measured spectra with `bandopt.photometry` — physical by construction
(a convex combination of real lamps' values). CCT is averaged in mired over
lamps where a CCT is meaningful and is `None` when the posterior says the lamp
most likely has none (|Duv| > 0.05).

**Why no continuous refinement.** We also tried refining the three best
candidates per pixel with `optimistix.LevenbergMarquardt` (a smooth
multiplicative change of the lamp spectrum, `S_k exp(Σ c_j P_j)` with Legendre
`P_1..P_4` and a Gaussian prior, plus the surface coefficients). On the
'quick' preset's three outer folds (recommended bands) it raised the
class-balanced LER error from 14.3 / 16.5 / 15.4 to 20.3 / 20.6 / 15.4 lm/W and
the CCT error on every fold, at ~200x the run time: with a handful of bands the
data cannot tell a lamp's tilt from its surface's, so the extra freedom fits
noise. The discrete posterior is exact for its prior, fast and physical.

**Intervals and reject.** The 90 % interval is the posterior's 5-95 %
range widened by a split-conformal factor (`Romano2019`) calibrated on the
inner folds' held-out lamps (class-balanced), then clipped to the physical
range. A pixel whose best reduced χ² at the sharp band error `FLAG_NOISE`
exceeds the 95th percentile of the inner folds' held-out lamps (a conformal
test at a 5 % false-flag rate on lamps of known types) is flagged
`unexplained` (and its type is not guessed).

**Type probabilities and modelled near-infrared.** Optionally
(`calibrate_probabilities`) the level-1/-2 probabilities are tempered with a
temperature that grows with the pixel's misfit, fitted on held-out lamps of
the types the prior knows (`bandopt.calibration`); lamps of a type it lacks
are left to the `unexplained` flag, and both groups' calibration is
reported. Optionally (`nir_error`) every lamp
whose 780-900 nm part is modelled enters the prior with two copies at the
low and high end of that model's measured error (`nir_variants`), sharing its
prior mass. `bandopt.evaluator.InversionConfig` turns both on.
"""

import dataclasses
import functools
import itertools
import math
from collections.abc import Sequence
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import logsumexp

from . import lampmodels
from .calibration import (
    MISFIT_FLOOR,
    expected_calibration_error,
    fit_temperature,
    temper,
)
from .datasets import surfaces as surf_mod
from .datasets.lamps import LEVEL1, LEVEL2, LEVEL2_PARENT, library
from .datasets.nir import extension_error, is_single_band_emitter, technology_of
from .estimate import (
    CCT_RANGE_K,
    METRICS,
    MIRED,
    LampTable,
    fit_estimator,
    fit_kernel_estimator,
    lamp_truth,
)
from .folds import class_balanced_weights, stratified_lamp_folds
from .forward import band_weights_on as forward_band_weights, dense_spectra
from .names import validate_method
from .photometry import G_CAP, K_M_LM_PER_W, ler
from .scene import build_scenarios


SURFACE_MODES = ("unknown", "class", "measured")
"""What the estimator is told about the surface under the lamp."""

PRIOR_SURFACES = (
    "asphalt",
    "road",
    "parking_lot",
    "sidewalk",
    "driveway",
    "composition_shingle",
    "wood_shingle",
    "tile_roof",
    "metal_roof",
    "concrete_roof_tile",
    "soil",
    "sand",
    "grass",
)
"""Surface types a street light may shine on (water and snow left out: one
spectrum each and not road scenes)."""

SURFACE_RANK = 12
"""Basis size of the surface prior: reproduces the mean reflectance of every
road-scene type within 0.4 % (rank 6: 4.5 % for asphalt) over 380-900 nm."""

SIGMA_REL_GRID = (0.003, 0.01, 0.03, 0.1, 0.3)
"""Relative band-error candidates `σ_rel`, chosen on inner folds."""

SIGMA_FLOOR = 1e-3
"""Absolute band-error floor relative to the pixel's mean band radiance (the
default; `fit_inversion(floor_grid=)` chooses it on inner folds)."""

FLOOR_GRID = (1e-3, 3e-3, 1e-2, 3e-2)
"""Band-error floor candidates for `fit_inversion(floor_grid=)`: with
`σ_rel` they set how the bands are weighted, from nearly by relative error
(small floor) to nearly uniformly (a floor above `σ_rel`)."""

S2_SIGMA = (0.05, 0.005)
"""Sentinel-2 L2A surface reflectance accuracy `σ = a ρ + b` (`Doxani2018`)."""

S2_MIN_INSIDE = 0.95
"""Least fraction of a Sentinel-2 band's response inside the grid to use it."""

S2_FILE = Path(__file__).parent / "sensor" / "data" / "sentinel2a_msi_srf.csv"

COVERAGE = 0.9
"""Nominal coverage of the intervals."""

UNEXPLAINED_QUANTILE = 0.95
"""Known-lamp quantile of the reduced χ² (at `FLAG_NOISE`) above which a pixel
is unexplained: a split-conformal novelty test (`Vovk2005`) whose false-flag
rate on held-out lamps of known types is 1 - 0.95. The inner folds' priors
lack a fold's lamps, so their misfits run higher than the final prior's and
the rate on new lamps of known types is at most that. The usual 5 % level of
a test; not chosen on any score. At 0.99 the flag never fired on types left
out of the prior (robustness suite, cc13a9a)."""

FLAG_NOISE = (0.003, 1e-3)
"""Band error (`σ_rel`, floor) of the misfit that decides `unexplained`: the
sharpest of `SIGMA_REL_GRID` with `SIGMA_FLOOR`, whatever band error the
estimates use. With a relative band error σ a band the prior cannot produce
at all adds only ~1/σ² to χ², so at the σ of 0.1 a fit may choose no pixel
can ever exceed the held-out lamps' upper percentiles and the flag never fires;
at 0.003 a pixel unlike every lamp stands far above any held-out lamp."""

PHYSICAL_RANGE = {
    "LER": (0.0, K_M_LM_PER_W),
    "G": (-G_CAP, G_CAP),
    "CCT": CCT_RANGE_K,
}
"""Bounds no estimate or interval ever leaves. [lm W⁻¹], [1], [K]"""

INTERVAL_FLOOR = np.array([1.0, 0.005, 2.0])
"""Smallest half-width of a posterior range before conformal scaling, in model
space (LER [lm W⁻¹], G [1], CCT [mired]): a posterior concentrated on one
lamp still gets an interval."""

INTERVAL_OFFSET_GRID = (0.0, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0)
"""Candidate offsets of the conformal interval's unit, as fractions of the
metric's spread over the training lamps (model space), for `fit_inversion(
interval_offsets=)`: a pixel's interval is its posterior 5-95 % range
widened by `conformal x (half-width + offset)`. 0 scales with the
posterior's width alone (a concentrated posterior gets a narrow interval,
a broad one a very wide one); large offsets widen every pixel by nearly the
same amount (at 10 x the spread, far above any posterior half-width, the
interval is in effect additive, as `Romano2019`'s conformalised quantile
regression). On partition 0, fold 0 the grid up to 1 chose 1 for LER and
CCT; 3 and 10 narrowed the calibration intervals by a further 5-7 %."""

CHUNK = 64
"""Pixels scored per compiled call (bounds memory to ~200 MB)."""


# ------------------------------------------------------------------------------
# Scene conditions and priors


@dataclasses.dataclass(frozen=True)
class Conditions:
    """What the inversion knows of the scene besides lamp and surface.

    - `wavelength_nm`: grid. (w,) [nm]
    - `t_up`: upward (total) transmittance of each candidate atmosphere; the
      Moon's light reaches the sensor through it (the whole neighbourhood is
      moonlit). (a, w) [1]
    - `moon`: Moon's irradiance on the ground `T_down E_moon cos θ` of its
      brightest state, or None for moonless scenes. (a, w) [W m⁻² nm⁻¹]
    - `path`: the Moon's path radiance, same state, or None. (a, w)
    - `labels`: atmosphere labels.
    - `t_lamp`: transmittance of the lamp light reflected in the pixel,
      `T_dir + k T_dif` for a neighbourhood whose lamp light is `k` times the
      pixel's (`scene.Factors.emission_transmittance`), or None for a uniform
      neighbourhood (`t_up`). (a, w) [1]
    """

    wavelength_nm: np.ndarray
    t_up: np.ndarray
    moon: np.ndarray | None
    path: np.ndarray | None
    labels: tuple[str, ...]
    t_lamp: np.ndarray | None = None

    @property
    def lamp_transmittance(self) -> np.ndarray:
        """`t_lamp`, or `t_up` for a uniform neighbourhood. (a, w) [1]"""
        return self.t_up if self.t_lamp is None else self.t_lamp

    @classmethod
    def from_scenarios(cls, scen) -> "Conditions":
        """Atmospheres, neighbourhood and the brightest Moon state of a
        `scene.ScenarioSet`. A neighbourhood with its own background surface
        is approximated by the pixel's surface (`T_dir + k T_dif`)."""
        f = scen.factors
        moon = path = None
        if f.moon_ground is not None:
            mg = np.asarray(f.moon_ground)
            k = int(np.argmax(mg.sum(axis=(0, 2))))
            if mg[:, k].max() > 0:
                moon = mg[:, k]
                path = None if f.path is None else np.asarray(f.path)[:, k]
        return cls(
            np.asarray(f.wavelength_nm, float),
            np.asarray(f.t_up, float),
            moon,
            path,
            tuple(scen.atmosphere_labels),
            None if f.t_dir is None else np.asarray(f.emission_transmittance(), float),
        )

    @classmethod
    def clear(cls, wavelength_nm) -> "Conditions":
        """No atmosphere (T = 1), no Moon."""
        w = np.asarray(wavelength_nm, float)
        return cls(w, np.ones((1, w.size)), None, None, ("none",))


@dataclasses.dataclass(frozen=True)
class SurfaceBasis:
    """Low-rank reflectance basis `ρ = mean + coords @ basis`.

    - `mean`: (w,) [1]; `basis`: (r, w) orthonormal rows; `scale`: prior SD of
      each coefficient (r,); `types`: surface types, `type_coords`: their mean
      reflectances' coefficients (t, r).
    """

    wavelength_nm: np.ndarray
    mean: np.ndarray
    basis: np.ndarray
    scale: np.ndarray
    types: tuple[str, ...]
    type_coords: np.ndarray

    def coords(self, reflectance) -> np.ndarray:
        """Least-squares coefficients of reflectances on the grid, (n, r)."""
        return (np.atleast_2d(reflectance) - self.mean) @ self.basis.T

    def reflectance(self, coords) -> np.ndarray:
        return self.mean + np.atleast_2d(coords) @ self.basis

    def class_coords(self, name: str, n: int = 11, seed: int = 0) -> np.ndarray:
        """Candidates when the class is known: its mean and `n` measured
        samples (drawn with `seed`), (n + 1, r)."""
        name = surf_mod.resolve_surface(name)
        grid = self.wavelength_nm
        _, mean = surf_mod.mean_reflectance([name], grid)
        s = surf_mod.sample_reflectance(name, n, seed, grid)
        return self.coords(np.vstack([mean, s]))


def surface_basis(
    wavelength_nm,
    types: Sequence[str] = PRIOR_SURFACES,
    rank: int = SURFACE_RANK,
) -> SurfaceBasis:
    """Type-balanced weighted PCA of every library reflectance of `types`."""
    grid = np.asarray(wavelength_nm, float)
    rows, wts, means = [], [], []
    for t in types:
        s = surf_mod.surface(t).resample(grid)
        r = np.asarray(s.reflectance, float)
        rows.append(r)
        wts.append(np.full(r.shape[0], 1.0 / (len(types) * r.shape[0])))
        means.append(r.mean(axis=0))
    x, w = np.vstack(rows), np.concatenate(wts)
    mu = w @ x
    xc = (x - mu) * np.sqrt(w)[:, None]
    _, sv, vt = np.linalg.svd(xc, full_matrices=False)
    basis = vt[:rank]
    scale = sv[:rank]  # weights sum to 1: singular values are the coefficient SDs
    return SurfaceBasis(
        grid, mu, basis, scale, tuple(types), (np.stack(means) - mu) @ basis.T
    )


def sentinel2_response(wavelength_nm) -> tuple[tuple[str, ...], np.ndarray]:
    """Sentinel-2A MSI band responses on the grid (bands with at least
    `S2_MIN_INSIDE` of their response area on it, cut at its ends),
    `(names, (b, w))`, from the vendored Py6S tables (`ESA2017`)."""
    data = np.genfromtxt(S2_FILE, delimiter=",", names=True)
    grid = np.asarray(wavelength_nm, float)
    names, rows = [], []
    wl = data["wavelength_nm"]
    for name in data.dtype.names[1:]:
        r = np.asarray(data[name], float)
        inside = (wl >= grid[0]) & (wl <= grid[-1])
        if np.trapezoid(r * inside, wl) < S2_MIN_INSIDE * np.trapezoid(r, wl):
            continue
        names.append(name)
        rows.append(np.interp(grid, data["wavelength_nm"], r, left=0.0, right=0.0))
    return tuple(names), np.stack(rows)


def observe_sentinel2(reflectance, wavelength_nm, *, seed: int = 0) -> np.ndarray:
    """Daytime Sentinel-2 band reflectances of surfaces with the L2A error
    `σ = 0.05 ρ + 0.005` (Gaussian, `numpy.random.default_rng(seed)`), (n, b)."""
    _, resp = sentinel2_response(wavelength_nm)
    r = np.atleast_2d(reflectance)
    band = r @ resp.T / resp.sum(axis=1)
    sd = S2_SIGMA[0] * band + S2_SIGMA[1]
    return band + sd * np.random.default_rng(seed).standard_normal(band.shape)


def surface_from_sentinel2(observed, basis: SurfaceBasis) -> np.ndarray:
    """Basis coefficients from Sentinel-2 band reflectances: the Gaussian
    posterior mean under the basis prior and the L2A error model, (n, r)."""
    _, resp = sentinel2_response(basis.wavelength_nm)
    h = resp / resp.sum(axis=1, keepdims=True)
    a = h @ basis.basis.T  # (b, r)
    m0 = h @ basis.mean
    obs = np.atleast_2d(observed)
    out = np.empty((obs.shape[0], basis.basis.shape[0]))
    for i, o in enumerate(obs):
        sd = S2_SIGMA[0] * np.clip(o, 0, None) + S2_SIGMA[1]
        aw = a / sd[:, None]
        lhs = aw.T @ aw + np.diag(1.0 / basis.scale**2)
        out[i] = np.linalg.solve(lhs, aw.T @ ((o - m0) / sd))
    return out


@dataclasses.dataclass(frozen=True)
class LampPrior:
    """Training lamps of the prior: spectra per lumen (k, w) [W nm⁻¹ lm⁻¹],
    their types, photometric truth (k, 3) in `METRICS` order with validity, and
    log prior weights (class-balanced over level-2 classes)."""

    ids: tuple[str, ...]
    spectra: np.ndarray
    level1: tuple[str, ...]
    level2: tuple[str, ...]
    truth: np.ndarray
    valid: np.ndarray
    log_prior: np.ndarray


def variant_base(lamp_id: str) -> str:
    """The lamp a prior entry stands for: its id without a NIR-variant prefix
    (`NIR_VARIANT_TAGS`), so a lamp and its variants share one prior mass."""
    head, sep, rest = lamp_id.partition(":")
    return rest if sep and head in NIR_VARIANT_TAGS else lamp_id


def lamp_prior(ids, spectra, level1, level2, wavelength_nm) -> LampPrior:
    """Build the prior from training lamps (level2 may repeat level1 for lamps
    without a level-2 class). Class-balanced over level-2 classes, each lamp
    the same within its class; a lamp's NIR variants (`nir_variants`) split
    its mass, so modelling the NIR's uncertainty does not reweigh classes."""
    spectra = np.asarray(spectra, float)
    truth, valid = lamp_truth(spectra, wavelength_nm)
    l2 = tuple(str(x) for x in level2)
    base = [variant_base(str(i)) for i in ids]
    groups = {}
    for b, c in zip(base, l2, strict=True):
        groups.setdefault(b, [0, c])[0] += 1
    keys = list(groups)
    gw = dict(
        zip(
            keys,
            class_balanced_weights(np.asarray([groups[k][1] for k in keys], object)),
            strict=True,
        )
    )
    w = np.array([gw[b] / groups[b][0] for b in base])
    return LampPrior(tuple(ids), spectra, tuple(level1), l2, truth, valid, np.log(w))


# ------------------------------------------------------------------------------
# Core


def _design(spectra, weights, cond: Conditions, basis: SurfaceBasis):
    """Band terms: lamp x surface `A (k, a, b, r+1)`, Moon `Q (a, b, r+1)`.

    The same contraction as `bandopt.forward.band_radiance` (weights
    `W` from `forward.band_weights_on`, lamp light through
    `T_e`, moonlight through `T`, path radiance added once), but over a
    different factorisation: every candidate lamp `k` times every surface
    *basis vector* `r` (mean and principal components, not reflectances) per
    candidate atmosphere, with the illuminance and the Moon's brightness left
    as unknown scales solved per pixel. `forward.band_radiance` contracts
    whole scenes (one reflectance per surface, one illuminance per class), so
    it cannot produce these per-basis-vector terms without one call per basis
    vector and lamp. `tests/test_inversion.py::
    test_design_matches_the_scene_in_its_neighbourhood` checks the terms
    against `scene.band_terms`, the contraction `forward.band_measurement`
    uses, on real scenes."""
    rho = np.vstack([basis.mean, basis.basis]) / math.pi  # (r+1, w)
    lw = cond.lamp_transmittance[:, None, :] * weights[None]  # (a, b, w)
    a = jnp.einsum(
        "kw,abw,rw->kabr", spectra, lw, rho, precision=jax.lax.Precision.HIGHEST
    )
    if cond.moon is None:
        return np.asarray(a), None
    tw = cond.t_up[:, None, :] * weights[None]  # (a, b, w)
    q = np.einsum("aw,abw,rw->abr", cond.moon, tw, rho)
    if cond.path is not None:
        q[..., 0] += np.einsum("aw,bw->ab", cond.path, weights)
    return np.asarray(a), q


def _chi2(yn, w, p, q, beta=None):
    """Weighted NNLS misfit of `yn ≈ α p + β q` (α, β ≥ 0) in closed form,
    broadcast over the leading axes of `p`, `q` (last axis: bands). With
    `beta` (a scalar, the known Moon amplitude in `yn`'s units) only `α` is
    fitted: the misfit of `yn - β q ≈ α p`."""

    def dot(u, v):
        nd = max(u.ndim, v.ndim)
        u = u.reshape((1,) * (nd - u.ndim) + u.shape)
        v = v.reshape((1,) * (nd - v.ndim) + v.shape)
        return jnp.sum(w.reshape((1,) * (nd - 1) + (-1,)) * u * v, axis=-1)

    spp, spy, syy = dot(p, p), dot(p, yn), dot(yn, yn)
    tiny = 1e-300
    if beta is not None and q is not None:
        sqq, spq, sqy = dot(q, q), dot(p, q), dot(q, yn)
        return _chi2_known(spp, spy, syy, sqq, spq, sqy, beta)
    a1 = jnp.maximum(spy, 0.0) / jnp.maximum(spp, tiny)
    chi_a = syy - a1 * spy
    if q is None:
        return chi_a
    sqq, spq, sqy = dot(q, q), dot(p, q), dot(q, yn)
    det = spp * sqq - spq**2
    ok = det > 1e-12 * jnp.maximum(spp * sqq, tiny)
    dsafe = jnp.where(ok, det, 1.0)
    a2 = (sqq * spy - spq * sqy) / dsafe
    b2 = (spp * sqy - spq * spy) / dsafe
    both = ok & (a2 >= 0) & (b2 >= 0)
    chi_ab = syy - a2 * spy - b2 * sqy
    b1 = jnp.maximum(sqy, 0.0) / jnp.maximum(sqq, tiny)
    chi_b = syy - b1 * sqy
    best = jnp.minimum(chi_a, chi_b)
    return jnp.maximum(jnp.where(both, jnp.minimum(chi_ab, best), best), 0.0)


def _chi2_known(spp, spy, syy, sqq, spq, sqy, beta):
    """Misfit of `y - β q ≈ α p` (α ≥ 0, β known) from the weighted sums of
    `_chi2`: `Σw(y-βq)² = syy - 2β sqy + β² sqq`, `Σw p(y-βq) = spy - β spq`."""
    r_py = spy - beta * spq
    r_yy = syy - 2.0 * beta * sqy + beta**2 * sqq
    a1 = jnp.maximum(r_py, 0.0) / jnp.maximum(spp, 1e-300)
    return jnp.maximum(r_yy - a1 * r_py, 0.0)


@jax.jit
def _score_chunk(y, cand, log_ps, a, q, log_pk, noise, moon_b=None):
    """Per pixel and band-error model in `noise (S, 2)` (`σ_rel`, floor: the
    band error is `σ_rel |y_b| + floor` in units of the pixel's mean |y|):
    log evidence per lamp (S, k) and best χ² (S,). `y (n, b)`, `cand (n, s,
    r+1)`, `log_ps (n, s)`."""

    def one(yp, c, lps, b):
        m = jnp.mean(jnp.abs(yp))
        mm = jnp.where(m > 0, m, 1.0)
        yn = yp / mm
        p = jnp.einsum("kabr,sr->ksab", a, c)
        qq = None if q is None else jnp.einsum("abr,sr->sab", q, c)[None]
        known = b is not None and qq is not None
        if known:  # NaN: unknown (fitted); double-where keeps gradients finite
            is_known = jnp.isfinite(b)
            beta = jnp.where(is_known, b, 0.0) / mm

        def at(nf):
            sd = nf[0] * jnp.abs(yn) + nf[1]
            chi = _chi2(yn, 1.0 / sd**2, p, qq)  # (k, s, a)
            if known:
                chi = jnp.where(is_known, _chi2(yn, 1.0 / sd**2, p, qq, beta), chi)
            lw = -0.5 * chi + lps[None, :, None]
            lk = logsumexp(lw.reshape(lw.shape[0], -1), axis=1) + log_pk
            return lk, jnp.min(chi)

        return jax.lax.map(at, noise)

    if moon_b is None:
        return jax.vmap(lambda yp, c, lps: one(yp, c, lps, None))(y, cand, log_ps)
    return jax.vmap(one)(y, cand, log_ps, moon_b)


def _log_sum_chi(chi, lps):
    """`log Σ_c exp(-χ²_c/2 + lps_c)` over the last axis (the surface-
    atmosphere candidates `c` of each lamp) and the least `χ²` of each row, in
    two passes over `chi` instead of three: the least `χ²` is also the
    shift, `-χ²_min/2 + max lps`, above every term, so nothing overflows, and
    the term of the best candidate is at least `exp(min lps - max lps)`, so a
    row never underflows to -inf. ~1.8x faster than jax's `logsumexp` and a
    separate `min` (which guard infinities these finite scores never hold);
    the same numbers to rounding (tested against them)."""
    cmin = jnp.min(chi, axis=-1, keepdims=True)
    top = jnp.max(lps)
    lk = jnp.log(jnp.sum(jnp.exp(-0.5 * (chi - cmin) + (lps - top)), axis=-1))
    return lk - 0.5 * cmin[..., 0] + top, cmin[..., 0]


@functools.partial(jax.jit, static_argnames=("all_known",))
def _score_chunk_shared(y, p, qq, log_ps, log_pk, noise, moon_b=None, all_known=False):
    """`_score_chunk` when every pixel has the same surface candidates.

    The weighted sums of `_chi2` are matrix products over the candidates'
    pixel-independent band products (`p²`, `p q`, `q²`, flattened to
    `(k s a, b)`), `Σ_b w_b u_b v_b = W @ (u v)ᵀ`, so a chunk of pixels is a few
    GEMMs plus the closed-form NNLS, elementwise (2-3x faster than
    broadcasting per pixel; same numbers to 1e-10, tested against
    `_score_chunk`). `p (k, s, a, b)`, `qq (1, s, a, b)` or None.
    `all_known` (static): every pixel's Moon amplitude is given (finite), so
    the misfit with a fitted Moon is not computed at all (about half the
    elementwise work; the result is the same), and the told misfit's lamp
    products `Σ w p y` and `Σ w p q` are one GEMM (`Σ w p (y - β q)`)."""
    k, s, a, b = p.shape
    pf = p.reshape(-1, b)
    p2 = pf * pf
    m = jnp.mean(jnp.abs(y), axis=1, keepdims=True)
    yn = y / jnp.where(m > 0, m, 1.0)
    lps = jnp.repeat(log_ps, a)[None, None, :]  # (1, 1, s a), a fastest
    hi = jax.lax.Precision.HIGHEST
    tiny = 1e-300

    def grid(x):  # (n, k s a) -> (n, k, s a)
        return x.reshape(x.shape[0], k, s * a)

    told = qq is not None and all_known
    if told:  # `Σ w p (y - β q)` as one GEMM over [p, p q] (see below)
        q_told = jnp.broadcast_to(qq, (1, s, a, b)).reshape(-1, b)
        p_pq = jnp.concatenate([pf, (p * qq).reshape(-1, b)], axis=1)  # (K, 2b)
        beta_told = (moon_b / jnp.where(m[:, 0] > 0, m[:, 0], 1.0))[:, None]

    def at(nf):
        sd = nf[0] * jnp.abs(yn) + nf[1]
        w = 1.0 / sd**2
        wy = w * yn
        spp = grid(jnp.matmul(w, p2.T, precision=hi))
        if told:
            # the Moon told: only `α` is fitted to `y - β q`, whose weighted
            # products with the lamp terms are `Σ w p y - β Σ w p q`: one GEMM
            # of `[w y, -β w]` against `[p, p q]` (inner size 2b) instead of
            # two, and no (n, K) difference; ~1.6x faster, the same numbers
            # to ~1e-12 (tested against the fitted-Moon path's formula)
            r_py = grid(
                jnp.matmul(
                    jnp.concatenate([wy, -beta_told * w], axis=1),
                    p_pq.T,
                    precision=hi,
                )
            )
            syy = jnp.sum(wy * yn, axis=1)[:, None]
            sqq = jnp.matmul(w, (q_told * q_told).T, precision=hi)
            sqy = jnp.matmul(wy, q_told.T, precision=hi)
            r_yy = (syy - 2.0 * beta_told * sqy + beta_told**2 * sqq)[:, None, :]
            chi = r_yy - jnp.square(jnp.maximum(r_py, 0.0)) / jnp.maximum(spp, tiny)
            lk, cmin = _log_sum_chi(jnp.maximum(chi, 0.0), lps)
            return lk + log_pk[None, :], jnp.min(cmin, axis=1)
        spy = grid(jnp.matmul(wy, pf.T, precision=hi))
        syy = jnp.sum(wy * yn, axis=1)[:, None, None]
        a1 = jnp.maximum(spy, 0.0) / jnp.maximum(spp, tiny)
        chi = syy - a1 * spy
        if qq is not None:
            qf = jnp.broadcast_to(qq, (1, s, a, b)).reshape(-1, b)
            pq = (p * qq).reshape(-1, b)
            sqq = jnp.matmul(w, (qf * qf).T, precision=hi)[:, None, :]
            sqy = jnp.matmul(wy, qf.T, precision=hi)[:, None, :]
            spq = grid(jnp.matmul(w, pq.T, precision=hi))
            det = spp * sqq - spq**2
            ok = det > 1e-12 * jnp.maximum(spp * sqq, tiny)
            dsafe = jnp.where(ok, det, 1.0)
            a2 = (sqq * spy - spq * sqy) / dsafe
            b2 = (spp * sqy - spq * spy) / dsafe
            both = ok & (a2 >= 0) & (b2 >= 0)
            chi_ab = syy - a2 * spy - b2 * sqy
            b1 = jnp.maximum(sqy, 0.0) / jnp.maximum(sqq, tiny)
            best = jnp.minimum(chi, syy - b1 * sqy)
            chi = jnp.where(both, jnp.minimum(chi_ab, best), best)
            if moon_b is not None:  # known Moon amplitude per pixel (NaN: fitted)
                is_known = jnp.isfinite(moon_b)[:, None, None]
                mm = jnp.where(m[:, 0] > 0, m[:, 0], 1.0)
                beta = (jnp.where(jnp.isfinite(moon_b), moon_b, 0.0) / mm)[
                    :, None, None
                ]
                chi_known = _chi2_known(spp, spy, syy, sqq, spq, sqy, beta)
                chi = jnp.where(is_known, chi_known, chi)
        lk, cmin = _log_sum_chi(jnp.maximum(chi, 0.0), lps)
        return lk + log_pk[None, :], jnp.min(cmin, axis=1)

    lk, chi = jax.lax.map(at, noise)  # (S, n, k), (S, n)
    return jnp.moveaxis(lk, 0, 1), jnp.moveaxis(chi, 0, 1)


@jax.jit
def _normalise(lk):
    """Log normaliser (..., 1) and posterior (..., k) of log weights `lk`
    (..., k), compiled (one fused pass instead of numpy's three)."""
    norm = logsumexp(lk, axis=-1, keepdims=True)
    return norm, jnp.exp(lk - norm)


def log_evidence(log_norm, y, sigmas, floors=None) -> np.ndarray:
    """Log marginal likelihood of each pixel's band radiances `y (n, b)`,
    normalised by their mean |y|, under the prior, per `σ_rel` in `sigmas`
    (with band-error floors `floors`, default `SIGMA_FLOOR` for each):
    `log Σ_k π_k Σ_s π_s exp(-χ²/2)` (`log_norm (n, S)`, what the scores
    sum) plus the Gaussian normalisers `-Σ_b log sd_b - b/2 log 2π` that
    depend on σ (`sd_b = σ |y_b| + floor`). The lamp amplitude and Moon
    term are profiled (fitted), so this is a profile evidence; it compares
    `σ_rel` values on the same pixels, not models with other amplitudes.
    (n, S)."""
    y = np.atleast_2d(np.asarray(y, float))
    m = np.mean(np.abs(y), axis=1, keepdims=True)
    yn = np.abs(y / np.where(m > 0, m, 1.0))
    sig = np.asarray(sigmas, float)
    fl = np.broadcast_to(
        np.asarray(SIGMA_FLOOR if floors is None else floors, float), sig.shape
    )
    sd = sig[None, :, None] * yn[:, None, :] + fl[None, :, None]  # (n, S, b)
    b = y.shape[1]
    return (
        np.asarray(log_norm) - np.log(sd).sum(axis=-1) - 0.5 * b * math.log(2 * math.pi)
    )


CALIBRATIONS = ("lamps", "classes")
"""Held-out data `fit_inversion` calibrates its 90 % intervals on: `"lamps"`
(default: the inner folds' held-out lamps, whose classes the inner prior
holds, so the intervals are calibrated for new lamps of known types) or
`"classes"` (each training class held out in turn from a prior of the other
classes at the chosen `σ_rel`: calibrated for lamps of a type the prior does
not hold, so wider)."""

SIGMA_RULES = ("error", "evidence", "per-metric")
"""How `fit_inversion` chooses `σ_rel` on its inner folds: `"error"` (the
class-balanced metric error of the held-out inner lamps, normalised per
metric and summed: the target itself, but noisy with few lamps per class),
`"evidence"` (the class-balanced mean log marginal likelihood of their
pixels, `log_evidence`: a proper score over every pixel and band, so a
steadier choice, but of the band-noise model, not of the metric error) or
`"per-metric"` (`σ_rel` as `"error"` for the types, misfit and flag, and
each metric's estimate and interval from the posterior at its own `σ_rel`,
the one with the least held-out error of that metric: `Inversion.
metric_sigma`; one more scoring per pixel when they differ). A small
`σ_rel` weighs the bands nearly by absolute error (the floor `SIGMA_FLOOR`
is then a third of the error), a large one by relative error; LER is best
estimated with the former, G and CCT with the latter (measured: issue 12,
`make estimate-mix`), so one σ for all three is a trade-off."""


SHARED_CHUNK = 256
"""Pixels per compiled call when the surface candidates are shared (bounds
the `(n, k s a)` temporaries to ~30 MB each for a 224-lamp prior)."""


K_BUCKET = 32
"""Prior sizes are padded to a multiple of this (one compilation for priors
of similar size; padded lamps have zero spectra and zero prior)."""


CHUNK_PRIOR = 256
"""Prior size up to which `CHUNK` and `SHARED_CHUNK` pixels go per call;
larger priors (e.g. with `mixture_lamps`) get proportionally fewer pixels
per call (`_chunk`), so memory stays bounded."""


def _chunk(base: int, k: int) -> int:
    """Pixels per compiled call for a prior of `k` lamps: `base` up to
    `CHUNK_PRIOR` lamps, then halved until `base·CHUNK_PRIOR/k` (at least 8)."""
    c = base
    while c > 8 and c * k > base * CHUNK_PRIOR:
        c //= 2
    return c


def _score(y, cand, log_ps, a, q, log_pk, noise, moon_b=None):
    """Chunked, padded `_score_chunk`: (log evidence (n, S, k), χ² (n, S));
    `noise (S, 2)`: (`σ_rel`, floor) per band-error model.
    `moon_b` (n,): known Moon amplitudes (relative to `q`'s Moon state; NaN:
    fitted), or None (all fitted)."""
    noise = np.asarray(noise, float)
    if noise.ndim != 2 or noise.shape[1] != 2:
        raise ValueError(
            f"noise: expected (S, 2) (σ_rel, floor) pairs, got {noise.shape}."
        )
    y = np.asarray(y, float)
    if moon_b is not None:
        moon_b = np.asarray(moon_b, float).reshape(-1)
        if moon_b.shape[0] != y.shape[0]:
            raise ValueError(
                f"moon: {moon_b.shape[0]} amplitudes for {y.shape[0]} pixels."
            )
        if q is None:
            if np.any(np.nan_to_num(moon_b, nan=0.0) != 0):
                raise ValueError(
                    "moon: a Moon amplitude was given but the conditions have no "
                    "Moon term."
                )
            moon_b = None
    n, k = y.shape[0], a.shape[0]
    kp = -(-k // K_BUCKET) * K_BUCKET
    a = np.concatenate([a, np.zeros((kp - k, *a.shape[1:]))])
    log_pk = np.concatenate([log_pk, np.full(kp - k, -1e30)])
    chunk, shared_chunk = _chunk(CHUNK, kp), _chunk(SHARED_CHUNK, kp)
    npad = -(-max(n, 1) // chunk) * chunk
    pad = npad - n

    def padded(x, fill):
        x = np.asarray(x, float)
        return np.concatenate([x, np.full((pad, *x.shape[1:]), fill)])

    cand = np.asarray(cand, float)
    if n > 1 and np.all(cand == cand[:1]) and np.all(log_ps == log_ps[:1]):
        # one set of surface candidates for every pixel (mode 'unknown')
        p = jnp.einsum("kabr,sr->ksab", jnp.asarray(a), jnp.asarray(cand[0]))
        qq = None if q is None else jnp.einsum("abr,sr->sab", q, cand[0])[None]
        npad = -(-n // shared_chunk) * shared_chunk
        y = np.concatenate([y, np.ones((npad - n, y.shape[1]))])
        all_known = moon_b is not None and bool(np.all(np.isfinite(moon_b)))
        mb = (
            None
            if moon_b is None
            else np.concatenate(
                [moon_b, np.full(npad - n, 0.0 if all_known else np.nan)]
            )
        )
        # the per-chunk arguments go in as numpy slices: `jnp.asarray` of each
        # is an eager op, ~0.3 ms a call, ~8 % of evaluate's predict at 32
        # pixels per chunk; the constant ones are converted once
        const = (
            None if qq is None else jnp.asarray(qq),
            jnp.asarray(log_ps[0]),
            jnp.asarray(log_pk),
            jnp.asarray(noise),
        )
        lks, chis = [], []
        for i in range(0, npad, shared_chunk):
            lk, chi = _score_chunk_shared(
                y[i : i + shared_chunk],
                p,
                *const,
                None if mb is None else mb[i : i + shared_chunk],
                all_known=all_known,
            )
            lks.append(np.asarray(lk))
            chis.append(np.asarray(chi))
        return np.concatenate(lks)[:n, :, :k], np.concatenate(chis)[:n]
    y, cand, log_ps = padded(y, 1.0), padded(cand, 0.0), padded(log_ps, 0.0)
    mb = None if moon_b is None else padded(moon_b, np.nan)
    cand[n:, :, 0] = 1.0
    args = (
        jnp.asarray(a),
        None if q is None else jnp.asarray(q),
        jnp.asarray(log_pk),
        jnp.asarray(noise),
    )
    lks, chis = [], []
    for i in range(0, npad, chunk):
        sl = slice(i, i + chunk)
        lk, chi = _score_chunk(
            jnp.asarray(y[sl]),
            jnp.asarray(cand[sl]),
            jnp.asarray(log_ps[sl]),
            *args,
            None if mb is None else jnp.asarray(mb[sl]),
        )
        lks.append(np.asarray(lk))
        chis.append(np.asarray(chi))
    return np.concatenate(lks)[:n, :, :k], np.concatenate(chis)[:n]


def weighted_quantile(values, weights, qs):
    """Quantiles of discrete distributions row-wise: values (k,), weights (n, k)."""
    order = np.argsort(values)
    v, w = values[order], weights[:, order]
    c = np.cumsum(w, axis=1)
    c = c / np.maximum(c[:, -1:], 1e-300)
    return np.stack(
        [v[np.minimum((c < q).sum(axis=1), v.size - 1)] for q in qs], axis=-1
    )


METRIC_ROWS = 1024
"""Most posterior rows `_posterior_metrics` summarises per compiled call
(fewer rows are padded to a power of two, more to a multiple of this: a few
shapes compile, and memory stays bounded)."""


@jax.jit
def _metric_summary(post, vals, okf, order, qs):
    """Per metric row of `vals`, `okf` (validity as 0/1), `order` (M, k): the
    mean (n, M) and the weighted quantiles `qs` (n, M, Q) of the prior's valid
    values under the posterior `post` (n, k), renormalised over the valid
    entries. `order` sorts each row's invalid entries first (zero weight, so
    they never hold a quantile: the first entry whose cumulative weight reaches
    q has weight > 0), then its values; `weighted_quantile`'s rule."""

    def one(v, ok, o):
        w = post * ok[None]
        w = w / jnp.maximum(w.sum(axis=1, keepdims=True), 1e-300)
        mean = jnp.matmul(w, v, precision=jax.lax.Precision.HIGHEST)
        c = jnp.cumsum(w[:, o], axis=1)
        c = c / jnp.maximum(c[:, -1:], 1e-300)
        idx = jnp.minimum(jnp.sum(c[:, :, None] < qs[None, None], axis=1), v.size - 1)
        return mean, v[o][idx]

    return jax.vmap(one, out_axes=(1, 1))(vals, okf, order)


def _posterior_metrics(post, prior: LampPrior, metrics=(0, 1, 2)):
    """Posterior mean and 5-95 % range in model space (CCT as mired), and
    P(CCT meaningful). post (n, k) sums to 1 per row. Only the columns of
    `metrics` (indices into `METRICS`) are computed; the others are NaN.
    Compiled (`_metric_summary`, `METRIC_ROWS` rows per call): the same
    numbers as `weighted_quantile` on each metric's valid entries."""
    post = np.asarray(post, float)
    t = prior.truth.copy()
    t[:, 2] = np.where(
        prior.valid[:, 2], MIRED / np.where(prior.valid[:, 2], t[:, 2], 1), 0
    )
    n = post.shape[0]
    mean = np.full((n, 3), np.nan)
    rng = np.full((n, 3, 2), np.nan)
    p_cct = post @ prior.valid[:, 2].astype(float)
    lo_q, hi_q = (1 - COVERAGE) / 2, 1 - (1 - COVERAGE) / 2
    ms = [m for m in metrics if prior.valid[:, m].any()]
    if not ms or n == 0:
        return mean, rng, p_cct
    ok = prior.valid[:, ms].T  # (M, k)
    vals = np.where(ok, t[:, ms].T, 0.0)
    order = np.stack([np.lexsort((v, o)) for v, o in zip(vals, ok, strict=True)])
    qs = jnp.asarray([lo_q, hi_q])
    # a few compiled shapes: powers of two up to METRIC_ROWS, then chunks
    step = min(METRIC_ROWS, 1 << max(3, (n - 1).bit_length()))
    rows = -(-n // step) * step
    padded = np.concatenate([post, np.zeros((rows - n, post.shape[1]))])
    parts = [
        _metric_summary(padded[i : i + step], vals, ok.astype(float), order, qs)
        for i in range(0, rows, step)
    ]
    mean[:, ms] = np.concatenate([np.asarray(p[0]) for p in parts])[:n]
    rng[:, ms] = np.concatenate([np.asarray(p[1]) for p in parts])[:n]
    return mean, rng, p_cct


def _to_model(values):
    v = np.array(values, float)
    v[..., 2] = MIRED / v[..., 2]
    return v


def _model_bounds():
    lo = np.array(
        [PHYSICAL_RANGE["LER"][0], PHYSICAL_RANGE["G"][0], MIRED / CCT_RANGE_K[1]]
    )
    hi = np.array(
        [PHYSICAL_RANGE["LER"][1], PHYSICAL_RANGE["G"][1], MIRED / CCT_RANGE_K[0]]
    )
    return lo, hi


# ------------------------------------------------------------------------------
# Fitted inversion


@dataclasses.dataclass(frozen=True)
class LampSet:
    """Measured lamps with their types: the rows an inversion trains on.
    `spectra` (l, w) per lumen on the conditions' grid."""

    ids: tuple[str, ...]
    spectra: np.ndarray
    level1: tuple[str, ...]
    level2: tuple[str, ...]

    def take(self, index) -> "LampSet":
        idx = np.asarray(index, int)
        return LampSet(
            tuple(self.ids[i] for i in idx),
            self.spectra[idx],
            tuple(self.level1[i] for i in idx),
            tuple(self.level2[i] for i in idx),
        )

    def __add__(self, other: "LampSet") -> "LampSet":
        return LampSet(
            self.ids + other.ids,
            np.vstack([self.spectra, other.spectra]),
            self.level1 + other.level1,
            self.level2 + other.level2,
        )


def library_lamps(wavelength_nm, *, scored: bool) -> LampSet:
    """Measured library lamps on a grid: the scored ones (`scored=True`) or the
    measured lamps of classes too small to score (`scored=False`, e.g.
    low-pressure sodium), which only ever train."""
    lib = library(wavelength_nm=np.asarray(wavelength_nm, float)).select()
    keep = [
        i
        for i, r in enumerate(lib.records)
        if (
            lib.is_scored(r)
            if scored
            else (not lib.is_scored(r) and r.excluded is None)
        )
        and (r.level2 is not None or not scored)
    ]
    return _lamp_set(lib, keep)


def _lamp_set(lib, keep) -> LampSet:
    """The library records `keep` (indices) as a `LampSet`; a record without a
    level-2 class (an unscored kind) gets its level 1 in its place."""
    recs = [lib.records[i] for i in keep]
    return LampSet(
        tuple(r.id for r in recs),
        np.asarray(lib.values[keep], float),
        tuple(r.level1 for r in recs),
        tuple(r.level2 if r.level2 is not None else r.level1 for r in recs),
    )


MODELLED_CLASSES = ("lps", "mercury", "led_amber", "metal_halide", "hps")
"""Level-2 classes that get modelled lamps by default: the rare outdoor
classes (2-11 measured lamps each). The white LED classes (`led_warm`,
`led_cool`, 150 measured lamps) also have a model but are left out by
default: they are well sampled already, and fitting their lamps adds ~3 min
per process (see `modelled_lamps`); pass them in `modelled_classes` to use
them. Fluorescent and incandescent lamps have no model."""

MIN_CALIBRATION_LAMPS = 2
"""Least measured training lamps of a class for its model to be sampled: a
calibration on one lamp has no spread (every sample would be that lamp's
fit). A class with fewer training lamps in a fit gets no modelled lamps."""

MODELLED_SEED_STRIDE = 104729
"""Seed offset between classes of one `modelled_lamps` call (a prime, so the
classes' draws never share a seed)."""


MIX_PAIRS = 50
"""Most same-class pairs per class whose mixtures join a prior
(`mixture_lamps`; all pairs when a class has fewer). Measured on partition
0's three outer folds (recommended bands, Moon told, surface unknown, σ_rel
fixed at 0.003): 50, 100 and 200 pairs per class gave LER errors of 11.9,
11.8 and 11.8 lm/W (all pairs, ~11,000 mixtures: fold 0 the same as 200), so
50 it is: a prior of ~1,300 entries instead of ~3,300, ~3x faster."""

MIX_FRACTIONS = (0.25, 0.5, 0.75)
"""Luminous-flux fractions of the first lamp in each pairwise mixture."""


def mixture_lamps(
    lamps: LampSet,
    max_pairs: int = MIX_PAIRS,
    *,
    fractions: Sequence[float] = MIX_FRACTIONS,
    seed: int = 0,
) -> LampSet:
    """Pairwise mixtures of same-class lamps: `f S_i + (1 - f) S_j` for
    `f` in `fractions`, per lumen like the lamps (each lamp contributes the
    fraction `f` of the mixture's luminous flux), labelled with the pair's
    level-1 and level-2 class. A class with more than `max_pairs` pairs gets
    `max_pairs` of them drawn without replacement (seed `seed`, per class in
    sorted class order); a class with one lamp gets none.

    Why: a prior of k measured lamps can only say a new lamp is one of them
    (or a posterior average); a new lamp usually lies between them. With the
    test lamp itself in the prior the inversion's error on `make estimate`'s
    scenes drops to ~0 (0.04 lm/W, partition 0, fold 0, σ_rel 0.003), so the
    scene (surface, atmosphere, Moon) is not what limits it; the prior's
    coverage of lamp space is. Mixtures of two real lamps of one class are
    the sparse non-negative mixture of issue 12 in its two-component limit:
    their spectra, and so their LER, G and CCT, are physical by construction
    (a blend of two measured lamps of that type), and they are built from the
    prior's own lamps only, so they never carry a scored lamp. Ids
    `mix:<id_i>+<id_j>@<f>`."""
    fr = tuple(float(f) for f in fractions)
    if max_pairs < 0:
        raise ValueError(f"max_pairs must be >= 0 (got {max_pairs}).")
    if any(not (0.0 < f < 1.0) for f in fr):
        raise ValueError(f"mixture fractions must lie in (0, 1) (got {fr}).")
    rng = np.random.default_rng(seed)
    l2 = np.asarray(lamps.level2, dtype=object)
    ids, rows, level1, level2 = [], [], [], []
    for c in sorted(set(l2)):
        idx = np.flatnonzero(l2 == c)
        pairs = [(int(i), int(j)) for a, i in enumerate(idx) for j in idx[a + 1 :]]
        if len(pairs) > max_pairs:
            pick = np.sort(rng.choice(len(pairs), max_pairs, replace=False))
            pairs = [pairs[p] for p in pick]
        for i, j in pairs:
            for f in fr:
                ids.append(f"mix:{lamps.ids[i]}+{lamps.ids[j]}@{f:g}")
                rows.append((i, j, f))
                level1.append(lamps.level1[i])
                level2.append(c)
    if not rows:
        return LampSet((), np.zeros((0, lamps.spectra.shape[1])), (), ())
    i, j, f = (np.array(x) for x in zip(*rows, strict=True))
    spectra = f[:, None] * lamps.spectra[i] + (1 - f[:, None]) * lamps.spectra[j]
    return LampSet(tuple(ids), spectra, tuple(level1), tuple(level2))


PEAK_SHIFTS_NM = (-10.0, -7.5, -5.0, -2.5, 2.5, 5.0, 7.5, 10.0)
"""Wavelength shifts of direct-emission LEDs in a prior (`shifted_lamps`,
`fit_inversion(peak_shifts=)`): a semiconductor LED's emission band sits
where its composition puts it and moves with junction temperature, so a
new LED of a type usually has its band a few nm from every library LED's
(the library's 4 direct amber LEDs peak at 594-605 nm). ±10 nm in 2.5 nm
steps: a shifted copy then lies within 1.25 nm of any peak within 10 nm of
a training LED's; beyond that the prior does not reach (chosen, not fitted
to any score)."""

DIRECT_LED_MAX_FWHM_NM = 40.0
"""Widest single emission band (half-maximum width, visible part) that
`shifted_lamps` treats as a direct-emission LED. A semiconductor's band is
~15-30 nm wide in the visible (the library's direct amber LEDs: 13-20 nm);
phosphor bands are wider (the library's phosphor-converted amber LEDs:
79-109 nm), and their position is set by the phosphor, not shifted with a
junction, so they are not shifted."""


def direct_emitters(lamps: "LampSet", wavelength_nm) -> np.ndarray:
    """Indices of `lamps` whose visible spectrum is one emission band
    (`datasets.nir.is_single_band_emitter`) no wider than
    `DIRECT_LED_MAX_FWHM_NM` at half maximum: direct-emission LEDs."""
    # start-up time: scipy.signal adds ~0.4 s to the import
    from scipy.signal import peak_widths

    wl = np.asarray(wavelength_nm, float)
    vis = wl <= 780.0
    step = float(np.median(np.diff(wl[vis])))
    out = []
    for i, s in enumerate(lamps.spectra):
        sv = np.nan_to_num(s[vis])
        if not is_single_band_emitter(wl[vis], sv):
            continue
        pk = int(np.argmax(sv))
        width = peak_widths(sv, [pk], rel_height=0.5)[0][0] * step
        if width <= DIRECT_LED_MAX_FWHM_NM:
            out.append(i)
    return np.asarray(out, int)


def shifted_lamps(
    lamps: "LampSet", wavelength_nm, shifts: Sequence[float] = PEAK_SHIFTS_NM
) -> "LampSet":
    """Copies of the direct-emission LEDs of `lamps` (`direct_emitters`)
    with their spectrum moved by each of `shifts` [nm], `S'(λ) = S(λ - δ)`
    (linear interpolation; the edge value beyond the grid), renormalised to
    one lumen like the lamps (`bandopt.photometry.ler` times the radiant
    power 380-780 nm), labelled with the lamp's classes. Their LER, G and
    CCT are computed from the shifted spectra like any prior lamp's, so they
    are physical by construction. Ids `shift:<id>@<δ>nm`. Built from the
    prior's own lamps only, like `mixture_lamps`."""
    sh = tuple(float(x) for x in shifts)
    if any(x == 0 or not math.isfinite(x) for x in sh) or len(set(sh)) != len(sh):
        raise ValueError(f"peak shifts {sh}: need distinct finite non-zero values.")
    wl = np.asarray(wavelength_nm, float)
    idx = direct_emitters(lamps, wl) if sh else np.zeros(0, int)
    if idx.size == 0:
        return LampSet((), np.zeros((0, lamps.spectra.shape[1])), (), ())
    rows = np.array([np.interp(wl - d, wl, lamps.spectra[i]) for i in idx for d in sh])
    vis = wl <= 780.0
    lum = np.asarray(ler(rows, wl)) * np.trapezoid(rows[:, vis], wl[vis], axis=1)
    rows = rows / lum[:, None]
    ids = tuple(f"shift:{lamps.ids[i]}@{d:+g}nm" for i in idx for d in sh)
    l1 = tuple(lamps.level1[i] for i in idx for _ in sh)
    l2 = tuple(lamps.level2[i] for i in idx for _ in sh)
    return LampSet(ids, rows, l1, l2)


NIR_VARIANT_TAGS = ("nir-low", "nir-high")
"""Id prefixes of a lamp's NIR variants: its modelled 780-900 nm part scaled
by the low and high quantile of the extension's measured error
(`bandopt.datasets.nir.extension_error`)."""


def nir_variants(lamps: "LampSet", wavelength_nm) -> "LampSet":
    """Copies of the library lamps in `lamps` whose part beyond their
    measured range is modelled (`LampRecord.extended`), with that part (from
    max(measured end, 780 nm)) scaled by `1 + low` and `1 + high` of its
    class's measured extension error (5 % and 95 % quantiles, leave-one-out
    on lamps measured to 900 nm; wide stated bounds where none is
    validated), renormalised to one lumen. With the lamp itself (the model's
    central value) they span what the NIR model's validation says the truth
    may be, so a posterior over the prior does not rest on the modelled part
    alone: a pixel whose NIR is lower or higher than modelled still finds its
    lamp. Their visible part is the lamp's, so their LER, G and CCT are too.
    Ids `nir-low:<id>`, `nir-high:<id>`; `lamp_prior` splits a lamp's mass
    over it and its variants."""
    wl = np.asarray(wavelength_nm, float)
    recs = {r.id: r for r in library().records}
    rows, ids, l1, l2 = [], [], [], []
    vis = wl <= 780.0
    for i, lamp_id in enumerate(lamps.ids):
        rec = recs.get(lamp_id)
        if rec is None or not rec.extended:
            continue
        beyond = wl > max(float(rec.measured_range_nm[1]), 780.0)
        if not beyond.any():
            continue
        err = extension_error(rec.level2, technology_of(rec.level2, rec.level1))
        for tag, factor in zip(NIR_VARIANT_TAGS, (err.low, err.high), strict=True):
            row = np.array(lamps.spectra[i], float)
            row[beyond] *= max(1.0 + float(factor), 0.0)
            rows.append(row)
            ids.append(f"{tag}:{lamp_id}")
            l1.append(lamps.level1[i])
            l2.append(lamps.level2[i])
    if not rows:
        return LampSet((), np.zeros((0, lamps.spectra.shape[1])), (), ())
    out = np.array(rows)
    lum = np.asarray(ler(out, wl)) * np.trapezoid(out[:, vis], wl[vis], axis=1)
    return LampSet(tuple(ids), out / lum[:, None], tuple(l1), tuple(l2))


def planck_lamps(wavelength_nm) -> LampSet:
    """The library's modelled incandescent spectra (Planck's law,
    `datasets.lamps.MODELLED_INCANDESCENT_K`, per lumen; `Planck1901`), as
    prior lamps of level 1 `incandescent`, level 2 `incandescent_halogen`.

    Why: an incandescent lamp is a thermal radiator, so its family has
    physics no measured class carries: with these in every prior a halogen
    lamp is named `incandescent` even when no measured incandescent lamp
    trains (each class held out in turn, partition 0: level 1 0.0 -> 0.99).
    They are modelled spectra: they train, never score (no scene row belongs
    to them), and every result that uses them says so. Not fitted to any
    lamp, so they carry no scored lamp's information."""
    lib = library(wavelength_nm=np.asarray(wavelength_nm, float))
    keep = [
        i
        for i, r in enumerate(lib.records)
        if r.modelled and r.level1 == "incandescent"
    ]
    return _lamp_set(lib, keep)


def own_lamps(
    names: Sequence[str], values, source_nm, wavelength_nm, level2: Sequence[str]
) -> LampSet:
    """A user's measured lamp spectra as prior lamps: `values` (l, w) on
    `source_nm` (any scale) put on `wavelength_nm` the way the library puts
    its lamps on a grid (linear interpolation, then one lumen on that grid:
    `bandopt.photometry.ler` times the radiant power 380-780 nm), labelled
    with their level-2 classes `level2` (one of `LEVEL2`) and those classes'
    level-1 families. Ids `own:<name>`. They train, never score: the held-out
    scores are of library lamps, so what a lamp of yours in the prior buys
    is the library's in-library bound (`make estimate-library`)."""
    wl = np.asarray(wavelength_nm, float)
    src = np.asarray(source_nm, float)
    v = np.atleast_2d(np.asarray(values, float))
    names, level2 = tuple(names), tuple(level2)
    if not (len(names) == len(level2) == v.shape[0]):
        raise ValueError(
            f"own lamps: {len(names)} names, {len(level2)} classes and "
            f"{v.shape[0]} spectra; need one of each per lamp."
        )
    bad = [c for c in level2 if c not in LEVEL2]
    if bad:
        raise ValueError(
            f"own lamps: class {bad[0]!r} is not a level-2 class; choose from "
            f"{', '.join(LEVEL2)}."
        )
    if v.shape[1] != src.size:
        raise ValueError(
            f"own lamps: spectra have {v.shape[1]} values, the grid {src.size}."
        )
    rows = np.array([np.interp(wl, src, x) for x in v]).reshape(-1, wl.size)
    vis = wl <= 780.0
    lum = np.asarray(ler(rows, wl)) * np.trapezoid(rows[:, vis], wl[vis], axis=1)
    if rows.size and not np.all(np.isfinite(lum) & (lum > 0)):
        k = int(np.flatnonzero(~(np.isfinite(lum) & (lum > 0)))[0])
        raise ValueError(f"own lamps: {names[k]} emits no light in 380-780 nm.")
    return LampSet(
        tuple(f"own:{n}" for n in names),
        rows / lum[:, None] if rows.size else rows,
        tuple(LEVEL2_PARENT[c] for c in level2),
        level2,
    )


def tm30_lamps(wavelength_nm) -> LampSet:
    """The measured lamps of the IES TM-30-15 set (`IES2015`; `library(
    tm30=True)`, source set `ies_tm30`) that the library lacks, per lumen on a
    grid, as prior lamps: commercial and experimental lamps of every
    technology, classified and deduplicated by the library's own rules (a
    copy of a library lamp is removed, the library's kept), 380-780 nm
    measured and NIR-extended beyond like the NIST sets; coloured LEDs are
    left out (`excluded`).

    Why: the held-out error falls with the library's size (`make
    estimate-library`), and these are real measured lamps the scored library
    does not hold. They train, never score: no scene row belongs to them, so
    every committed result stays comparable."""
    lib = library(wavelength_nm=np.asarray(wavelength_nm, float), tm30=True)
    keep = [
        i
        for i, r in enumerate(lib.records)
        if r.source_set == "ies_tm30" and r.excluded is None and r.level2 is not None
    ]
    return _lamp_set(lib, keep)


def with_tm30_lamps(always: LampSet | None, grid, drop_class=None) -> LampSet:
    """`always` (None: no lamps) plus `tm30_lamps`, less those of level-2
    class `drop_class` (a class held out as unseen: measured lamps of it must
    not train)."""
    tm30 = tm30_lamps(grid)
    if drop_class is not None:
        tm30 = tm30.take([i for i, c in enumerate(tm30.level2) if c != drop_class])
    return tm30 if always is None else always + tm30


def with_planck_lamps(always: LampSet | None, grid) -> LampSet:
    """`always` (None: no lamps) plus `planck_lamps`."""
    planck = planck_lamps(grid)
    return planck if always is None else always + planck


def modelled_lamps(
    train_ids: Sequence[str],
    wavelength_nm,
    n_per_class: int,
    *,
    classes: Sequence[str] = MODELLED_CLASSES,
    seed: int = 0,
) -> tuple[LampSet, dict]:
    """Modelled lamps for one fit's prior: `n_per_class` spectra per level-2
    class in `classes` whose model is calibrated ONLY on the measured lamps
    among `train_ids` (`lampmodels.calibrate(c, train_ids)`), labelled with
    the class and its level-1 parent.

    A class with fewer than `MIN_CALIBRATION_LAMPS` measured lamps among
    `train_ids` gets none (listed in `skipped`). Spectra are sampled on the
    library grid (`lampmodels.sample_library`, seed `seed + 104729 j` for the
    j-th class of `classes`; near-infrared beyond the calibration lamps'
    measured range: the library's extension), then put on `wavelength_nm` the
    way the library puts measured lamps on a grid: linear interpolation, then
    one lumen on that grid (`lampmodels.per_lumen`, the library's
    `683 ∫ V S dλ = 1`). [W nm⁻¹ lm⁻¹]

    Returns the lamps (ids `model_<class>_<seed>_<j>`) and a record: lamps
    added per class, the calibration lamps per class, the skipped classes with
    their training-lamp count. Raises `RuntimeError` if a calibration used a
    lamp outside `train_ids` (never expected: a leak).

    **Cost.** `lampmodels.calibrate` fits every calibration lamp once per
    process (Levenberg-Marquardt, 4 starts, cached per lamp), so a
    cross-validation pays it once, whatever its folds. Measured on a 2-core
    machine busy with other runs (so up to ~2x slow): one fit takes 0.1-1 s
    (median 0.6-1 s for the LEDs), but the first fit of each family and
    padded observation count compiles (5-50 s; one metal-halide lamp 120 s).
    The 34 measured lamps of the five `MODELLED_CLASSES`: 350 s in one fresh
    process (LPS 25 s, mercury 13 s, amber LED 27 s, metal halide 214 s,
    HPS 71 s) and 630 s in a second, busier run (metal halide 470 s). All 184
    measured lamps with a model (the scored ones and LPS; with the white LEDs:
    97 warm 70 s, 53 cool 126 s): 823 s. Calibrating and sampling once
    fitted: < 0.1 s per class.
    """
    if n_per_class < 1:
        raise ValueError(f"n_per_class must be >= 1 (got {n_per_class}).")
    grid = np.asarray(wavelength_nm, float)
    lib = library()
    train = set(train_ids)
    ids, spectra, level1, level2 = [], [], [], []
    added, calibrated_on, skipped = {}, {}, {}
    for j, c in enumerate(classes):
        lampmodels.family_of(c)  # ValueError: no model for this class
        members = [
            r.id
            for r in lib.records
            if r.level2 == c and not r.modelled and r.excluded is None and r.id in train
        ]
        if len(members) < MIN_CALIBRATION_LAMPS:
            skipped[c] = len(members)
            continue
        cal = lampmodels.calibrate(c, list(train_ids))
        if not set(cal.lamps) <= train:
            raise RuntimeError(
                f"{c}: model calibrated on lamps outside the fit's training "
                f"lamps: {sorted(set(cal.lamps) - train)}."
            )
        out = lampmodels.sample_library(
            [c], n_per_class, seed + MODELLED_SEED_STRIDE * j, calibrations={c: cal}
        )
        if not all(r.modelled for r in out.records):
            raise RuntimeError("sample_library returned a lamp not marked modelled.")
        v = np.asarray(out.values, float)
        w = np.asarray(out.wavelength_nm, float)
        if w.shape != grid.shape or not np.allclose(w, grid):
            v = np.stack([np.interp(grid, w, row) for row in v])
            v = lampmodels.per_lumen(grid, v)
        if not np.all(np.isfinite(v)):
            raise RuntimeError(f"{c}: modelled spectra are not finite on the grid.")
        ids += [r.id for r in out.records]
        spectra.append(v)
        level1 += [r.level1 for r in out.records]
        level2 += [c] * len(out.records)
        added[c] = len(out.records)
        calibrated_on[c] = list(cal.lamps)
    lamps = LampSet(
        tuple(ids),
        np.vstack(spectra) if spectra else np.zeros((0, grid.size)),
        tuple(level1),
        tuple(level2),
    )
    info = {
        "n_per_class": int(n_per_class),
        "added": added,
        "calibration_lamps": calibrated_on,
        "skipped": skipped,
        "min_calibration_lamps": MIN_CALIBRATION_LAMPS,
        "seed": int(seed),
    }
    return lamps, info


CLOSE_CALL_RATIO = 0.5
"""A level-1 call is close when the second type is at least this fraction as
probable as the first (e.g. 0.6 against 0.3): the answer names both."""


def top_two(probabilities: dict) -> dict:
    """The two most probable types of `{type: probability}` (ties in the
    given order) and whether the call is close (`CLOSE_CALL_RATIO`): then
    both are answers a user should weigh."""
    order = sorted(probabilities, key=lambda k: -probabilities[k])[:2]
    pair = [{"type": k, "probability": float(probabilities[k])} for k in order]
    close = len(pair) == 2 and pair[1]["probability"] >= CLOSE_CALL_RATIO * max(
        pair[0]["probability"], 1e-300
    )
    return {"types": pair, "close": bool(close)}


@dataclasses.dataclass(frozen=True)
class InversionResult:
    """Per pixel: `estimate` (n, 3) [lm W⁻¹], [1], [K] (CCT NaN where not
    meaningful), `interval90` (n, 3, 2), `cct_probability` (P(CCT meaningful)),
    `unexplained` (n,), `misfit` (reduced χ², n), level-1/-2 probabilities
    with their labels, and the predicted types (None where unexplained)."""

    estimate: np.ndarray
    interval90: np.ndarray
    cct_probability: np.ndarray
    unexplained: np.ndarray
    misfit: np.ndarray
    level1_labels: tuple[str, ...]
    level1_probabilities: np.ndarray
    level2_labels: tuple[str, ...]
    level2_probabilities: np.ndarray
    level1: tuple[str | None, ...]
    level2: tuple[str | None, ...]
    testable: bool

    def row(self, i: int) -> dict:
        """JSON-ready result of pixel `i`: metrics null with a reason where they
        cannot be estimated, never outside `PHYSICAL_RANGE`."""
        est, reasons, iv = {}, {}, {}
        for m, name in enumerate(METRICS):
            v = float(self.estimate[i, m])
            lo, hi = (float(x) for x in self.interval90[i, m])
            if self.unexplained[i]:
                est[name], iv[name] = None, None
                reasons[name] = "unexplained: no lamp of the prior fits this pixel"
            elif not np.isfinite(v):
                est[name], iv[name] = None, None
                reasons[name] = (
                    "no meaningful CCT: the posterior favours lamps whose "
                    f"chromaticity is > 0.05 Duv off the Planckian locus "
                    f"(P(meaningful) = {self.cct_probability[i]:.2f})"
                )
            else:
                est[name], iv[name] = v, [lo, hi]
        return {
            "estimate": est,
            "interval90": iv,
            "null_reasons": reasons,
            "unexplained": bool(self.unexplained[i]),
            "misfit_reduced_chi2": float(self.misfit[i]),
            "level1_probabilities": {
                k: float(p)
                for k, p in zip(
                    self.level1_labels, self.level1_probabilities[i], strict=True
                )
            },
            "predicted_level1": self.level1[i],
            "predicted_level2": self.level2[i],
            "level1_top2": self.top2(i),
        }

    def top2(self, i: int) -> dict:
        """`top_two` of pixel `i`'s level-1 probabilities."""
        return top_two(
            dict(zip(self.level1_labels, self.level1_probabilities[i], strict=True))
        )


@dataclasses.dataclass(frozen=True)
class Inversion:
    """A fitted inversion for one band set (see the module docstring)."""

    prior: LampPrior
    basis: SurfaceBasis
    conditions: Conditions
    weights: np.ndarray
    design: tuple
    surface_mode: str
    sigma_rel: float
    conformal: np.ndarray
    threshold: float
    diagnostics: dict
    metric_sigma: tuple[float, ...] = ()
    sigma_floor: float = SIGMA_FLOOR
    metric_floor: tuple[float, ...] = ()
    interval_offset: tuple[float, ...] = ()
    level1_temperature: float = 1.0
    level2_temperature: float = 1.0
    temperature_slope: tuple[float, float] = (0.0, 0.0)
    flag_noise: tuple[float, float] | None = None

    @property
    def offsets(self) -> np.ndarray:
        """Offset added to each metric's posterior half-width before conformal
        scaling (3,), model space (`fit_inversion(interval_offsets=)`; zeros
        by default)."""
        return np.asarray(self.interval_offset or (0.0,) * 3, float)

    def with_interval_offset(self, fraction: float) -> "Inversion":
        """This inversion with the intervals of one candidate offset of its
        fit's `interval_offsets` (a fraction of each metric's spread) for all
        three metrics: same posterior and estimates, the conformal factors
        calibrated for that offset on the same held-out lamps."""
        cands = self.diagnostics.get("interval_candidates", {})
        key = f"{float(fraction):g}"
        if key not in cands:
            raise ValueError(
                f"interval offset {fraction!r}: this fit calibrated only "
                f"{sorted(cands, key=float)} (fit_inversion(interval_offsets=))."
            )
        c = cands[key]
        return dataclasses.replace(
            self,
            conformal=np.array([c["conformal"][m] for m in METRICS]),
            interval_offset=tuple(float(c["offset"][m]) for m in METRICS),
        )

    @property
    def metric_sigmas(self) -> tuple[float, float, float]:
        """`σ_rel` of each metric's estimate and interval (`METRICS` order):
        `metric_sigma` when set (`fit_inversion(sigma_rule="per-metric")`),
        else `sigma_rel` for all three."""
        if not self.metric_sigma:
            return (self.sigma_rel,) * 3
        return tuple(float(x) for x in self.metric_sigma)

    @property
    def metric_noise(self) -> tuple[tuple[float, float], ...]:
        """(`σ_rel`, floor) of each metric's estimate and interval."""
        floors = self.metric_floor or (self.sigma_floor,) * 3
        return tuple(
            (s, float(f)) for s, f in zip(self.metric_sigmas, floors, strict=True)
        )

    @property
    def n_bands(self) -> int:
        return int(self.weights.shape[0])

    def _dof(self) -> int:
        return self.n_bands - (1 if self.conditions.moon is None else 2)

    def candidates(self, n: int, surface=None):
        """Surface candidates `(n, s, r+1)` and their log prior `(n, s)`.

        `surface`: None (mode 'unknown'), a sequence of n type names (mode
        'class'), or basis coefficients (n, r) (mode 'measured')."""
        return surface_candidates(self.basis, self.surface_mode, n, surface)

    def posterior(
        self,
        radiance,
        surface=None,
        sigmas=None,
        *,
        evidence=False,
        moon=None,
        floors=None,
    ):
        """Posterior over prior lamps (n, k) and reduced χ² (n,); with `sigmas`
        (S,) one of each per `σ_rel`: (n, S, k), (n, S) (`floors`: the band-
        error floor of each, default `sigma_floor`). With `evidence`, also
        the log marginal likelihood of each pixel's mean-normalised band
        radiances under the prior, (n,) or (n, S) (`log_evidence`).

        `moon` (n,): the Moon's brightness when it is known (from the time and
        place of the acquisition), relative to the conditions' Moon state
        (`Conditions.moon`: 0 moonless, 1 that state); NaN where unknown.
        Known, it is not fitted. Default None: fitted for every pixel."""
        y = np.atleast_2d(np.asarray(radiance, float))
        cand, lps = self.candidates(y.shape[0], surface)
        a, q = self.design
        sig = [self.sigma_rel] if sigmas is None else list(sigmas)
        fl = np.broadcast_to(
            np.asarray(self.sigma_floor if floors is None else floors, float),
            (len(sig),),
        )
        noise = np.column_stack([np.asarray(sig, float), fl])
        lk, chi = _score(y, cand, lps, a, q, self.prior.log_prior, noise, moon)
        norm, post = (np.asarray(x) for x in _normalise(jnp.asarray(lk)))
        dof = np.full(y.shape[0], max(self._dof(), 1), float)
        if moon is not None:  # a known Moon amplitude is not a fitted parameter
            known = np.isfinite(np.asarray(moon, float))
            dof = np.where(known, max(self.n_bands - 1, 1), dof)
        red = chi / (dof[:, None] if chi.ndim == 2 else dof)
        out = (post, red)
        if evidence:
            out += (log_evidence(norm[..., 0], y, sig, fl),)
        return tuple(x[:, 0] for x in out) if sigmas is None else out

    def reconstruct(self, radiance, surface=None, moon=None) -> np.ndarray:
        """Posterior-mean lamp spectrum per lumen, (n, w) [W nm⁻¹ lm⁻¹]
        (`moon`: known Moon brightness per pixel, see `posterior`)."""
        post, _ = self.posterior(radiance, surface, moon=moon)
        return post @ self.prior.spectra

    def predict(self, radiance, surface=None, moon=None) -> InversionResult:
        """Invert band radiances (n, b) (any brightness; `moon`: known Moon
        brightness per pixel, see `posterior`). Types, misfit and flag come
        from the posterior at `sigma_rel`, each metric from the posterior at
        its own `metric_noise` (one scoring per distinct value)."""
        joint = (self.sigma_rel, self.sigma_floor)
        flag = self.flag_noise or joint
        noise = sorted({joint, flag, *self.metric_noise})
        if len(noise) == 1:
            post, misfit = self.posterior(radiance, surface, moon=moon)
            return _result(self, post, misfit)
        posts, misfits = self.posterior(
            radiance, surface, [n[0] for n in noise], moon=moon,
            floors=[n[1] for n in noise],
        )  # fmt: skip
        j = noise.index(joint)
        by_metric = [posts[:, noise.index(x)] for x in self.metric_noise]
        return _result(
            self, posts[:, j], misfits[:, j], by_metric, misfits[:, noise.index(flag)]
        )


def build_inversion(
    lamps: LampSet,
    weights,
    conditions: Conditions,
    basis: SurfaceBasis,
    surface_mode: str = "unknown",
    sigma_rel: float = 0.03,
    sigma_floor: float = SIGMA_FLOOR,
) -> Inversion:
    """An uncalibrated inversion with `lamps` as its prior (no conformal
    widening, no reject threshold): the building block of `fit_inversion`.
    Band error `σ_rel |y_b| + sigma_floor` (pixel mean |y| units)."""
    if not sigma_floor > 0:
        raise ValueError(f"sigma_floor must be > 0 (got {sigma_floor}).")
    if surface_mode not in SURFACE_MODES:
        raise ValueError(
            f"surface mode {surface_mode!r}: expected one of {SURFACE_MODES}."
        )
    weights = np.asarray(weights, float)
    grid = conditions.wavelength_nm
    if weights.shape[-1] != grid.size or basis.mean.size != grid.size:
        raise ValueError(
            f"band weights ({weights.shape[-1]}), surface basis ({basis.mean.size}) "
            f"and conditions ({grid.size}) must share one wavelength grid."
        )
    prior = lamp_prior(lamps.ids, lamps.spectra, lamps.level1, lamps.level2, grid)
    return Inversion(
        prior,
        basis,
        conditions,
        weights,
        _design(prior.spectra, weights, conditions, basis),
        surface_mode,
        float(sigma_rel),
        np.zeros(3),
        np.inf,
        {},
        sigma_floor=float(sigma_floor),
    )


def surface_candidates(basis: SurfaceBasis, mode: str, n: int, surface=None):
    if mode not in SURFACE_MODES:
        raise ValueError(f"surface mode {mode!r}: expected one of {SURFACE_MODES}.")
    r = basis.basis.shape[0]
    if mode == "unknown":
        c = np.broadcast_to(basis.type_coords, (n, *basis.type_coords.shape))
    elif mode == "class":
        if surface is None or len(surface) != n:
            raise ValueError("surface mode 'class' needs one surface type per pixel.")
        cache = {}
        for t in set(surface):
            cache[t] = basis.class_coords(t)
        c = np.stack([cache[t] for t in surface])
    else:
        coords = np.asarray(surface, float) if surface is not None else None
        if coords is None or coords.shape != (n, r):
            raise ValueError(
                "surface mode 'measured' needs basis coefficients (n, r) per pixel "
                "(see surface_from_sentinel2)."
            )
        c = coords[:, None, :]
    ones = np.ones((*c.shape[:2], 1))
    cand = np.concatenate([ones, c], axis=-1)
    return cand, np.full(cand.shape[:2], -np.log(cand.shape[1]))


def _metrics_per_posterior(posts, prior: LampPrior):
    """`_posterior_metrics` with each metric (`METRICS` order) taken from its
    own posterior `posts[m]` (n, k); P(CCT meaningful) from the CCT one.
    Posteriors that are the same object are summarised once."""
    done = {}
    for p in posts:
        if id(p) not in done:
            which = tuple(m for m, q in enumerate(posts) if q is p)
            done[id(p)] = _posterior_metrics(p, prior, which)
    mean = np.stack([done[id(p)][0][:, m] for m, p in enumerate(posts)], axis=1)
    rng = np.stack([done[id(p)][1][:, m] for m, p in enumerate(posts)], axis=1)
    return mean, rng, done[id(posts[2])][2]


def _widened(mean, rng, conformal, offset):
    """Posterior means clipped to the physical range and the 90 % interval
    `range ± conformal x (max(half-width, INTERVAL_FLOOR) + offset)`, clipped
    likewise and stretched to hold the mean; model space, (n, 3) each."""
    lo_b, hi_b = _model_bounds()
    unit = np.maximum((rng[..., 1] - rng[..., 0]) / 2, INTERVAL_FLOOR) + offset
    lo = np.clip(rng[..., 0] - conformal * unit, lo_b, hi_b)
    hi = np.clip(rng[..., 1] + conformal * unit, lo_b, hi_b)
    mean = np.clip(mean, lo_b, hi_b)
    return mean, np.minimum(lo, mean), np.maximum(hi, mean)


def _result(
    inv: Inversion, post, misfit, by_metric=None, flag_misfit=None
) -> InversionResult:
    """Estimates, intervals, flags and types of the posterior `post` (n, k);
    `by_metric`: one posterior per metric for the estimates and intervals
    (default: `post` for all three); `flag_misfit`: the misfit at
    `Inversion.flag_noise` that decides `unexplained` (default `misfit`)."""
    mean, rng, p_cct = _metrics_per_posterior(
        [post] * 3 if by_metric is None else by_metric, inv.prior
    )
    mean, lo, hi = _widened(mean, rng, inv.conformal, inv.offsets)
    est = mean.copy()
    est[:, 2] = np.where(p_cct >= 0.5, MIRED / mean[:, 2], np.nan)
    # mired interval [lo, hi] is CCT [MIRED/hi, MIRED/lo]
    iv = np.stack([lo, hi], axis=-1)
    iv[:, 2] = np.stack([MIRED / hi[:, 2], MIRED / lo[:, 2]], axis=-1)
    unexplained = (misfit if flag_misfit is None else flag_misfit) > inv.threshold
    l2 = sorted(set(inv.prior.level2))
    m2 = np.array([[x == c for c in l2] for x in inv.prior.level2], float)
    p2 = post @ m2
    parents = [LEVEL2_PARENT.get(c, c) for c in l2]
    l1 = [c for c in LEVEL1 if c in parents]
    p1 = p2 @ np.array([[p == c for c in l1] for p in parents], float)
    if inv.level1_temperature != 1.0 or inv.level2_temperature != 1.0:
        # calibrated (fit_inversion(calibrate_probabilities=True)): each
        # pixel's temperature grows with its misfit; tempering keeps each
        # row's order, so the predicted types do not change
        m = np.maximum(np.asarray(misfit, float), MISFIT_FLOOR)
        p1 = temper(p1, inv.level1_temperature * m ** inv.temperature_slope[0])
        p2 = temper(p2, inv.level2_temperature * m ** inv.temperature_slope[1])
    parent_idx = np.array([l1.index(p) for p in parents])
    i1 = np.argmax(p1, axis=1)
    inside = parent_idx[None, :] == i1[:, None]
    i2 = np.argmax(np.where(inside, p2, -1.0), axis=1)
    pred1 = [None if u else l1[a] for u, a in zip(unexplained, i1, strict=True)]
    pred2 = [
        None if u or l2[b] not in LEVEL2 else l2[b]
        for u, b in zip(unexplained, i2, strict=True)
    ]
    return InversionResult(
        est,
        iv,
        p_cct,
        unexplained,
        misfit,
        tuple(l1),
        p1,
        tuple(l2),
        p2,
        tuple(pred1),
        tuple(pred2),
        bool(np.isfinite(inv.threshold)),
    )


def _lamp_errors(pred_model, truth_model, valid, row_lamp, lamps):
    """Mean |error| per lamp over its rows in model space, (len(lamps), 3)."""
    out = np.full((len(lamps), 3), np.nan)
    for i, l in enumerate(lamps):
        rows = row_lamp == l
        e = np.abs(pred_model[rows] - truth_model[l][None]).mean(axis=0)
        out[i] = np.where(valid[l], e, np.nan)
    return out


def fit_inversion(
    radiance,
    row_lamp,
    lamps: LampSet,
    train_lamps,
    inner: Sequence[tuple[np.ndarray, np.ndarray]],
    weights,
    conditions: Conditions,
    *,
    basis: SurfaceBasis | None = None,
    surface_mode: str = "unknown",
    row_surface=None,
    always: LampSet | None = None,
    sigma_grid: Sequence[float] = SIGMA_REL_GRID,
    modelled_per_class: int = 0,
    modelled_classes: Sequence[str] = MODELLED_CLASSES,
    modelled_seed: int = 0,
    sigma_rule: str = "error",
    floor_grid: Sequence[float] = (SIGMA_FLOOR,),
    row_moon=None,
    calibration: str = "lamps",
    mixtures: int = 0,
    interval_offsets: Sequence[float] = (0.0,),
    peak_shifts: Sequence[float] = (),
    nir_error: bool = False,
    calibrate_probabilities: bool = False,
) -> Inversion:
    """Fit an inversion on `train_lamps` (indices into `lamps`).

    `radiance` (N, b) are simulated band radiances of labelled pixels whose lamp
    is `row_lamp` (N,) (index into `lamps`); `inner` are (train, validation)
    lamp splits of `train_lamps` on which `σ_rel`, the conformal factors and the
    unexplained threshold are chosen (never the lamps scored later).
    `row_surface`: per-pixel surface knowledge for modes 'class'/'measured'.
    `always`: lamps that are in every prior and never scored.

    `modelled_per_class` (default 0: measured lamps only): add that many
    modelled lamps per class of `modelled_classes` to every prior this fit
    builds (`modelled_lamps`, seed `modelled_seed`), each calibrated on the
    measured lamps of THAT prior only: the final prior on `train_lamps` plus
    `always`, each inner fold's prior on its own training lamps plus `always`
    (so the inner validation lamps that set `σ_rel`, the conformal factors
    and the threshold never shape a model either). Modelled lamps are never
    scored: no row of `radiance` belongs to them. `diagnostics
    ["modelled_lamps"]` records what the final prior holds.

    `sigma_rule` (`SIGMA_RULES`): how `σ_rel` is chosen on the inner folds,
    by held-out metric error (default), by held-out log evidence, or by
    held-out metric error per metric (`"per-metric"`: each metric's estimate,
    interval and conformal factor at its own `σ_rel`, `Inversion.
    metric_sigma`; types, misfit and the unexplained threshold at the
    `"error"` choice); `diagnostics` holds every criterion per candidate
    and `diagnostics["metric_sigma"]` each metric's `σ_rel`.

    `floor_grid` (default: `SIGMA_FLOOR` alone, as before): band-error floor
    candidates, chosen with `σ_rel` (every pair of the two grids; the inner
    scoring grows with their product) by the same rule; `sigma_floor` and
    `diagnostics["sigma_floor"]` / `["metric_floor"]` say which. With more
    than one floor the diagnostics' keys are `"σ/floor"`.

    `row_moon` (N,): the Moon's brightness per row when known (see
    `Inversion.posterior`), used on the inner folds; pass the test pixels'
    to `predict` too. Default None: fitted.

    `calibration` (`CALIBRATIONS`): the held-out lamps the conformal factors
    of the 90 % intervals are chosen on: the inner folds' (`"lamps"`,
    default) or each training class held out in turn (`"classes"`: one more
    prior per training class, at the chosen `σ_rel`, its rows scored once;
    class-balanced like the inner folds). `σ_rel` and the unexplained
    threshold come from the inner folds either way, so the point estimates
    and flags do not change; `diagnostics["calibration"]` says which.

    `mixtures` (default 0: none): every prior this fit builds also holds
    pairwise mixtures of its own measured lamps (`mixture_lamps`, at most
    `mixtures` pairs per class, seed `modelled_seed`): the final prior's of
    `train_lamps` and `always`, each inner fold's of its own training lamps
    and `always`. `diagnostics["mixtures"]` says how many.

    `interval_offsets` (default `(0.0,)`: the interval's unit is the
    posterior's half-width, as before; `INTERVAL_OFFSET_GRID` to choose):
    candidate offsets, as fractions of each metric's spread over
    `train_lamps`, added to the half-width before conformal scaling; each
    metric takes the candidate whose calibrated intervals are narrowest on
    the held-out calibration lamps (`_narrowest_intervals`; every candidate
    is calibrated to the same coverage there). `diagnostics
    ["interval_candidates"]` holds each candidate's factors and mean widths,
    so `Inversion.with_interval_offset` gives any candidate's intervals.

    `nir_error` (default False): every prior this fit builds also holds the
    NIR variants of its extended lamps (`nir_variants`), so the modelled
    780-900 nm part carries its measured error into every band that sees it.

    `calibrate_probabilities` (default False): the level-1 and level-2
    probabilities are temperature-scaled (`bandopt.calibration`) on held-out
    rows: the inner folds' (types the prior knows) and, with calibration
    "classes", the rows of each training class held out in turn (types it
    lacks), the two groups weighted equally, each class-balanced.
    `diagnostics["probabilities"]` gives the temperatures, the ECE before and
    after per group and the `unexplained` rate on both groups."""
    fracs = [float(x) for x in interval_offsets]
    if not fracs or min(fracs) < 0 or len(set(fracs)) != len(fracs):
        raise ValueError(
            f"interval_offsets {tuple(interval_offsets)}: need distinct values >= 0."
        )
    if calibration not in CALIBRATIONS:
        raise ValueError(
            f"calibration {calibration!r}: expected one of {CALIBRATIONS}."
        )
    if sigma_rule not in SIGMA_RULES:
        raise ValueError(f"sigma_rule {sigma_rule!r}: expected one of {SIGMA_RULES}.")
    if modelled_per_class < 0:
        raise ValueError(f"modelled_per_class must be >= 0 (got {modelled_per_class}).")
    radiance = np.asarray(radiance, float)
    row_lamp = np.asarray(row_lamp, int)
    weights = np.asarray(weights, float)
    grid = conditions.wavelength_nm
    basis = basis if basis is not None else surface_basis(grid)
    truth, valid = lamp_truth(lamps.spectra, grid)
    tm = _to_model(np.where(valid, truth, 1.0))
    l2 = np.asarray(lamps.level2, dtype=object)

    def modelled(train_idx) -> tuple[LampSet | None, dict]:
        if modelled_per_class == 0:
            return None, {"n_per_class": 0, "added": {}}
        ids = [lamps.ids[i] for i in np.asarray(train_idx, int)]
        ids += [] if always is None else list(always.ids)
        mset, info = modelled_lamps(
            ids,
            grid,
            modelled_per_class,
            classes=modelled_classes,
            seed=modelled_seed,
        )
        if not set(mset.ids).isdisjoint(lamps.ids):  # scored rows are lamps'
            raise RuntimeError("a modelled lamp id is also a scored lamp's id.")
        return mset, info

    if mixtures < 0:
        raise ValueError(f"mixtures must be >= 0 (got {mixtures}).")

    def make(prior_set: LampSet, noise, extra=None) -> Inversion:
        pset = prior_set if always is None else prior_set + always
        measured = pset
        if mixtures:
            pset = pset + mixture_lamps(measured, mixtures, seed=modelled_seed)
        if peak_shifts:
            pset = pset + shifted_lamps(measured, grid, peak_shifts)
        if nir_error:
            pset = pset + nir_variants(measured, grid)
        pset = pset if extra is None else pset + extra
        return build_inversion(
            pset, weights, conditions, basis, surface_mode, noise[0], noise[1]
        )

    def rows_of(lamp_idx):
        return np.flatnonzero(np.isin(row_lamp, lamp_idx))

    moon_rows = None if row_moon is None else np.asarray(row_moon, float)

    def moon_of(rows):
        return None if moon_rows is None else moon_rows[rows]

    def surf(rows):
        if row_surface is None:
            return None
        if isinstance(row_surface, np.ndarray) and row_surface.ndim == 2:
            return row_surface[rows]
        return [row_surface[i] for i in rows]

    # inner folds: choose σ_rel, collect calibration data
    spread = np.array(
        [
            np.sqrt(np.cov(tm[train_lamps][valid[train_lamps, m], m]))
            if valid[train_lamps, m].sum() > 1
            else 1.0
            for m in range(3)
        ]
    )
    if not floor_grid or min(floor_grid) <= 0:
        raise ValueError(f"floor_grid {tuple(floor_grid)}: needs values > 0.")
    grid_n = [(float(s), float(f)) for f in floor_grid for s in sigma_grid]
    scores = {s: [] for s in grid_n}
    scores_m = {s: [] for s in grid_n}  # per metric (3,)
    evid = {s: [] for s in grid_n}
    calib = {s: [] for s in grid_n}
    known_probs = {s: [] for s in grid_n}  # (rows, va, level-1, level-2 probs)
    scored_n = grid_n + ([] if FLAG_NOISE in grid_n else [FLAG_NOISE])
    flag_col = scored_n.index(FLAG_NOISE)
    flag_known = []  # (rows, va, misfit at FLAG_NOISE) per inner fold
    for tr, va in inner:
        rows = rows_of(va)
        inv = make(lamps.take(tr), grid_n[0], modelled(tr)[0])
        posts, misfits, lev = inv.posterior(
            radiance[rows],
            surf(rows),
            sigmas=[x[0] for x in scored_n],
            evidence=True,
            moon=moon_of(rows),
            floors=[x[1] for x in scored_n],
        )
        flag_known.append((rows, va, misfits[:, flag_col]))
        w = class_balanced_weights(l2[va])
        rl = row_lamp[rows]
        for j, s in enumerate(grid_n):
            post, misfit = posts[:, j], misfits[:, j]
            mean, rng, _ = _posterior_metrics(post, inv.prior)
            err = _lamp_errors(mean, tm, valid, rl, va)
            per_m = np.zeros(3)
            for m in range(3):
                ok = ~np.isnan(err[:, m])
                per_m[m] = (
                    np.sum(w[ok] * err[ok, m]) / max(w[ok].sum(), 1e-300) / spread[m]
                )
            scores[s].append(float(per_m.sum()))
            scores_m[s].append(per_m)
            # class-balanced mean over lamps of each lamp's mean log evidence
            per_lamp = np.array([lev[rl == lamp, j].mean() for lamp in va])
            evid[s].append(float(np.sum(w * per_lamp) / max(w.sum(), 1e-300)))
            calib[s].append((rows, mean, rng, misfit, va))
            if calibrate_probabilities:
                probs = _global_probabilities(post, inv.prior)
                flagm = misfits[:, flag_col]
                known_probs[s].append((rows, va, *probs, misfit, flagm))
    if sigma_rule == "evidence":
        best = max(grid_n, key=lambda s: float(np.mean(evid[s])))
    else:
        best = min(grid_n, key=lambda s: float(np.mean(scores[s])))
    per_metric = (best,) * 3
    if sigma_rule == "per-metric":
        per_metric = tuple(
            min(grid_n, key=lambda s: float(np.mean(scores_m[s], axis=0)[m]))
            for m in range(3)
        )
    # conformal factors and reject threshold from the held-out inner lamps
    held_out = _per_metric_held_out([calib[x] for x in per_metric])
    novel_probs = []  # the rows of each training class held out in turn
    if calibration == "classes":  # each training class held out in turn
        held_out = []
        sig = sorted({best, FLAG_NOISE, *per_metric})
        train_arr = np.asarray(train_lamps, int)
        for c in sorted(set(l2[train_arr])):
            va = train_arr[l2[train_arr] == c]
            tr = train_arr[l2[train_arr] != c]
            if tr.size == 0:
                continue
            rows = rows_of(va)
            inv = make(lamps.take(tr), best, modelled(tr)[0])
            posts, misfits = inv.posterior(
                radiance[rows],
                surf(rows),
                [x[0] for x in sig],
                moon=moon_of(rows),
                floors=[x[1] for x in sig],
            )
            mean, rng, _ = _metrics_per_posterior(
                [posts[:, sig.index(x)] for x in per_metric], inv.prior
            )
            held_out.append((rows, mean, rng, misfits[:, sig.index(best)], va))
            if calibrate_probabilities:
                novel_probs.append(
                    (
                        rows,
                        va,
                        *_global_probabilities(posts[:, sig.index(best)], inv.prior),
                        misfits[:, sig.index(best)],
                        misfits[:, sig.index(FLAG_NOISE)],
                    )
                )
    offs = np.array(fracs)[:, None] * spread[None]
    pick, confs, widths = _narrowest_intervals(held_out, row_lamp, l2, tm, valid, offs)
    conf, offset = confs[pick, np.arange(3)], offs[pick, np.arange(3)]
    mis_all, w_all = [], []
    for rows, va, misfit in flag_known:
        mis_all.append(misfit)
        w_all.append(_row_weights(rows, va, row_lamp, l2))
    mis_all, w_all = np.concatenate(mis_all), np.concatenate(w_all)
    dof = weights.shape[0] - (1 if conditions.moon is None else 2)
    thr = (
        float(weighted_quantile(mis_all, w_all[None], (UNEXPLAINED_QUANTILE,))[0, 0])
        if dof >= 1
        else np.inf
    )
    extra, extra_info = modelled(train_lamps)
    final = make(lamps.take(train_lamps), best, extra)
    temps, prob_diag = ((1.0, 0.0), (1.0, 0.0)), {"calibrated": False}
    if calibrate_probabilities:
        temps, prob_diag = _probability_temperatures(
            known_probs[best], novel_probs, thr, row_lamp, lamps, l2
        )

    def key(x) -> str:  # a σ alone when the floor is not chosen
        return str(x[0]) if len(floor_grid) == 1 else f"{x[0]:g}/{x[1]:g}"

    per = sigma_rule == "per-metric"
    return dataclasses.replace(
        final,
        conformal=conf,
        threshold=thr,
        metric_sigma=tuple(x[0] for x in per_metric) if per else (),
        metric_floor=tuple(x[1] for x in per_metric) if per else (),
        interval_offset=tuple(offset.tolist()),
        level1_temperature=float(temps[0][0]),
        level2_temperature=float(temps[1][0]),
        temperature_slope=(float(temps[0][1]), float(temps[1][1])),
        flag_noise=FLAG_NOISE,
        diagnostics={
            "probabilities": prob_diag,
            "nir_error": {
                "variants": bool(nir_error),
                "n": sum(variant_base(i) != i for i in final.prior.ids),
            },
            "sigma_rel": best[0],
            "sigma_floor": best[1],
            "floor_grid": [float(f) for f in floor_grid],
            "sigma_rule": sigma_rule,
            "metric_sigma": dict(zip(METRICS, [x[0] for x in per_metric], strict=True)),
            "metric_floor": dict(zip(METRICS, [x[1] for x in per_metric], strict=True)),
            "calibration": calibration,
            "moon": "fitted" if row_moon is None else "known per pixel",
            "inner_scores": {key(s): float(np.mean(v)) for s, v in scores.items()},
            "inner_scores_per_metric": {
                key(s): dict(zip(METRICS, np.mean(v, axis=0).tolist(), strict=True))
                for s, v in scores_m.items()
            },
            "inner_log_evidence": {key(s): float(np.mean(v)) for s, v in evid.items()},
            "conformal_factor": dict(zip(METRICS, conf.tolist(), strict=True)),
            "interval_offset": {m: fracs[pick[j]] for j, m in enumerate(METRICS)},
            "interval_candidates": {
                f"{f:g}": {
                    "offset": dict(zip(METRICS, offs[c].tolist(), strict=True)),
                    "conformal": dict(zip(METRICS, confs[c].tolist(), strict=True)),
                    "mean_width": dict(zip(METRICS, widths[c].tolist(), strict=True)),
                }
                for c, f in enumerate(fracs)
            },
            "unexplained_threshold_reduced_chi2": thr,
            "unexplained_band_error": dict(
                zip(("sigma_rel", "floor"), FLAG_NOISE, strict=True)
            ),
            "n_prior_lamps": len(final.prior.ids),
            "mixtures": {
                "max_pairs_per_class": int(mixtures),
                "fractions": list(MIX_FRACTIONS) if mixtures else [],
                "n": sum(i.startswith("mix:") for i in final.prior.ids),
            },
            "peak_shifts": {
                "shifts_nm": [float(x) for x in peak_shifts],
                "n": sum(i.startswith("shift:") for i in final.prior.ids),
            },
            "surface_mode": surface_mode,
            "modelled_lamps": {
                **extra_info,
                "ids": [] if extra is None else list(extra.ids),
                "calibrated_on": "the measured training lamps of this fit only "
                "(train_lamps and always; each inner fold's prior: its own "
                "training lamps and always); never scored",
            },
        },
    )


GLOBAL_LEVEL2 = tuple(dict.fromkeys((*LEVEL2, *LEVEL1)))
"""Level-2 columns of the calibration rows: every level-2 class, then the
level-1 names that stand for lamps without a level-2 class."""


def _global_probabilities(post, prior: LampPrior):
    """Level-1 (n, len(LEVEL1)) and level-2 (n, len(GLOBAL_LEVEL2))
    probabilities of posteriors `post` (n, k) on fixed columns, so rows from
    priors that lack some classes line up (a class the prior lacks: 0)."""
    m1 = np.array([[c == x for x in LEVEL1] for c in prior.level1], float)
    m2 = np.array([[c == x for x in GLOBAL_LEVEL2] for c in prior.level2], float)
    tot = np.sum(post, axis=1, keepdims=True)  # 1 to the scoring's precision
    post = post / np.where(tot > 0, tot, 1.0)
    return post @ m1, post @ m2


def _probability_temperatures(known, novel, thr, row_lamp, lamps, l2):
    """Misfit-dependent temperatures ((value, slope) for level 1 and level 2,
    `calibration.fit_temperature`) of the type probabilities, fitted on the
    held-out rows of known types `known` (inner folds, class-balanced), and
    the diagnostics: temperatures, then per group (`known` and `novel`, the
    rows of each training class held out in turn) the level-1 accuracy, ECE
    before/after and the `unexplained` rate at threshold `thr` (rows
    `(rows, lamps, level-1 probs, level-2 probs, misfit, misfit at
    FLAG_NOISE)`). A lamp of a type the prior lacks can never be named: its
    pixels are the `unexplained` flag's to catch, and fitting the temperature
    on them too made the answers on known types under-confident (level-1 ECE
    0.14 on held-out lamps, robustness suite at cc13a9a) without making
    those on new types trustworthy (0.38)."""
    groups = {"known_types": known, "left_out_types": novel}
    data = {}
    for name, items in groups.items():
        if not items:
            continue
        rows = np.concatenate([it[0] for it in items])
        w = np.concatenate([_row_weights(it[0], it[1], row_lamp, l2) for it in items])
        data[name] = (
            rows,
            w / w.sum(),
            np.vstack([it[2] for it in items]),
            np.vstack([it[3] for it in items]),
            np.concatenate([it[4] for it in items]),
            np.concatenate([it[5] for it in items]),
        )
    lab1 = np.array([LEVEL1.index(x) for x in lamps.level1])
    lab2 = np.array([GLOBAL_LEVEL2.index(x) for x in lamps.level2])
    rows, w, p1, p2, mis, _ = data["known_types"]
    fits = [
        fit_temperature(p, lab[row_lamp[rows]], w, mis)
        for p, lab in ((p1, lab1), (p2, lab2))
    ]
    diag = {
        "calibrated": True,
        "method": "temperature scaling fitted by the Brier score on held-out "
        "lamps of known types (bandopt.calibration)",
        "fitted_on": "known_types",
        "level1": fits[0].to_dict(),
        "level2": fits[1].to_dict(),
        "unexplained_false_flag_rate": 1.0 - UNEXPLAINED_QUANTILE,
        "groups": {},
    }
    for name, (r, wg, p1, _p2, m, m_flag) in data.items():
        right = p1.argmax(axis=1) == lab1[row_lamp[r]]
        flagged = m_flag > thr
        diag["groups"][name] = {
            "rows": int(r.size),
            "level1_right": float(np.sum(wg * right)),
            "ece_level1_before": expected_calibration_error(p1.max(axis=1), right, wg),
            "ece_level1_after": expected_calibration_error(
                temper(p1, fits[0].at(m)).max(axis=1), right, wg
            ),
            "unexplained_rate": float(np.sum(wg * flagged)),
        }
    return tuple((f.value, f.slope) for f in fits), diag


def _per_metric_held_out(per_metric_calib):
    """Held-out inner-fold data `(rows, mean, range, misfit, lamps)` per fold
    with metric m's columns from `per_metric_calib[m]` (the same folds scored
    at that metric's `σ_rel`); rows, misfit and lamps from the first."""
    out = []
    for folds in zip(*per_metric_calib, strict=True):
        rows, _, _, misfit, va = folds[0]
        mean = np.stack([f[1][:, m] for m, f in enumerate(folds)], axis=1)
        rng = np.stack([f[2][:, m] for m, f in enumerate(folds)], axis=1)
        out.append((rows, mean, rng, misfit, va))
    return out


def _row_weights(rows, va, row_lamp, l2) -> np.ndarray:
    """Weights of held-out rows: class-balanced over the held-out lamps `va`,
    each lamp's weight shared by its rows."""
    lamp_w = dict(zip(va, class_balanced_weights(l2[va]), strict=True))
    rl = row_lamp[rows]
    counts = {l: int((rl == l).sum()) for l in va}
    return np.array([lamp_w[l] / counts[l] for l in rl])


def _conformal_factors(held_out, row_lamp, l2, tm, valid, offset=0.0) -> np.ndarray:
    """Split-conformal factor per metric (3,): the `COVERAGE` weighted
    quantile over held-out rows of the distance of the true value outside the
    posterior 5-95 % range, in units of `max(half-width, INTERVAL_FLOOR) +
    offset` (`offset`: (3,) or scalar, model space; `held_out`: (rows, mean,
    range, misfit, lamps) per held-out set; rows class-balanced within a
    set)."""
    s_all, w_all = [], []
    for rows, _mean, rng, _misfit, va in held_out:
        rl = row_lamp[rows]
        half = np.maximum((rng[..., 1] - rng[..., 0]) / 2, INTERVAL_FLOOR) + offset
        y = tm[rl]
        score = np.maximum(rng[..., 0] - y, y - rng[..., 1]) / half
        s_all.append(np.where(valid[rl], score, np.nan))
        w_all.append(_row_weights(rows, va, row_lamp, l2))
    s_all, w_all = np.vstack(s_all), np.concatenate(w_all)
    conf = np.empty(3)
    for m in range(3):
        ok = ~np.isnan(s_all[:, m])
        conf[m] = max(
            float(weighted_quantile(s_all[ok, m], w_all[None, ok], (COVERAGE,))[0, 0]),
            0.0,
        )
    return conf


def _narrowest_intervals(held_out, row_lamp, l2, tm, valid, offsets):
    """Per metric, the candidate offset (`offsets` (C, 3), model space) whose
    conformal intervals are narrowest on the held-out rows at their
    calibrated coverage: the class-balanced mean width of the clipped
    intervals (`_widened`; ties: the first). Returns the chosen index per
    metric (3,), the conformal factors (C, 3) and the mean widths (C, 3)."""
    offsets = np.asarray(offsets, float)
    conf = np.array(
        [_conformal_factors(held_out, row_lamp, l2, tm, valid, o) for o in offsets]
    )
    width = np.zeros(offsets.shape)
    for c, o in enumerate(offsets):
        num, den = np.zeros(3), np.zeros(3)
        for rows, mean, rng, _misfit, va in held_out:
            _, lo, hi = _widened(mean, rng, conf[c], o)
            ok = valid[row_lamp[rows]]
            w = _row_weights(rows, va, row_lamp, l2)[:, None] * ok
            num += np.sum(w * np.where(ok, hi - lo, 0.0), axis=0)
            den += w.sum(axis=0)
        width[c] = num / np.maximum(den, 1e-300)
    return np.argmin(width, axis=0), conf, width


# ------------------------------------------------------------------------------
# Nested cross-validation on a search context (lamp-grouped, shared folds)


ESTIMATORS = ("inversion", "ridge", "kernel")
"""Estimators `cross_validate` and `bandopt evaluate` know (`cross_validate`
also `MODELLED_ESTIMATORS`)."""

MODELLED_ESTIMATORS = ("inversion+models", "ridge+models", "kernel+models")
"""`cross_validate` estimators that train on modelled lamps too: the inversion
with them in its prior, the ridge and kernel ridge with their scenes among
the training rows (`augment_with_modelled`)."""

MOON_ESTIMATOR = "inversion-moon"
"""`cross_validate` estimator: the inversion told each pixel's Moon brightness
(`context_moon`; known from the acquisition's time and place) instead of
fitting it."""

MOON_UNSEEN_ESTIMATOR = "inversion-moon-loco"
"""`cross_validate` estimator: `MOON_ESTIMATOR` with its 90 % intervals
calibrated on training classes held out in turn (leave one class out,
`fit_inversion(calibration="classes")`) instead of held-out lamps of known
classes: the same point estimates, intervals meant to hold for lamp types
the prior does not know."""

EVIDENCE_ESTIMATOR = "inversion-evidence"
"""`cross_validate` estimator: the inversion with `σ_rel` chosen by held-out
log evidence (`fit_inversion(sigma_rule="evidence")`) instead of metric error."""

MIX_ESTIMATOR = "inversion-moon-mix"
"""`cross_validate` estimator: `MOON_ESTIMATOR` with pairwise same-class
mixtures of its prior's lamps in every prior (`fit_inversion(mixtures=
MIX_PAIRS)`, `mixture_lamps`)."""

MIX_METRIC_ESTIMATOR = "inversion-moon-mix-metric"
"""`cross_validate` estimator: `MIX_ESTIMATOR` with each metric estimated
with its own band-error model, `σ_rel` and floor (`fit_inversion(
sigma_rule="per-metric", floor_grid=FLOOR_GRID)`)."""

NARROW_ESTIMATOR = "inversion-moon-mix-metric-narrow"
"""`cross_validate` estimator: `MIX_METRIC_ESTIMATOR` with each metric's
interval unit offset chosen for the narrowest calibrated intervals
(`fit_inversion(interval_offsets=INTERVAL_OFFSET_GRID)`): the same
estimates, other intervals. Asked for together with `MIX_METRIC_ESTIMATOR`,
both come from one fit (that one at offset 0, `Inversion.
with_interval_offset`)."""

SHIFT_ESTIMATOR = "inversion-moon-mix-metric-narrow-shift"
"""`NARROW_ESTIMATOR` with wavelength-shifted copies of the prior's
direct-emission LEDs in every prior (`fit_inversion(peak_shifts=
PEAK_SHIFTS_NM)`, `shifted_lamps`)."""

PLANCK_ESTIMATOR = "inversion-moon-mix-metric-narrow-planck"
"""`NARROW_ESTIMATOR` with the library's modelled incandescent spectra
(`planck_lamps`) in every prior, beside the never-scored measured lamps:
modelled spectra train, never score; its records say `modelled_in_prior`."""

DEFAULT_ESTIMATOR = "inversion-moon-mix-metric-narrow-shift-planck"
"""`NARROW_ESTIMATOR` with both `SHIFT_ESTIMATOR`'s shifted LEDs and
`PLANCK_ESTIMATOR`'s modelled incandescent spectra in every prior: what
`bandopt evaluate` does by default."""

TM30_ESTIMATOR = "inversion-moon-mix-metric-narrow-shift-planck-tm30"
"""`DEFAULT_ESTIMATOR` with the measured IES TM-30-15 lamps the library lacks
(`tm30_lamps`) in every prior, beside the never-scored measured lamps: they
train, never score; its records say `tm30_in_prior`."""

MODEL_NOISE_SEED_OFFSET = 15485863
"""Noise seed offset of modelled lamps' rows (a prime): with photon noise,
their draws never share a seed with the measured rows' draws."""


@dataclasses.dataclass(frozen=True)
class Augmented:
    """Training data of a learned estimator with modelled lamps added
    (`augment_with_modelled`): `radiance` (N + M, b) and `table` (measured
    rows and lamps first, unchanged, then the modelled ones), `train` the
    outer training lamps plus the modelled lamps calibrated on them, `inner`
    the inner (train, validation) splits, each train plus the modelled lamps
    calibrated on that inner training set (validation: measured lamps only),
    and `info` what was added (`modelled_per_class`,
    `modelled_classes_added`: level-2 class -> lamps of the outer set)."""

    radiance: np.ndarray
    table: LampTable
    train: np.ndarray
    inner: list
    info: dict


def augment_with_modelled(
    ctx,
    bands,
    radiance,
    train,
    inner,
    n_per_class: int,
    *,
    classes: Sequence[str] = MODELLED_CLASSES,
    seed: int = 0,
) -> Augmented:
    """Add modelled lamps to a learned estimator's training data (issue 11 b).

    For the outer training lamps `train` and for each inner split's training
    lamps, `n_per_class` modelled lamps per class of `classes`
    (`modelled_lamps`: calibrated on those measured lamps plus the
    never-scored `always` lamps, nothing else), lit by every scene of the
    context (`ScenarioSet.with_lamps`, same atmospheres, surfaces, Moon and
    classes) and measured with the same band set and noise rule
    (`Context.radiance_of`, own noise seeds). Each model set trains only the
    fit it was calibrated for; no modelled lamp is ever a validation or test
    lamp. `radiance` is `ctx.radiance(bands)` (the measured rows)."""
    lamps, always, _, _ = context_setup(ctx)
    scen = context_scenarios(ctx)
    grid = ctx.wavelength_nm
    base = ctx.table
    q = ctx.toa.shape[1]
    n0 = base.n_lamps
    rads, lamp_of = [np.asarray(radiance, float)], [np.asarray(base.lamp_of)]
    cls, truth, valid = [base.classes], [base.truth], [base.valid]
    added_info = {}

    def add(train_idx, j: int) -> np.ndarray:
        ids = [lamps.ids[i] for i in np.asarray(train_idx, int)] + list(always.ids)
        mset, info = modelled_lamps(ids, grid, n_per_class, classes=classes, seed=seed)
        if j == 0:
            added_info.update(info)
        m = len(mset.ids)
        if m == 0:
            return np.zeros(0, int)
        toa = np.asarray(dense_spectra(scen.with_lamps(mset.ids, mset.spectra)))
        toa = toa.reshape(m, -1, toa.shape[-1])
        if toa.shape[1] != q:
            raise RuntimeError(
                f"modelled lamps' scenes: {toa.shape[1]} per lamp, context {q}."
            )
        start = n0 + sum(len(c) for c in cls[1:])
        rads.append(
            ctx.radiance_of(toa, bands, seed=seed + MODEL_NOISE_SEED_OFFSET * (j + 1))
        )
        lamp_of.append(start + np.repeat(np.arange(m), q))
        cls.append(np.asarray(mset.level2, dtype=object))
        t, v = lamp_truth(mset.spectra, grid)
        truth.append(np.asarray(t))
        valid.append(np.asarray(v))
        return start + np.arange(m)

    train = np.asarray(train, int)
    new_train = np.concatenate([train, add(train, 0)])
    new_inner = [
        (np.concatenate([np.asarray(tr, int), add(tr, j + 1)]), np.asarray(va, int))
        for j, (tr, va) in enumerate(inner)
    ]
    table = LampTable(
        np.concatenate(lamp_of),
        np.concatenate(cls),
        np.vstack(truth),
        np.vstack(valid),
    )
    return Augmented(
        np.vstack(rads),
        table,
        new_train,
        new_inner,
        {
            "modelled_per_class": int(n_per_class),
            "modelled_classes_added": dict(added_info.get("added", {})),
        },
    )


def fit_for_context(
    ctx,
    bands,
    radiance,
    train,
    inner,
    *,
    surface_mode="unknown",
    sigma_grid: Sequence[float] = SIGMA_REL_GRID,
    modelled_per_class: int = 0,
    modelled_classes: Sequence[str] = MODELLED_CLASSES,
    modelled_seed: int = 0,
):
    """`fit_inversion` on a `search.Context`'s scenes for one band set (surface
    knowledge 'unknown' or 'class' — the per-row types come from the context;
    `sigma_grid` one value: `σ_rel` fixed; `modelled_*`: modelled lamps in the
    prior, default none, see `fit_inversion`)."""
    lamps, always, cond, row_types = context_setup(ctx)
    grid = ctx.wavelength_nm
    w = band_weights_on(bands, grid)
    return fit_inversion(
        radiance,
        ctx.table.lamp_of,
        lamps,
        np.asarray(train),
        list(inner),
        w,
        cond,
        basis=_basis(grid),
        surface_mode=surface_mode,
        row_surface=row_types if surface_mode == "class" else None,
        always=always,
        sigma_grid=sigma_grid,
        modelled_per_class=modelled_per_class,
        modelled_classes=modelled_classes,
        modelled_seed=modelled_seed,
    )


_BASIS_CACHE: dict = {}


def _basis(grid) -> "SurfaceBasis":
    key = (float(grid[0]), float(grid[-1]), len(grid))
    if key not in _BASIS_CACHE:
        _BASIS_CACHE[key] = surface_basis(grid)
    return _BASIS_CACHE[key]


_SETUP_CACHE: dict = {}


def context_setup(ctx):
    """Lamps, always-in-prior lamps, conditions and per-row surface types of a
    `search.Context` (its scenes are surface x atmosphere x Moon x class);
    cached per context object."""
    return _cached_setup(ctx)[:4]


def context_moon(ctx) -> np.ndarray:
    """The Moon's brightness in each row of a `search.Context`, relative to the
    inversion's Moon state (`Conditions.from_scenarios`: the brightest), (N,):
    0 moonless, 1 that state, else the ratio of the states' moonlit-ground
    irradiance (same shape assumed; exact for none/full). What an analyst
    knows from the acquisition's time and place."""
    scen = context_scenarios(ctx)
    q = ctx.toa.shape[1]
    amp = moon_amplitudes(scen)
    n_c = len(scen.class_labels)
    per_scene = amp[(np.arange(q) // n_c) % amp.size]
    return np.tile(per_scene, ctx.table.n_lamps)


def moon_amplitudes(scen) -> np.ndarray:
    """The Moon's brightness in each Moon state of a `scene.ScenarioSet`
    (`scen.moon_labels` order), relative to its brightest state (the one
    `Conditions.from_scenarios` holds): moonlit-ground irradiance summed over
    atmospheres and wavelengths, over that of the brightest state; 0 for a
    moonless state, all 0 when no state has a Moon. (m,) [1]"""
    f = scen.factors
    if f.moon_ground is None:
        return np.zeros(max(len(scen.moon_labels), 1))
    tot = np.asarray(f.moon_ground).sum(axis=(0, 2))  # (a, m, w) -> (m,)
    return tot / tot.max() if tot.max() > 0 else np.zeros_like(tot)


def context_scenarios(ctx):
    """The `scene.ScenarioSet` of a `search.Context`'s scenes, lit by its first
    lamp (`ScenarioSet.with_lamps` lights them with others); cached."""
    return _cached_setup(ctx)[4]


def _cached_setup(ctx):
    key = id(ctx)
    hit = _SETUP_CACHE.get(key)
    if hit is not None and hit[0] is ctx:
        return hit[1]
    out = _context_setup(ctx)
    _SETUP_CACHE[key] = (ctx, out)
    return out


def _context_setup(ctx):
    grid = ctx.wavelength_nm
    lamps = library_lamps(grid, scored=True)
    if lamps.ids != tuple(ctx.lamp_ids):
        raise RuntimeError("context lamps and library scored lamps differ")
    always = library_lamps(grid, scored=False)
    sc = ctx.config["scenarios"]
    atms = [a if isinstance(a, str) else tuple(a) for a in sc["atmospheres"]]
    scen = build_scenarios(
        lamps=[lamps.ids[0]],
        surfaces=sc["surfaces"],
        atmospheres=atms,
        moons=tuple(sc["moons"]),
        classes=tuple(sc["classes"]),
        wavelength_nm=grid,
    )
    per_surface = ctx.toa.shape[1] // len(sc["surfaces"])
    q = np.arange(ctx.toa.shape[1]) // per_surface
    row_types = [sc["surfaces"][i] for i in np.tile(q, ctx.table.n_lamps)]
    return lamps, always, Conditions.from_scenarios(scen), row_types, scen


def band_weights_on(bands, wavelength_nm) -> np.ndarray:
    """Band-averaging weights `(b, w)` of a band set on a grid: those of the
    forward model (`forward.band_weights_on`), as a NumPy array."""
    return np.asarray(forward_band_weights(bands, np.asarray(wavelength_nm, float)))


def _surface_knowledge(row_types, basis: SurfaceBasis, seed: int) -> dict:
    """Per-row surface input of each mode (the Sentinel-2 draw only when asked)."""

    class _Lazy(dict):
        def __missing__(self, key):
            if key != "measured":
                raise KeyError(key)
            self[key] = measured_surfaces(row_types, basis, seed=seed)
            return self[key]

    return _Lazy(unknown=None, **{"class": row_types})


def measured_surfaces(row_types, basis: SurfaceBasis, *, seed: int = 0):
    """Per-row surface coefficients from a simulated daytime Sentinel-2
    measurement of each row's true (type-mean) surface, (N, r)."""
    types = sorted(set(row_types))
    _, refl = surf_mod.mean_reflectance(types, basis.wavelength_nm)
    idx = np.array([types.index(t) for t in row_types])
    obs = observe_sentinel2(refl[idx], basis.wavelength_nm, seed=seed)
    return surface_from_sentinel2(obs, basis)


def _smaller_library(split, level2, fraction: float, seed: int, fold: int):
    """`split` (an outer fold) with `fraction` of its training lamps of each
    level-2 class in `level2` (at least one), drawn with seed `(seed, fold)`,
    and its inner folds restricted to them (an inner fold left without
    training or validation lamps is dropped). Its test lamps are unchanged."""
    rng = np.random.default_rng([seed, fold, 7919])
    train = np.asarray(split.train)
    cls = np.asarray(level2, object)[train]
    keep = []
    for c in sorted(set(cls)):
        ids = train[cls == c]
        n = max(1, round(fraction * ids.size))
        keep += rng.choice(ids, size=n, replace=False).tolist()
    kept = np.sort(np.asarray(keep, train.dtype))
    inner = tuple(
        (tr[np.isin(tr, kept)], va[np.isin(va, kept)])
        for tr, va in (tuple(np.asarray(x) for x in pair) for pair in split.inner)
    )
    inner = tuple((tr, va) for tr, va in inner if tr.size and va.size)
    if not inner:
        raise ValueError(
            f"train_fraction {fraction}: outer fold {fold} keeps no inner fold."
        )
    return dataclasses.replace(split, train=kept, inner=inner)


def cross_validate(
    ctx,
    bands,
    *,
    estimators: Sequence[str] = ESTIMATORS,
    surface_modes: Sequence[str] = ("unknown",),
    folds: Sequence[int] | None = None,
    seed: int = 0,
    modelled_per_class: int = 0,
    modelled_classes: Sequence[str] = MODELLED_CLASSES,
    scored: str = "test",
    train_fraction: float = 1.0,
) -> list[dict]:
    """Score estimators on the context's outer folds (lamp-grouped, the same
    folds for every estimator). One record per (estimator, surface mode, outer
    fold, test lamp) with the lamp's mean |error| per metric (CCT in K and in
    mired), interval coverage, level-1 correctness and unexplained rate
    (inversion only) and the number of rows whose estimate left the physical
    range (must be 0).

    Estimators `MODELLED_ESTIMATORS` (only with `modelled_per_class` > 0)
    train on `modelled_per_class` modelled lamps per class of
    `modelled_classes` too, calibrated on each outer fold's (and inner
    fold's) measured training lamps only, seed `seed`: "inversion+models"
    holds them in its prior (`fit_inversion`), "ridge+models" and
    "kernel+models" have their scenes among the training rows
    (`augment_with_modelled`; hyper-parameters chosen on inner folds whose
    validation lamps are measured). Test lamps are measured lamps only,
    whatever the estimator. With `modelled_per_class` > 0 every record says
    how many modelled lamps per class its estimator trained on
    (`modelled_per_class`: N for a `MODELLED_ESTIMATORS` row, 0 otherwise)
    and those rows list the classes that got them in that fold
    (`modelled_classes_added`); with the default 0 the records are as
    before (no such keys).

    `scored`: "test" (default: the outer fold's held-out lamps) or "train"
    (its training lamps, which are in the prior: how well the estimator does
    on a lamp the library holds, the in-library bound of a held-out score;
    records then say `"scored": "train"`, and the never-scored check, which
    would refuse them, is not made).

    `train_fraction` < 1: each outer fold trains on that fraction of its
    training lamps of each level-2 class (at least one; seeded by `seed` and
    the fold), its inner folds on their share of them: a smaller library, to
    see how the held-out error falls with the library's size (the
    always-in-prior lamps stay; records then say `train_fraction` and
    `train_lamps`). Default 1: all, no such keys."""
    scored = validate_method(scored, ("test", "train"), "scored")
    if not 0.0 < train_fraction <= 1.0:
        raise ValueError(f"train_fraction {train_fraction}: must be in (0, 1].")
    bad = [e for e in estimators if e in MODELLED_ESTIMATORS]
    if bad and modelled_per_class < 1:
        raise ValueError(
            f"estimators {bad} need modelled_per_class >= 1 (got {modelled_per_class})."
        )
    lamps, always, cond, row_types = context_setup(ctx)
    grid = ctx.wavelength_nm
    rad = ctx.radiance(bands)
    w = band_weights_on(bands, grid)
    row_lamp = np.asarray(ctx.table.lamp_of)
    truth, valid = ctx.table.truth, ctx.table.valid
    basis = _basis(grid)
    surf_in = _surface_knowledge(row_types, basis, seed)
    out = []
    folds = range(len(ctx.splits)) if folds is None else folds
    augmented: dict = {}  # per outer fold, shared by ridge+models and kernel+models
    # what records list of their priors: once, not per record
    planck_ids = planck_lamps(grid).ids
    n_tm30 = len(tm30_lamps(grid).ids) if TM30_ESTIMATOR in estimators else 0
    for k in folds:
        s = ctx.splits[k]
        if train_fraction < 1.0:
            s = _smaller_library(s, lamps.level2, train_fraction, seed, k)
        inner = list(s.inner)
        score_ids = s.test if scored == "test" else s.train
        rows = np.flatnonzero(np.isin(row_lamp, score_ids))
        preds, model_info = {}, {}
        for name in estimators:
            if name in (
                "inversion",
                "inversion+models",
                EVIDENCE_ESTIMATOR,
                MOON_ESTIMATOR,
                MOON_UNSEEN_ESTIMATOR,
                MIX_ESTIMATOR,
                MIX_METRIC_ESTIMATOR,
                NARROW_ESTIMATOR,
                SHIFT_ESTIMATOR,
                PLANCK_ESTIMATOR,
                DEFAULT_ESTIMATOR,
                TM30_ESTIMATOR,
            ):
                narrow = name in (
                    NARROW_ESTIMATOR,
                    SHIFT_ESTIMATOR,
                    PLANCK_ESTIMATOR,
                    DEFAULT_ESTIMATOR,
                    TM30_ESTIMATOR,
                )
                planck = name in (PLANCK_ESTIMATOR, DEFAULT_ESTIMATOR, TM30_ESTIMATOR)
                shift = name in (SHIFT_ESTIMATOR, DEFAULT_ESTIMATOR, TM30_ESTIMATOR)
                if name == MIX_METRIC_ESTIMATOR and NARROW_ESTIMATOR in estimators:
                    continue  # scored from the narrow fit at offset 0
                per = narrow or name == MIX_METRIC_ESTIMATOR
                mix = per or name == MIX_ESTIMATOR
                told = mix or name in (MOON_ESTIMATOR, MOON_UNSEEN_ESTIMATOR)
                moon_rows = context_moon(ctx) if told else None
                n_model = modelled_per_class if name == "inversion+models" else 0
                prior_always = with_planck_lamps(always, grid) if planck else always
                for mode in surface_modes:
                    si = surf_in[mode]
                    inv = fit_inversion(
                        rad,
                        row_lamp,
                        lamps,
                        s.train,
                        inner,
                        w,
                        cond,
                        basis=basis,
                        surface_mode=mode,
                        row_surface=si,
                        always=(
                            with_tm30_lamps(prior_always, grid)
                            if name == TM30_ESTIMATOR
                            else prior_always
                        ),
                        modelled_per_class=n_model,
                        modelled_classes=modelled_classes,
                        modelled_seed=seed,
                        sigma_rule=(
                            "per-metric"
                            if per
                            else "evidence"
                            if name == EVIDENCE_ESTIMATOR
                            else "error"
                        ),
                        row_moon=moon_rows,
                        calibration=(
                            "classes" if name == MOON_UNSEEN_ESTIMATOR else "lamps"
                        ),
                        mixtures=MIX_PAIRS if mix else 0,
                        floor_grid=FLOOR_GRID if per else (SIGMA_FLOOR,),
                        interval_offsets=INTERVAL_OFFSET_GRID if narrow else (0.0,),
                        peak_shifts=PEAK_SHIFTS_NM if shift else (),
                    )
                    sub = (
                        None
                        if si is None
                        else (
                            si[rows]
                            if isinstance(si, np.ndarray)
                            else [si[i] for i in rows]
                        )
                    )
                    moon_sub = None if moon_rows is None else moon_rows[rows]
                    preds[(name, mode)] = (inv.predict(rad[rows], sub, moon_sub), inv)
                    if name == NARROW_ESTIMATOR and MIX_METRIC_ESTIMATOR in estimators:
                        base = inv.with_interval_offset(0.0)
                        preds[(MIX_METRIC_ESTIMATOR, mode)] = (
                            base.predict(rad[rows], sub, moon_sub),
                            base,
                        )
            elif name == "ridge":
                est = fit_estimator(rad, ctx.table, s.train, inner)
                preds[("ridge", "unknown")] = (np.asarray(est.predict(rad[rows])), None)
            elif name == "kernel":
                est = fit_kernel_estimator(rad, ctx.table, s.train, inner, seed=seed)
                preds[("kernel", "unknown")] = (
                    np.asarray(est.predict(rad[rows])),
                    None,
                )
            elif name in ("ridge+models", "kernel+models"):
                if k not in augmented:
                    augmented[k] = augment_with_modelled(
                        ctx,
                        bands,
                        rad,
                        s.train,
                        inner,
                        modelled_per_class,
                        classes=modelled_classes,
                        seed=seed,
                    )
                aug = augmented[k]
                if np.isin(s.test, aug.train).any() or any(
                    np.isin(s.test, tr).any() for tr, _ in aug.inner
                ):
                    raise RuntimeError("a test lamp is among the training lamps.")
                est = (
                    fit_estimator(aug.radiance, aug.table, aug.train, aug.inner)
                    if name == "ridge+models"
                    else fit_kernel_estimator(
                        aug.radiance, aug.table, aug.train, aug.inner, seed=seed
                    )
                )
                preds[(name, "unknown")] = (np.asarray(est.predict(rad[rows])), None)
                model_info[name] = aug.info
            else:
                raise ValueError(
                    f"estimator {name!r}: expected one of "
                    f"{(*ESTIMATORS, *MODELLED_ESTIMATORS)} or "
                    f"{(EVIDENCE_ESTIMATOR, MOON_ESTIMATOR, MOON_UNSEEN_ESTIMATOR)}"
                    f" or {(MIX_ESTIMATOR, MIX_METRIC_ESTIMATOR, NARROW_ESTIMATOR)}"
                    f" or {(SHIFT_ESTIMATOR, PLANCK_ESTIMATOR, DEFAULT_ESTIMATOR)}."
                )
        for (name, mode), (p, inv) in preds.items():
            res = p if isinstance(p, InversionResult) else None
            est = res.estimate if res is not None else p
            if inv is not None and scored == "test":
                _check_never_scored(inv, [lamps.ids[i] for i in s.test])
            for lamp in score_ids:
                sel = row_lamp[rows] == lamp
                e = est[sel]
                t = truth[lamp]
                rec = {
                    "estimator": name,
                    "surface": mode,
                    "fold": int(k),
                    "lamp": lamps.ids[lamp],
                    "level1": lamps.level1[lamp],
                    "level2": lamps.level2[lamp],
                    "rows": int(sel.sum()),
                    "out_of_range": int(_out_of_range(e)),
                }
                if scored == "train":
                    rec["scored"] = "train"
                if train_fraction < 1.0:
                    rec["train_fraction"] = float(train_fraction)
                    rec["train_lamps"] = len(s.train)
                rec.update(record_errors(e, t, valid[lamp]))
                if res is not None:
                    rec.update(_interval_fields(res.interval90[sel], t, valid[lamp]))
                    l1 = np.array(res.level1, dtype=object)[sel]
                    rec["level1_correct"] = float(np.mean(l1 == lamps.level1[lamp]))
                    l2p = np.array(res.level2, dtype=object)[sel]
                    rec["level2_correct"] = float(np.mean(l2p == lamps.level2[lamp]))
                    rec["unexplained"] = float(np.mean(res.unexplained[sel]))
                    rec["sigma_rel"] = inv.sigma_rel
                    if inv.metric_sigma:
                        rec["metric_noise"] = [list(x) for x in inv.metric_noise]
                    if name in (PLANCK_ESTIMATOR, DEFAULT_ESTIMATOR, TM30_ESTIMATOR):
                        rec["modelled_in_prior"] = list(planck_ids)
                    if name == TM30_ESTIMATOR:
                        rec["tm30_in_prior"] = n_tm30
                if modelled_per_class > 0:
                    rec.update(model_info.get(name) or _modelled_fields(inv))
                out.append(rec)
    return out


def record_errors(est, truth, valid) -> dict:
    """A record's error fields for one lamp: its pixels' estimates `est`
    (n, 3) in `METRICS` order against its `truth` (3,); the mean |error| per
    metric (None where `valid` says the truth has no meaning), CCT also in
    mired, a null CCT estimate counting as the range's far end
    (`CCT_RANGE_K`), and the rate of null CCTs."""
    rec: dict = {}
    for m, name in enumerate(METRICS):
        if not valid[m]:
            rec[name] = None
            continue
        v = est[:, m]
        if name == "CCT":
            # a null CCT (not meaningful) counts as the range's far end
            vv = np.where(np.isfinite(v), v, CCT_RANGE_K[1])
            rec["CCT"] = float(np.mean(np.abs(vv - truth[m])))
            rec["CCT_mired"] = float(np.mean(np.abs(MIRED / vv - MIRED / truth[m])))
            rec["CCT_null_rate"] = float(np.mean(~np.isfinite(v)))
        else:
            rec[name] = float(np.mean(np.abs(v - truth[m])))
    return rec


def _interval_fields(iv, truth, valid) -> dict:
    """Per valid metric of one lamp: the fraction of its pixels whose 90 %
    interval `iv` (n, 3, 2) holds the true value (`{m}_covered`) and the
    intervals' mean width (`{m}_width`: lm/W, 1, K; CCT also in mired,
    `CCT_width_mired`)."""
    out = {}
    for m, name in enumerate(METRICS):
        if not valid[m]:
            continue
        lo, hi = iv[:, m, 0], iv[:, m, 1]
        out[f"{name}_covered"] = float(np.mean((lo <= truth[m]) & (truth[m] <= hi)))
        out[f"{name}_width"] = float(np.mean(hi - lo))
        if name == "CCT":
            out["CCT_width_mired"] = float(np.mean(MIRED / lo - MIRED / hi))
    return out


def _modelled_fields(inv) -> dict:
    """What a record says about modelled lamps in its estimator's prior."""
    info = {} if inv is None else inv.diagnostics.get("modelled_lamps", {})
    n = int(info.get("n_per_class", 0))
    out = {"modelled_per_class": n}
    if n:
        out["modelled_classes_added"] = dict(info["added"])
    return out


def _check_never_scored(inv, test_ids) -> None:
    """Modelled lamps and mixtures train, never score: none is a test lamp,
    no mixture is made of one (a bug, not a user error)."""
    modelled = set(inv.diagnostics.get("modelled_lamps", {}).get("ids", ()))
    if modelled & set(test_ids):
        raise RuntimeError(
            f"modelled lamps among the scored lamps: {sorted(modelled & set(test_ids))}"
        )
    parts = {
        p
        for i in inv.prior.ids
        if i.startswith("mix:")
        for p in i[4:].rsplit("@", 1)[0].split("+")
    }
    if parts & set(test_ids):
        raise RuntimeError(
            f"mixtures of scored lamps in the prior: {sorted(parts & set(test_ids))}"
        )
    shifted = {i[6:].rsplit("@", 1)[0] for i in inv.prior.ids if i.startswith("shift:")}
    if shifted & set(test_ids):
        raise RuntimeError(
            f"shifted copies of scored lamps in the prior: "
            f"{sorted(shifted & set(test_ids))}"
        )


def _out_of_range(est) -> int:
    """Rows with an estimate outside `PHYSICAL_RANGE` (NaN CCT is a null)."""
    bad = np.zeros(est.shape[0], bool)
    for m, name in enumerate(METRICS):
        lo, hi = PHYSICAL_RANGE[name]
        v = est[:, m]
        fin = np.isfinite(v)
        bad |= fin & ((v < lo - 1e-9) | (v > hi + 1e-9))
        if name != "CCT":
            bad |= ~fin
    return int(bad.sum())


# ------------------------------------------------------------------------------
# Summaries of cross-validation records


def _cb_mean(values, classes) -> float:
    """Class-balanced mean (each class the same weight) of per-lamp values."""
    v = np.asarray(values, float)
    ok = np.isfinite(v)
    if not ok.any():
        return float("nan")
    return float(np.sum(class_balanced_weights(np.asarray(classes)[ok]) * v[ok]))


SUMMARY_COLUMNS = (
    "LER",
    "G",
    "CCT",
    "CCT_mired",
    "LER_covered",
    "G_covered",
    "CCT_covered",
    "LER_width",
    "G_width",
    "CCT_width",
    "CCT_width_mired",
    "level1_correct",
    "level2_correct",
    "unexplained",
)


def summarise(records: Sequence[dict], keys=("band_set", "estimator", "surface")):
    """Per group of `keys`: per partition the class-balanced mean over test
    lamps of each `SUMMARY_COLUMNS` value (MAE for the metrics), then mean and
    SD over partitions; `out_of_range` summed. Records need a `partition`.
    Records that say `modelled_per_class` pass it on to their group's row
    (records without it, e.g. those of a run without modelled lamps: no
    such key)."""
    groups: dict = {}
    for r in records:
        groups.setdefault(tuple(r[k] for k in keys), []).append(r)
    rows = []
    for g, recs in sorted(groups.items()):
        parts = sorted({r["partition"] for r in recs})
        row = dict(zip(keys, g, strict=True))
        row["partitions"] = len(parts)
        row["lamps_per_partition"] = len(recs) // max(len(parts), 1)
        row["out_of_range"] = int(sum(r["out_of_range"] for r in recs))
        n_model = {r["modelled_per_class"] for r in recs if "modelled_per_class" in r}
        if len(n_model) > 1:
            raise ValueError(
                f"group {g}: records with different modelled_per_class {n_model}."
            )
        if n_model:
            row["modelled_per_class"] = n_model.pop()
        for col in SUMMARY_COLUMNS:
            per = []
            for p in parts:
                rp = [r for r in recs if r["partition"] == p and r.get(col) is not None]
                if rp:
                    per.append(
                        _cb_mean([r[col] for r in rp], [r["level2"] for r in rp])
                    )
            if per:
                row[col] = float(np.mean(per))
                row[f"{col}_sd"] = float(np.std(per, ddof=1)) if len(per) > 1 else None
                row[f"{col}_per_partition"] = per
        rows.append(row)
    return rows


def paired_differences(summary_rows, reference: str, against: str):
    """Per (estimator, surface): MAE of `against` minus `reference` band set,
    paired by partition; mean, SD and relative change of the mean."""
    by = {(r["band_set"], r["estimator"], r["surface"]): r for r in summary_rows}
    out = []
    for (bs, est, surf), r in sorted(by.items()):
        if bs != against or (reference, est, surf) not in by:
            continue
        row = {"estimator": est, "surface": surf, "band_set": against, "vs": reference}
        out.append(_paired_by_partition(r, by[(reference, est, surf)], row))
    return out


PAIRED_COLUMNS = ("LER", "G", "CCT", "CCT_mired")
"""Summary columns `_paired_by_partition` compares by default (the errors)."""


def _paired_by_partition(row_a, row_b, out: dict, columns=PAIRED_COLUMNS) -> dict:
    """`out` plus, per column of `columns`, `a - b` of two summary rows paired
    by partition: mean (`_diff`), SD (ddof 1, `_diff_sd`) and mean relative
    to b's (`_relative`); columns without matching per-partition values are
    left out."""
    for m in columns:
        a, b = row_a.get(f"{m}_per_partition"), row_b.get(f"{m}_per_partition")
        if not a or not b or len(a) != len(b):
            continue
        d = np.asarray(a) - np.asarray(b)
        out[f"{m}_diff"] = float(d.mean())
        out[f"{m}_diff_sd"] = float(d.std(ddof=1)) if d.size > 1 else None
        out[f"{m}_relative"] = float(d.mean() / np.mean(b)) if np.mean(b) else None
    return out


ESTIMATOR_PAIRS = (
    ("ridge+models", "ridge"),
    ("kernel+models", "kernel"),
    ("inversion+models", "inversion"),
    (EVIDENCE_ESTIMATOR, "inversion"),
    (MOON_ESTIMATOR, "inversion"),
    (MIX_ESTIMATOR, MOON_ESTIMATOR),
    (MIX_METRIC_ESTIMATOR, MIX_ESTIMATOR),
)
"""(variant, base) estimator pairs `estimator_differences` compares: what
modelled training lamps, the evidence rule for `σ_rel`, the told Moon and
mixtures in the told-Moon prior change."""


def estimator_differences(summary_rows, pairs=ESTIMATOR_PAIRS, columns=PAIRED_COLUMNS):
    """Per band set, surface and (variant, base) pair of `pairs`: MAE of the
    variant minus the base estimator (or any other summary `columns`), paired
    by partition (the same folds and test lamps); mean, SD over partitions
    (ddof 1) and relative change of the mean. Pairs missing from
    `summary_rows` are skipped."""
    by = {(r["band_set"], r["estimator"], r["surface"]): r for r in summary_rows}
    out = []
    for variant, base in pairs:
        for (bs, est, surf), r in sorted(by.items()):
            if est != variant or (bs, base, surf) not in by:
                continue
            row = {"band_set": bs, "surface": surf, "estimator": variant, "vs": base}
            out.append(_paired_by_partition(r, by[(bs, base, surf)], row, columns))
    return out


def _fractions(labels) -> dict[str, float]:
    """Fraction of each label among `labels` (None: "unexplained"), by
    decreasing fraction."""
    keys = ["unexplained" if x is None else str(x) for x in labels]
    n = max(len(keys), 1)
    counts: dict[str, int] = {}
    for k in keys:
        counts[k] = counts.get(k, 0) + 1
    return {k: c / n for k, c in sorted(counts.items(), key=lambda kv: -kv[1])}


def leave_one_class_out(
    ctx,
    bands,
    *,
    surface_mode: str = "unknown",
    seed: int = 0,
    modelled_per_class: int = 0,
    modelled_classes: Sequence[str] = MODELLED_CLASSES,
    moon_known: bool = False,
    calibration: str = "lamps",
    mixtures: int = 0,
    sigma_rule: str = "error",
    floor_grid: Sequence[float] = (SIGMA_FLOOR,),
    interval_offsets: Sequence[float] = (0.0,),
    peak_shifts: Sequence[float] = (),
    planck: bool = False,
    tm30: bool = False,
):
    """Unseen lamp types: for every scored level-2 class, fit on all other
    classes (inner folds: 2 class-stratified lamp folds of those) and score its
    lamps. One record per test lamp as `cross_validate` (fold = the class),
    with the fraction of its pixels given each level-1 family
    (`level1_predicted`; "unexplained" for flagged pixels).

    `modelled_per_class` > 0: modelled lamps in every prior, calibrated on that
    fit's training lamps only (`fit_inversion`), so the held-out class never
    gets any (its lamps are not training lamps); the records then say
    `modelled_per_class` and the classes that got them. Default 0: as before.

    `moon_known`: the inversion is told each row's Moon brightness
    (`context_moon`) instead of fitting it (`MOON_ESTIMATOR`). `calibration`:
    the intervals' held-out lamps (`fit_inversion`; "classes": each of the
    fit's training classes held out in turn, never the scored class).
    `mixtures`: pairwise same-class mixtures of the prior's lamps
    (`fit_inversion(mixtures=)`; never of the held-out class: its lamps are
    not in any prior). `sigma_rule`, `floor_grid`, `interval_offsets`: as
    `fit_inversion`'s; with more than one offset (0 among them) every lamp
    gets two records from the one fit, `"intervals": "narrowest"` and
    `"offset 0"` (`Inversion.with_interval_offset(0)`), the same but for the
    intervals. `peak_shifts`: wavelength-shifted copies of the prior's
    direct-emission LEDs (`fit_inversion(peak_shifts=)`; never of the
    held-out class's lamps, which are in no prior). `planck`: the library's
    modelled incandescent spectra in every prior (`planck_lamps`; the
    records then say `modelled_in_prior`). `tm30`: the measured IES TM-30-15
    lamps in every prior (`tm30_lamps`) except those of the held-out class
    (measured lamps of an unseen type must not train; the records then say
    `tm30_in_prior`, the number in that class's prior)."""
    two = len(interval_offsets) > 1
    if two and 0.0 not in [float(x) for x in interval_offsets]:
        raise ValueError(
            f"interval_offsets {tuple(interval_offsets)}: several need 0 among them."
        )
    lamps, always, cond, row_types = context_setup(ctx)
    grid = ctx.wavelength_nm
    modelled_in_prior = planck_lamps(grid) if planck else None
    if planck:
        always = with_planck_lamps(always, grid)
    rad = ctx.radiance(bands)
    w = band_weights_on(bands, grid)
    row_lamp = np.asarray(ctx.table.lamp_of)
    classes = np.asarray(lamps.level2, dtype=object)
    basis = _basis(grid)
    si = _surface_knowledge(row_types, basis, seed)[surface_mode]
    moon_rows = context_moon(ctx) if moon_known else None
    out = []
    for c in sorted(set(classes)):
        test = np.flatnonzero(classes == c)
        train = np.flatnonzero(classes != c)
        folds = stratified_lamp_folds(classes[train], 2, seed)
        inner = [(np.setdiff1d(train, train[v]), np.sort(train[v])) for v in folds]
        prior_always = with_tm30_lamps(always, grid, drop_class=c) if tm30 else always
        inv = fit_inversion(
            rad,
            row_lamp,
            lamps,
            train,
            inner,
            w,
            cond,
            basis=basis,
            surface_mode=surface_mode,
            row_surface=si,
            always=prior_always,
            modelled_per_class=modelled_per_class,
            modelled_classes=modelled_classes,
            modelled_seed=seed,
            row_moon=moon_rows,
            calibration=calibration,
            mixtures=mixtures,
            sigma_rule=sigma_rule,
            floor_grid=floor_grid,
            interval_offsets=interval_offsets,
            peak_shifts=peak_shifts,
        )
        _check_never_scored(inv, [lamps.ids[i] for i in test])
        if c in inv.diagnostics["modelled_lamps"]["added"]:
            raise RuntimeError(f"held-out class {c} got modelled lamps (a leak).")
        if any(
            "ies_tm30_" in i and l2 == c
            for i, l2 in zip(inv.prior.ids, inv.prior.level2, strict=True)
        ):
            raise RuntimeError(f"held-out class {c} has IES TM-30 lamps (a leak).")
        rows = np.flatnonzero(np.isin(row_lamp, test))
        sub = (
            None
            if si is None
            else (si[rows] if isinstance(si, np.ndarray) else [si[i] for i in rows])
        )
        moon_sub = None if moon_rows is None else moon_rows[rows]
        res = inv.predict(rad[rows], sub, moon_sub)
        variants = [("narrowest", res.interval90)] if two else [(None, res.interval90)]
        if two:
            base = inv.with_interval_offset(0.0).predict(rad[rows], sub, moon_sub)
            variants.append(("offset 0", base.interval90))
        for lamp, (tag, iv90) in itertools.product(test, variants):
            sel = row_lamp[rows] == lamp
            t, v = ctx.table.truth[lamp], ctx.table.valid[lamp]
            rec = {
                "held_out_class": c,
                "lamp": lamps.ids[lamp],
                "level1": lamps.level1[lamp],
                "level2": c,
                "rows": int(sel.sum()),
                "out_of_range": _out_of_range(res.estimate[sel]),
                "level1_in_prior": lamps.level1[lamp] in set(inv.prior.level1),
                "level1_correct": float(
                    np.mean(
                        np.array(res.level1, dtype=object)[sel] == lamps.level1[lamp]
                    )
                ),
                "unexplained": float(np.mean(res.unexplained[sel])),
                "level1_predicted": _fractions(np.array(res.level1, dtype=object)[sel]),
            }
            for m, name in enumerate(METRICS):
                if not v[m]:
                    continue
                e = res.estimate[sel, m]
                ee = np.where(np.isfinite(e), e, CCT_RANGE_K[1]) if name == "CCT" else e
                rec[name] = float(np.mean(np.abs(ee - t[m])))
            rec.update(_interval_fields(iv90[sel], t, v))
            if tag is not None:
                rec["intervals"] = tag
            if modelled_in_prior is not None:
                rec["modelled_in_prior"] = list(modelled_in_prior.ids)
            if tm30:
                rec["tm30_in_prior"] = sum(
                    i.startswith("ies_tm30_") for i in prior_always.ids
                )
            if modelled_per_class > 0:
                rec.update(_modelled_fields(inv))
            out.append(rec)
    return out
