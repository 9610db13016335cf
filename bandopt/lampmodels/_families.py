"""The lamp model families, their fitting to one measured spectrum and their
calibration on the library (`bandopt.lampmodels`, whose docstring describes
the models)."""

import dataclasses
import functools
import itertools
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float

from ..datasets import nir as nir_mod
from ..datasets.lamps import LEVEL2_PARENT, LampLibrary, LampRecord, library
from ..photometry import K_M_LM_PER_W
from ..spectra import planck_radiance


# --------------------------------------------------------------------------------------
# Line lists: NIST ASD air wavelengths (`NISTASD`). [nm]

HG_405 = (404.656,)
HG_436 = (435.833,)
HG_492 = (491.604,)
HG_546 = (546.074,)
HG_577 = (576.960,)
HG_579 = (579.066,)
NA_D = (588.995, 589.592)
NA_498 = (497.854, 498.281)
NA_515 = (514.882, 515.365)
NA_568 = (568.263, 568.819)
NA_615 = (615.423, 616.075)
NA_819 = (818.326, 819.482)
K_767 = (766.490, 769.896)
TL_535 = (535.046,)
IN_410 = (410.176,)
IN_451 = (451.131,)
LI_671 = (670.776, 670.791)

HC_EV_NM = 1239.841984
"""h c in eV nm (CODATA 2018). [eV nm]"""
NIR_MEASURED_NM = 830.0
"""A lamp constrains the near-infrared parameters when measured this far. [nm]"""
RIDGE = 1e-3
"""Weight of the pull of z towards the default start in every fit. [1]"""
SHRINKAGE = 0.5
"""Calibration covariance: (1 - s) sample covariance + s its diagonal. [1]"""
N_STARTS = 4
MAX_STEPS = 300
Z_CLIP = 6.0
"""Fitted z are clipped to ±6 (sigmoid 0.25 % from a bound) before calibration."""


@dataclasses.dataclass(frozen=True)
class Param:
    """One bounded parameter: `lo < value < hi`, default start `init`, and
    whether only near-infrared data (beyond 780 nm) constrain it."""

    name: str
    lo: float
    hi: float
    init: float
    nir: bool = False


@dataclasses.dataclass(frozen=True)
class Family:
    """A model family: parameters and the spectrum function of their values."""

    name: str
    classes: tuple[str, ...]
    params: tuple[Param, ...]
    fn: Callable[[dict, Array], Array]
    reference: str

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.params]

    @property
    def lo(self) -> np.ndarray:
        return np.array([p.lo for p in self.params])

    @property
    def hi(self) -> np.ndarray:
        return np.array([p.hi for p in self.params])

    @property
    def nir_mask(self) -> np.ndarray:
        return np.array([p.nir for p in self.params])

    def z_init(self) -> np.ndarray:
        return to_z(self, np.array([p.init for p in self.params]))


def to_z(family: Family, values: ArrayLike) -> np.ndarray:
    """Inverse of the bound map: physical values -> unconstrained z."""
    u = (np.asarray(values, float) - family.lo) / (family.hi - family.lo)
    if np.any((u <= 0) | (u >= 1)):
        raise ValueError(
            f"{family.name}: parameter values must lie inside their bounds."
        )
    return np.log(u) - np.log1p(-u)


def to_values(
    family: Family, z: Float[ArrayLike, "*batch k"]
) -> Float[Array, "*batch k"]:
    """Bound map: `lo + (hi - lo) sigmoid(z)`."""
    lo = jnp.asarray(family.lo)
    hi = jnp.asarray(family.hi)
    return lo + (hi - lo) * jax.nn.sigmoid(jnp.asarray(z))


# --------------------------------------------------------------------------------------
# Profiles, each normalised to unit area on the grid `w` (trapezoid).


def _unit_area(f: Array, w: Array) -> Array:
    area = jnp.trapezoid(f, w)
    ok = area > 0
    return f / jnp.where(ok, area, 1.0) * ok


def _gauss_lines(w: Array, centres: Sequence, fwhm: Array) -> Array:
    sig = fwhm / 2.354820045
    f = sum(jnp.exp(-0.5 * ((w - c) / sig) ** 2) for c in centres)
    return _unit_area(f, w)


def _lorentz_lines(w: Array, centres: Sequence, fwhm: Array) -> Array:
    f = sum(1.0 / (1.0 + ((w - c) / (0.5 * fwhm)) ** 2) for c in centres)
    return _unit_area(f, w)


def _voigt_lines(w: Array, centres: Sequence[float], fwhm: Array, eta: Array) -> Array:
    """Pseudo-Voigt: η Lorentzian + (1 - η) Gaussian of the same FWHM."""
    return eta * _lorentz_lines(w, centres, fwhm) + (1 - eta) * _gauss_lines(
        w, centres, fwhm
    )


