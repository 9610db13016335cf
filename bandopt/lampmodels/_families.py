"""The five lamp model families as pure JAX functions of their parameters: the
NIST line lists, the bounded parameters (`Param`, `Family`, the sigmoid map
`to_values` and its inverse `to_z`), unit-area line and band profiles, each
family's spectrum function and `spectrum`, the model normalised to unit
visible power (`per_lumen` scales to the library's one lumen). Apart from
fitting and calibration because a model needs neither a solver nor the
library (`bandopt.lampmodels` describes each family)."""

import dataclasses
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

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