def _split_gauss(x: Array, centre: Array, fwhm: Array, skew: Array) -> Array:
    """Gaussian with FWHM·(1 - skew) below the centre, FWHM·(1 + skew) above."""
    sig = fwhm / 2.354820045 * jnp.where(x < centre, 1 - skew, 1 + skew)
    return jnp.exp(-0.5 * ((x - centre) / sig) ** 2)


def _phosphor(w: Array, centre_nm: Array, fwhm_ev: Array, skew: Array) -> Array:
    """Band Gaussian in photon energy E = hc/λ (split by `skew`, positive: wider
    towards high energy), as power per nm: G(E) |dE/dλ| = G(E) hc/λ²."""
    e = HC_EV_NM / w
    return _unit_area(_split_gauss(e, HC_EV_NM / centre_nm, fwhm_ev, skew) / w**2, w)


def _planck(w: Array, temperature_k: Array) -> Array:
    """Planck's law shape (`Planck1901`, `spectra.planck_radiance`), unit
    area on the grid."""
    return _unit_area(planck_radiance(w, jnp.asarray(temperature_k)), w)


def _na_d_reversed(w: Array, p: dict, prefix: str = "") -> Array:
    """Self-reversed, pressure-broadened Na D (`DeGroot1986`).

    (1 - exp(-τ φ)) exp(-τ_a g): φ an asymmetric Lorentzian of half widths
    γ_blue, γ_red centred `shift` from 589.29 nm; g Gaussians of standard
    deviation σ_a at the D lines. Unit area.
    """
    centre = 589.29 + p[prefix + "d_shift_nm"]
    gamma = jnp.where(
        w < centre, p[prefix + "d_gamma_blue_nm"], p[prefix + "d_gamma_red_nm"]
    )
    tau = jnp.exp(p[prefix + "d_ln_tau"]) / (1 + ((w - centre) / gamma) ** 2)
    g = sum(jnp.exp(-0.5 * ((w - c) / p[prefix + "d_sigma_abs_nm"]) ** 2) for c in NA_D)
    return _unit_area(-jnp.expm1(-tau) * jnp.exp(-p[prefix + "d_tau_abs"] * g), w)


def _na_d_params(init_shift=1.0, init_gamma=(3.0, 8.0)) -> tuple[Param, ...]:
    return (
        Param("d_shift_nm", -4.0, 8.0, init_shift),
        Param("d_ln_tau", 0.0, 9.0, 3.0),
        Param("d_gamma_blue_nm", 0.3, 30.0, init_gamma[0]),
        Param("d_gamma_red_nm", 0.3, 60.0, init_gamma[1]),
        Param("d_tau_abs", 0.0, 12.0, 1.5),
        Param("d_sigma_abs_nm", 0.5, 15.0, 3.0),
    )


def _amp(name: str, init: float = -3.0, nir: bool = False) -> Param:
    """Natural log of a component's power relative to the reference component."""
    return Param(name, -12.0, 4.0, init, nir)


# --------------------------------------------------------------------------------------
# Families


def _pc_led(p: dict, w: Array) -> Array:
    pump = _unit_area(
        _split_gauss(w, p["pump_nm"], p["pump_fwhm_nm"], p["pump_skew"]), w
    )
    ph1 = _phosphor(w, p["ph1_nm"], p["ph1_fwhm_ev"], p["ph1_skew"])
    ph2 = _phosphor(
        w, p["ph1_nm"] + p["ph2_offset_nm"], p["ph2_fwhm_ev"], p["ph2_skew"]
    )
    return ph1 + jnp.exp(p["ln_pump"]) * pump + jnp.exp(p["ln_ph2"]) * ph2


PC_LED = Family(
    "pc_led",
    ("led_warm", "led_cool", "led_amber"),
    (
        Param("pump_nm", 395.0, 475.0, 450.0),
        Param("pump_fwhm_nm", 8.0, 45.0, 20.0),
        Param("pump_skew", -0.6, 0.6, 0.1),
        _amp("ln_pump", -1.5),
        Param("ph1_nm", 490.0, 610.0, 545.0),
        Param("ph1_fwhm_ev", 0.12, 0.8, 0.4),
        Param("ph1_skew", -0.6, 0.6, 0.0),
        Param("ph2_offset_nm", 10.0, 160.0, 70.0),
        Param("ph2_fwhm_ev", 0.08, 0.7, 0.3),
        Param("ph2_skew", -0.6, 0.6, 0.0),
        _amp("ln_ph2", -0.5),
    ),
    _pc_led,
    "first phosphor band",
)


def _hps(p: dict, w: Array) -> Array:
    lines = _gauss_lines
    f = p["fwhm_lines_nm"]
    s = _na_d_reversed(w, p)
    for key, group in (
        ("ln_na498", NA_498),
        ("ln_na515", NA_515),
        ("ln_na568", NA_568),
        ("ln_na615", NA_615),
        ("ln_k767", K_767),
        ("ln_hg436", HG_436),
        ("ln_hg546", HG_546),
    ):
        s = s + jnp.exp(p[key]) * lines(w, group, f)
    s = s + jnp.exp(p["ln_na819"]) * _lorentz_lines(w, NA_819, p["fwhm_na819_nm"])
    return s + jnp.exp(p["ln_cont"]) * _planck(w, p["cont_k"])


HPS = Family(
    "hps",
    ("hps",),
    (
        *_na_d_params(),
        Param("fwhm_lines_nm", 0.8, 15.0, 4.0),
        _amp("ln_na498"),
        _amp("ln_na515"),
        _amp("ln_na568"),
        _amp("ln_na615"),
        _amp("ln_k767"),
        _amp("ln_hg436", -5.0),
        _amp("ln_hg546", -5.0),
        _amp("ln_na819", -2.0, nir=True),
        Param("fwhm_na819_nm", 1.0, 25.0, 5.0, nir=True),
        _amp("ln_cont", -2.0),
        Param("cont_k", 1000.0, 8000.0, 3000.0),
    ),
    _hps,
    "Na D",
)


def _lps(p: dict, w: Array) -> Array:
    f, eta = p["fwhm_nm"], p["eta"]
    s = _voigt_lines(w, NA_D, f, eta)
    for key, group in (
        ("ln_na498", NA_498),
        ("ln_na515", NA_515),
        ("ln_na568", NA_568),
        ("ln_na615", NA_615),
    ):
        s = s + jnp.exp(p[key]) * _voigt_lines(w, group, f, eta)
    s = s + jnp.exp(p["ln_na819"]) * _voigt_lines(w, NA_819, f, eta)
    return s + jnp.exp(p["ln_cont"]) * _planck(w, p["cont_k"])


LPS = Family(
    "lps",
    ("lps",),
    (
        Param("fwhm_nm", 0.3, 12.0, 3.0),
        Param("eta", 0.0, 1.0, 0.3),
        _amp("ln_na498", -6.0),
        _amp("ln_na515", -6.0),
        _amp("ln_na568", -4.0),
        _amp("ln_na615", -5.0),
        _amp("ln_na819", -2.5, nir=True),
        _amp("ln_cont", -6.0),
        Param("cont_k", 1000.0, 8000.0, 3000.0),
    ),
    _lps,
    "Na D",
)


def _mercury(p: dict, w: Array) -> Array:
    f = p["fwhm_lines_nm"]
    s = _gauss_lines(w, HG_546, f)
    for key, group in (
        ("ln_hg405", HG_405),
        ("ln_hg436", HG_436),
        ("ln_hg492", HG_492),
        ("ln_hg577", HG_577),
        ("ln_hg579", HG_579),
    ):
        s = s + jnp.exp(p[key]) * _gauss_lines(w, group, f)
    fp = p["fwhm_phosphor_nm"]
    s = s + jnp.exp(p["ln_red1"]) * _gauss_lines(w, (p["red1_nm"],), fp)
    s = s + jnp.exp(p["ln_red2"]) * _gauss_lines(w, (p["red2_nm"],), fp)
    return s + jnp.exp(p["ln_cont"]) * _planck(w, p["cont_k"])


MERCURY = Family(
    "mercury",
    ("mercury",),
    (
        Param("fwhm_lines_nm", 0.8, 15.0, 4.0),
        _amp("ln_hg405", -1.0),
        _amp("ln_hg436", -0.5),
        _amp("ln_hg492", -5.0),
        _amp("ln_hg577", -1.0),
        _amp("ln_hg579", -1.0),
        _amp("ln_red1", -1.0),
        Param("red1_nm", 605.0, 635.0, 618.0),
        _amp("ln_red2", -3.0),
        Param("red2_nm", 685.0, 715.0, 700.0),
        Param("fwhm_phosphor_nm", 1.0, 30.0, 6.0),
        _amp("ln_cont", 0.0),
        Param("cont_k", 1000.0, 8000.0, 4000.0),
    ),
    _mercury,
    "Hg 546.1 nm",
)


def _metal_halide(p: dict, w: Array) -> Array:
    f = p["fwhm_lines_nm"]
    s = _planck(w, p["cont_k"])
    for key, group in (
        ("ln_hg405", HG_405),
        ("ln_hg436", HG_436),
        ("ln_hg546", HG_546),
        ("ln_hg577", HG_577),
        ("ln_hg579", HG_579),
        ("ln_tl535", TL_535),
        ("ln_in410", IN_410),
        ("ln_in451", IN_451),
        ("ln_li671", LI_671),
        ("ln_na568", NA_568),
        ("ln_na615", NA_615),
        ("ln_k767", K_767),
    ):
        s = s + jnp.exp(p[key]) * _gauss_lines(w, group, f)
    s = s + jnp.exp(p["ln_nad"]) * _na_d_reversed(w, p)
    s = s + jnp.exp(p["ln_na819"]) * _lorentz_lines(w, NA_819, p["fwhm_na819_nm"])
    hump = _unit_area(
        _split_gauss(w, p["hump_nm"], p["hump_fwhm_nm"], jnp.zeros_like(p["hump_nm"])),
        w,
    )
    return s + jnp.exp(p["ln_hump"]) * hump


METAL_HALIDE = Family(
    "metal_halide",
    ("metal_halide",),
    (
        Param("cont_k", 1500.0, 12000.0, 5000.0),
        Param("fwhm_lines_nm", 0.8, 15.0, 4.0),
        _amp("ln_hg405"),
        _amp("ln_hg436"),
        _amp("ln_hg546"),
        _amp("ln_hg577"),
        _amp("ln_hg579"),
        _amp("ln_tl535"),
        _amp("ln_in410"),
        _amp("ln_in451"),
        _amp("ln_li671"),
        _amp("ln_na568"),
        _amp("ln_na615"),
        _amp("ln_k767"),
        _amp("ln_nad", -1.0),
        *_na_d_params(init_gamma=(2.0, 4.0)),
        _amp("ln_na819", -2.0, nir=True),
        Param("fwhm_na819_nm", 1.0, 25.0, 5.0, nir=True),
        _amp("ln_hump", -1.0),
        Param("hump_nm", 420.0, 680.0, 560.0),
        Param("hump_fwhm_nm", 30.0, 300.0, 150.0),
    ),
    _metal_halide,
    "Planckian continuum",
)

FAMILIES: dict[str, Family] = {
    f.name: f for f in (PC_LED, HPS, LPS, MERCURY, METAL_HALIDE)
}
FAMILY_OF_CLASS: dict[str, str] = {
    c: f.name for f in FAMILIES.values() for c in f.classes
}
"""Level-2 class -> model family. Classes not listed have no physical model."""
REFERENCE = {name: f.reference for name, f in FAMILIES.items()}


def family_of(level2: str) -> Family:
    """The model family of a level-2 class (`ValueError` lists the choices)."""
    if level2 not in FAMILY_OF_CLASS:
        raise ValueError(
            f"No lamp model for class {level2!r}; modelled classes: "
            f"{sorted(FAMILY_OF_CLASS)}."
        )
    return FAMILIES[FAMILY_OF_CLASS[level2]]


# --------------------------------------------------------------------------------------
# Spectra


def spectrum(
    family: Family, z: Float[ArrayLike, " k"], wavelength_nm: Float[ArrayLike, " w"]
) -> Float[Array, " w"]:
    """The model spectrum for unconstrained parameters `z`, normalised to unit
    visible power (∫_380^780 S dλ = 1 on the grid). [nm⁻¹]"""
    w = jnp.asarray(wavelength_nm)
    values = to_values(family, z)
    s = family.fn(dict(zip(family.names, values, strict=True)), w)
    vis = (w >= 380.0) & (w <= 780.0)
    seg = jnp.diff(w) * (vis[:-1] & vis[1:])  # trapezoid segments inside 380-780
    weights = 0.5 * (jnp.pad(seg, (1, 0)) + jnp.pad(seg, (0, 1)))
    p_vis = jnp.sum(weights * s)
    ok = p_vis > 0
    return s / jnp.where(ok, p_vis, 1.0)


def visible_normalised(wavelength_nm: np.ndarray, values: np.ndarray) -> np.ndarray:
    """A spectrum divided by its visible power ∫_380^780 S dλ (trapezoid). [nm⁻¹]"""
    vis = (wavelength_nm >= 380.0) & (wavelength_nm <= 780.0)
    p = np.trapezoid(values[..., vis], wavelength_nm[vis], axis=-1)
    return values / np.asarray(p)[..., None]


def per_lumen(wavelength_nm: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Scale spectra to one lumen, the library's convention: 683 ∫_380^780 V S dλ
    = 1 (trapezoid on the grid, colour's CIE 1924 V). [W nm⁻¹ lm⁻¹]"""
    # start-up time: colour takes ~1.5 s to import
    from colour import SDS_LEFS

    v = SDS_LEFS["CIE 1924 Photopic Standard Observer"]
    vis = (wavelength_nm >= 380.0) & (wavelength_nm <= 780.0)
    lum = K_M_LM_PER_W * np.trapezoid(
        values[..., vis] * v[wavelength_nm[vis]], wavelength_nm[vis], axis=-1
    )
    return values / np.asarray(lum)[..., None]


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
