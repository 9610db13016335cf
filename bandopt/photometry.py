"""Photometric ground truth from full spectra: LER, G index, CCT and Duv.

Pure JAX on a batch of spectra `(*batch, w)` sampled on one wavelength grid.
These are the reference values the band-radiance estimators learn.

**Grid.** `wavelength_nm` must be a concrete (not traced) 1 nm grid whose samples
fall on whole nanometres and that covers at least 380-780 nm; anything else raises
`ValueError`. Under `jax.jit`, close over the grid (`jax.jit(lambda s:
metrics(s, wl))`). Every integral is the trapezoid rule on that 1 nm grid with the
stated end points (half weight at both ends).

**Spectra** may be in any radiometric unit (it cancels in every quantity here).
NaN (or ±inf) inside 380-780 nm raises `ValueError` at entry when the spectra
are concrete, and `eqx.error_if` fails the computation when they are traced.
Outside 380-780 nm a NaN marks a sample as not measured: it only narrows
`LER_full_range`.

**One pass.** Every quantity is a function of eight integrals per spectrum
(∫S, ∫VS, X, Y, Z and the blue ∫S over their ranges, ∫S and ∫VS over the whole
grid), taken in one matrix product with stacked weights, so the spectra are
read once. The checks run on those integrals (a NaN/inf sample makes the
whole-grid ∫S non-finite); only spectra that fail them are read again.
Concrete spectra are integrated on the host with NumPy and are scale-free
(see `_host_integrals`); traced spectra are integrated by XLA, unscaled.

**Undefined values.** A spectrum with no net power in 380-780 nm (all zero) has
no LER, chromaticity or CCT: those are NaN, documented here and flagged (CCT);
it is the only way this module returns NaN. Every division and logarithm is a
double `where`, so gradients stay finite everywhere, NaN rows included.

Tables (V(λ), CIE 1931 2° CMFs, the Planckian table, Robertson's lines) come
from colour-science; see `bandopt._photometry_tables`.

References (keys in `bandopt/datasets/references.bib`): `CIE2018` (V(λ), CMFs,
K_m), `Donatello2019` (G index), `Ohno2014` (Ohno 2013 CCT), `Robertson1968`,
`Mansencal2025` (colour-science, the tables and the reference implementation).
"""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Real

from . import _photometry_tables as _tables
from ._photometry_cct import (
    ohno2013 as _ohno2013,
    robertson1968 as _robertson1968,
    safe_div as _safe_div,
)
from .names import canonical_key


__all__ = [
    "CCT_MAX_K",
    "CCT_MIN_K",
    "DUV_MAX",
    "G_CAP",
    "K_M_LM_PER_W",
    "cct_duv",
    "g_index",
    "ler",
    "metrics",
]

K_M_LM_PER_W = 683.0
"""Maximum luminous efficacy of photopic vision, K_m. [lm W⁻¹] (`CIE2018`)"""

G_CAP = 10.0
"""Value of the G index where it is capped (flagged). [1]

G = -2.5 log10(B/L) diverges when the blue integral B (380-500 nm) vanishes, as
for low-pressure sodium. Wherever B/L <= 10^(-G_CAP/2.5) = 1e-4 (including B <= 0
and no visible light at all), G is set to `G_CAP` and flagged. 10 lies above every
source in the lamp library that emits below 500 nm: the least blue measured lamps
read about 2.3 (HPS) and 5.1 (the Philips TLD 36W/15 tube), the modelled 700 K
blackbody (fire) 8.65; only LPS (nothing below 500 nm) is capped.
"""

CCT_MIN_K = 1000.0
"""Lowest CCT reported as meaningful. [K]"""
CCT_MAX_K = 25000.0
"""Highest CCT reported as meaningful. [K]"""
DUV_MAX = 0.05
"""Largest |Duv| for which a CCT is meaningful (Ohno 2014). [1]"""

VISIBLE_START_NM = 380
"""Start of the visible integrals. [nm]"""
VISIBLE_END_NM = 780
"""End of the visible integrals. [nm]"""
BLUE_END_NM = 500
"""End of the blue integral of the G index (Donatello2019). [nm]"""

_G_RATIO_MIN = 10.0 ** (-G_CAP / 2.5)
_COARSE_STRIDE = 32  # Ohno nearest-point search: every 32nd table row, then ±32 rows
_DENOMINATORS = {"380780": "380-780", "full": "full", "fullrange": "full"}
_CCT_METHODS = {"ohno2013": "ohno2013", "robertson1968": "robertson1968"}


def _resolve(name: str, registry: dict[str, str], argument: str) -> str:
    try:
        return registry[canonical_key(name)]
    except KeyError:
        choices = sorted(set(registry.values()))
        raise ValueError(
            f"Unknown {argument}={name!r}; expected one of {choices} "
            "(case and separators are ignored)."
        ) from None


# --------------------------------------------------------------------------------------
# Validation (static, before anything is traced)


_COLUMNS = ("S", "VS", "X", "Y", "Z", "blue", "S_full", "VS_full")
"""The integrals every quantity here is computed from, in the order of the
columns of `_grid_constants(...)["weights"]`: ∫S, ∫VS, X, Y, Z over 380-780 nm,
∫S over 380-500 nm, and ∫S, ∫VS over the whole grid (every sample measured)."""
_S, _VS, _X, _BLUE, _S_FULL, _VS_FULL = 0, 1, 2, 5, 6, 7  # in `_COLUMNS`


@functools.cache
def _grid_constants(start_nm: int, n: int) -> dict[str, np.ndarray | int]:
    """Index range of 380-780 nm, V(λ) and the stacked trapezoid weights of
    every integral in `_COLUMNS` on the 1 nm grid `start_nm + arange(n)`."""
    obs_nm, v_obs, xyz_obs = _tables.observer_tables()
    grid = start_nm + np.arange(n, dtype=np.float64)
    # V(λ) on the whole grid, zero where the CIE does not tabulate it (< 360, > 830).
    pos = np.searchsorted(obs_nm, grid)
    inside = (grid >= obs_nm[0]) & (grid <= obs_nm[-1])
    v_full = np.where(inside, v_obs[np.clip(pos, 0, obs_nm.size - 1)], 0.0)

    vis = np.arange(VISIBLE_START_NM, VISIBLE_END_NM + 1, dtype=np.float64)
    rows = (vis - obs_nm[0]).astype(int)
    q_vis = np.ones(vis.size)
    q_vis[[0, -1]] = 0.5  # trapezoid, 1 nm
    q_blue = np.where(vis <= BLUE_END_NM, 1.0, 0.0)
    q_blue[[0, BLUE_END_NM - VISIBLE_START_NM]] = 0.5
    q_full = np.ones(n)
    q_full[[0, -1]] = 0.5
    i0 = VISIBLE_START_NM - start_nm
    weights = np.zeros((n, len(_COLUMNS)))
    weights[i0 : i0 + vis.size, :_S_FULL] = np.stack(
        [q_vis, q_vis * v_obs[rows], *(q_vis[:, None] * xyz_obs[rows]).T, q_blue],
        axis=-1,
    )
    weights[:, _S_FULL] = q_full
    weights[:, _VS_FULL] = q_full * v_full
    weights.setflags(write=False)
    return {"i380": i0, "i781": i0 + vis.size, "weights": weights, "v_full": v_full}


def _check_grid(wavelength_nm, n_samples: int) -> int:
    """Validate the grid; return its first wavelength (a whole number). [nm]"""
    try:
        wl = np.asarray(wavelength_nm, dtype=np.float64)
    except jax.errors.TracerArrayConversionError:
        raise ValueError(
            "`wavelength_nm` must be concrete (a NumPy array), not traced: close "
            "over the grid outside `jax.jit`/`jax.vmap`, e.g. "
            "`jax.jit(lambda s: metrics(s, wavelength_nm))`."
        ) from None
    if wl.ndim != 1 or wl.size < 2:
        raise ValueError(
            "`wavelength_nm` must be 1-D with at least 2 samples; got shape "
            f"{wl.shape}."
        )
    if wl.size != n_samples:
        raise ValueError(
            f"`spectra` has {n_samples} wavelength samples but `wavelength_nm` has "
            f"{wl.size}."
        )
    if not np.all(np.isfinite(wl)):
        raise ValueError("`wavelength_nm` contains NaN or inf.")
    step = np.diff(wl)
    if not np.allclose(step, 1.0, rtol=0.0, atol=1e-6):
        raise ValueError(
            "`wavelength_nm` must be a 1 nm grid; got steps from "
            f"{step.min():g} to {step.max():g} nm. Resample first "
            "(`bandopt.spectra.resample` onto `bandopt.spectra.GRID_1NM`)."
        )
    start = round(float(wl[0]))
    if abs(wl[0] - start) > 1e-6:
        raise ValueError(
            "`wavelength_nm` samples must fall on whole nanometres (so that 380 and "
            f"780 nm are samples); the grid starts at {wl[0]:g} nm."
        )
    if wl[0] > VISIBLE_START_NM + 1e-6 or wl[-1] < VISIBLE_END_NM - 1e-6:
        raise ValueError(
            f"`wavelength_nm` must cover {VISIBLE_START_NM}-{VISIBLE_END_NM} nm; it "
            f"covers {wl[0]:g}-{wl[-1]:g} nm."
        )
    return start


def _as_spectra(spectra) -> Array | np.ndarray:
    if not isinstance(spectra, jax.Array):
        spectra = np.asarray(spectra)
    if not jnp.issubdtype(spectra.dtype, jnp.floating):
        spectra = spectra.astype(jnp.result_type(float))
    if spectra.ndim < 1:
        raise ValueError("`spectra` must have a wavelength axis (the last axis).")
    return spectra


def _raise_if_visible_not_finite(rows, row_index, batch_shape, start_nm) -> None:
    """`ValueError` naming the first NaN/inf inside 380-780 nm, if any.

    `rows` (k, w) are the spectra at the flat batch positions `row_index`: every
    spectrum whose integrals are not finite, so every one that can hold one.
    """
    i0 = VISIBLE_START_NM - start_nm
    bad = ~np.isfinite(rows[:, i0 : i0 + VISIBLE_END_NM - VISIBLE_START_NM + 1])
    if bad.any():
        k, nm = np.argwhere(bad)[0]
        where = np.unravel_index(row_index[k], batch_shape)
        raise ValueError(
            f"`spectra` has NaN or inf inside {VISIBLE_START_NM}-{VISIBLE_END_NM} nm "
            f"({int(bad.any(axis=-1).sum())} spectra; first at batch index "
            f"{tuple(int(i) for i in where)}, {VISIBLE_START_NM + nm} nm): "
            "the visible integrals need every sample there."
        )


def _run(spectra, wavelength_nm, quantity: str, method: str = "ohno2013"):
    """Validate outside any trace, integrate (one pass), then one jitted
    function of the integrals for `quantity`."""
    spectra = _as_spectra(spectra)
    start = _check_grid(wavelength_nm, spectra.shape[-1])
    try:
        host = np.asarray(spectra)
    except jax.errors.TracerArrayConversionError:
        return _core(spectra, start, quantity, method)
    return _from_host_integrals(_host_integrals(host, start), quantity, method)


def _bucket(n: int) -> int:
    """The batch size `_from_integrals` is compiled for when `n` rows are
    asked: the next power of two. Each compiled size costs ~140 memory maps
    (XLA:CPU code and constants), and a process that asked for every batch size
    it met would reach the kernel's limit (vm.max_map_count, 65530) after a few
    hundred sizes and die in the compiler (seen in the test suite); buckets
    bound the count by log2 of the largest batch."""
    return 1 << max(n - 1, 0).bit_length()


def _from_host_integrals(sums: np.ndarray, quantity: str, method: str):
    """`_from_integrals` of host integrals `(*batch, 8)`, the rows padded with
    copies of the first to `_bucket(n)` and the padding dropped again (every
    quantity is a function of its own row only)."""
    batch = sums.shape[:-1]
    flat = sums.reshape(-1, sums.shape[-1])
    n = flat.shape[0]
    if n == 0:
        return _from_integrals(sums, quantity, method)
    pad = _bucket(n) - n
    if pad:
        flat = np.concatenate([flat, np.repeat(flat[:1], pad, axis=0)])
    out = _from_integrals(flat, quantity, method)
    return jax.tree_util.tree_map(lambda a: a[:n].reshape(batch), out)


# --------------------------------------------------------------------------------------
# Integrals: the one pass over the spectra


def _dot(a, b):
    """Matrix product at full precision, NumPy or JAX by the type of `a`."""
    if isinstance(a, np.ndarray):
        return a @ b
    return jnp.matmul(a, b, precision=jax.lax.Precision.HIGHEST)


def _masked_integrals(xp, spectra, weights: np.ndarray, v_full: np.ndarray):
    """(*batch, 8) integrals of `_COLUMNS` where a NaN/inf sample outside
    380-780 nm is not measured: the full-range pair then covers only the grid
    intervals whose two end samples are finite. `xp` is NumPy or `jax.numpy`.
    [nm·S]"""
    measured = xp.isfinite(spectra)
    s0 = xp.where(measured, spectra, 0.0)
    pair = (measured[..., :-1] & measured[..., 1:]).astype(s0.dtype)
    pad = xp.zeros((*s0.shape[:-1], 1), s0.dtype)
    q = 0.5 * (xp.concatenate([pad, pair], -1) + xp.concatenate([pair, pad], -1))
    qs = q * s0
    full = [xp.sum(qs, -1), _dot(qs, v_full.astype(s0.dtype))]
    return xp.concatenate(
        [_dot(s0, weights[:, :_S_FULL].astype(s0.dtype)), xp.stack(full, -1)], -1
    )


def _unit_peak(spectra: np.ndarray) -> np.ndarray:
    """Each spectrum scaled by the power of two that brings its largest finite
    |value| into [0.5, 1) (exact). An all-zero spectrum stays zero."""
    finite = np.isfinite(spectra)
    peak = np.max(np.where(finite, np.abs(spectra), 0.0), axis=-1, keepdims=True)
    _, exponent = np.frexp(peak)
    return np.where(finite, np.ldexp(spectra, -exponent), spectra)


def _host_integrals(spectra: np.ndarray, start_nm: int) -> np.ndarray:
    """(*batch, 8) integrals of `_COLUMNS` of concrete spectra, scale-free. [1]

    One product of the spectra with the stacked weights reads every sample
    once, on the host (NumPy keeps subnormal numbers; XLA on CPU flushes them
    to zero). The checks then run on the integrals: the full-range ∫S weighs
    every sample, so a NaN/inf sample makes it non-finite, and an integral of
    at least 2^(2 p) times the smallest normal number (p mantissa bits) has
    lost nothing to products that underflowed. Only the spectra failing that
    (a NaN/inf, an integral that overflows, is zero or tiny) are read again:
    checked for NaN/inf inside 380-780 nm (`ValueError`), scaled to a unit
    peak by a power of two and integrated with unmeasured samples left out.
    Every row of integrals is finally scaled by the power of two that brings
    its largest into [0.5, 1): every quantity is a ratio of them, so results
    are exactly those of the unscaled spectrum wherever its arithmetic neither
    overflows nor underflows, and right where it would.
    """
    consts = _grid_constants(start_nm, spectra.shape[-1])
    weights = consts["weights"].astype(spectra.dtype)
    flat = spectra.reshape(-1, spectra.shape[-1])
    info = np.finfo(spectra.dtype)
    with np.errstate(over="ignore", invalid="ignore"):  # caught by the test below
        sums = (weights.T @ flat.T).T  # this operand order is ~2x faster in BLAS
        ok = np.isfinite(sums) & (np.abs(sums) >= np.ldexp(info.tiny, 2 * info.nmant))
    redo = ~np.all(ok, axis=-1)
    if redo.any():
        rows, row_index = flat[redo], np.flatnonzero(redo)
        _raise_if_visible_not_finite(rows, row_index, spectra.shape[:-1], start_nm)
        sums[redo] = _masked_integrals(
            np, _unit_peak(rows), consts["weights"], consts["v_full"]
        )
    _, exponent = np.frexp(np.max(np.abs(sums), axis=-1, keepdims=True))
    return np.ldexp(sums, -exponent).reshape(*spectra.shape[:-1], len(_COLUMNS))


# --------------------------------------------------------------------------------------
# From the integrals to the quantities (pure JAX)


def _ler_from(num: Array, den: Array) -> Array:
    ok = den > 0
    return jnp.where(ok, K_M_LM_PER_W * _safe_div(num, den, ok), jnp.nan)


def _g_from(blue: Array, luminous: Array) -> tuple[Array, Array]:
    ratio = _safe_div(blue, luminous, luminous > 0)
    ok = ratio > _G_RATIO_MIN
    g = jnp.where(ok, -2.5 * jnp.log10(jnp.where(ok, ratio, 1.0)), G_CAP)
    return g, ~ok


def _uv_from_xyz(xyz: Array) -> tuple[Array, Array, Array]:
    """CIE 1960 UCS (u, v) and a validity mask; invalid rows get the point of E."""
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    den = x + 15.0 * y + 3.0 * z
    ok = (den > 0) & (y > 0)
    u = jnp.where(ok, _safe_div(4.0 * x, den, ok), 4.0 / 19.0)
    v = jnp.where(ok, _safe_div(6.0 * y, den, ok), 6.0 / 19.0)
    return u, v, ok


def _cct_from_xyz(xyz: Array, method: str) -> tuple[Array, Array, Array]:
    batch = xyz.shape[:-1]
    u, v, ok = _uv_from_xyz(xyz.reshape(-1, 3))
    dtype = xyz.dtype
    if method == "ohno2013":
        table = jnp.asarray(_tables.planckian_table_ohno2013(), dtype)
        cct, duv, in_table = _ohno2013(u, v, table, _COARSE_STRIDE)
    else:
        lines = jnp.asarray(_tables.isotemperature_lines_robertson1968(), dtype)
        cct, duv, in_table = _robertson1968(u, v, lines)
    meaningful = (
        ok
        & in_table
        & (jnp.abs(duv) <= DUV_MAX)
        & (cct >= CCT_MIN_K)
        & (cct <= CCT_MAX_K)
    )
    cct = jnp.where(ok, cct, jnp.nan)
    duv = jnp.where(ok, duv, jnp.nan)
    return cct.reshape(batch), duv.reshape(batch), meaningful.reshape(batch)


@functools.partial(jax.jit, static_argnums=(1, 2))
def _from_integrals(sums: Float[Array, "*batch 8"], quantity: str, method: str):
    """`quantity` from the integrals of `_COLUMNS` (any common scale)."""
    ler_visible = _ler_from(sums[..., _VS], sums[..., _S])
    ler_full = _ler_from(sums[..., _VS_FULL], sums[..., _S_FULL])
    if quantity in ("ler", "ler-full"):
        return ler_visible if quantity == "ler" else ler_full
    g, g_flag = _g_from(sums[..., _BLUE], sums[..., _VS])
    if quantity == "g":
        return g, g_flag
    cct, duv, meaningful = _cct_from_xyz(sums[..., _X : _X + 3], method)
    if quantity == "cct":
        return cct, duv, meaningful
    return {
        "LER": ler_visible,
        "LER_full_range": ler_full,
        "G": g,
        "G_flag": g_flag,
        "CCT": cct,
        "Duv": duv,
        "CCT_flag": ~meaningful,
    }


@functools.partial(jax.jit, static_argnums=(1, 2, 3))
def _core(spectra: Array, start_nm: int, quantity: str, method: str):
    """Traced spectra: one product with the stacked weights; only if an
    integral is not finite, the whole batch again with unmeasured samples
    left out, failing (`eqx.error_if`) on a NaN/inf inside 380-780 nm.
    Unscaled: a spectrum near the float limits can overflow or underflow."""
    consts = _grid_constants(start_nm, spectra.shape[-1])
    sums = _dot(spectra, jnp.asarray(consts["weights"], spectra.dtype))

    def masked():
        visible = spectra[..., consts["i380"] : consts["i781"]]
        return (
            _masked_integrals(jnp, spectra, consts["weights"], consts["v_full"]),
            jnp.any(~jnp.isfinite(visible)),
        )

    sums, bad = jax.lax.cond(
        jnp.all(jnp.isfinite(sums)), lambda: (sums, jnp.bool_(False)), masked
    )
    sums = eqx.error_if(sums, bad, "`spectra` has NaN or inf inside 380-780 nm.")
    return _from_integrals(sums, quantity, method)


# --------------------------------------------------------------------------------------
# Public API


def ler(
    spectra: Real[ArrayLike, "*batch w"],
    wavelength_nm: Real[ArrayLike, " w"],
    *,
    denominator: str = "380-780",
) -> Float[Array, "*batch"]:
    """Luminous efficacy of radiation, LER = K_m ∫V S dλ / ∫S dλ. [lm W⁻¹]

    **Arguments:**

    - `spectra`: spectral power in any radiometric unit (it cancels). [any]
    - `wavelength_nm`: concrete 1 nm grid covering 380-780 nm. [nm]
    - `denominator`: the range of both integrals. `"380-780"` (default): the
      visible range. `"full"`: every interval of the grid whose two end samples
      are finite (NaN marks a sample as not measured), per spectrum; V(λ) is zero
      beyond 360-830 nm, so only the denominator grows there.

    Trapezoid rule at 1 nm, K_m = `K_M_LM_PER_W` (`CIE2018`). NaN where the
    denominator is not positive (no light).
    """
    which = _resolve(denominator, _DENOMINATORS, "denominator")
    return _run(spectra, wavelength_nm, "ler" if which == "380-780" else "ler-full")


def g_index(
    spectra: Real[ArrayLike, "*batch w"], wavelength_nm: Real[ArrayLike, " w"]
) -> tuple[Float[Array, "*batch"], Bool[Array, "*batch"]]:
    """Spectral G index and its cap flag (`Donatello2019`, JRC EUR 29631). [1]

    G = -2.5 log10( ∫_380^500 S dλ / ∫_380^780 S V dλ ), trapezoid rule at 1 nm
    with those end points. Larger G means less blue light. Where the ratio is
    <= 1e-4 (no emission below 500 nm, e.g. low-pressure sodium, or no visible
    light at all) G is `G_CAP` and the flag is True; G and its gradient are
    finite everywhere.

    The JRC tables sum at 1 nm with full weight at both end points (rectangle
    rule); the trapezoid here halves the 380 and 500 nm samples of the blue
    integral, which lowers it by a few tenths of a percent for LEDs (G higher by
    up to about 0.01).

    **Returns:** `(G, flag)`, flag True where G is capped.
    """
    return _run(spectra, wavelength_nm, "g")


def cct_duv(
    spectra: Real[ArrayLike, "*batch w"],
    wavelength_nm: Real[ArrayLike, " w"],
    method: str = "ohno2013",
) -> tuple[Float[Array, "*batch"], Float[Array, "*batch"], Bool[Array, "*batch"]]:
    """Correlated colour temperature and Duv (CIE 1931 2°, CIE 1960 UCS).

    XYZ are trapezoid integrals over 380-780 nm at 1 nm. `method`:

    - `"ohno2013"` (`Ohno2014`): nearest point of colour's Planckian table
      (1000-100000 K), then the triangular or parabolic refinement, exactly as
      colour's `uv_to_CCT_Ohno2013`.
    - `"robertson1968"` (`Robertson1968`): interpolation between the 31
      isotemperature lines (1667 K-infinity), as colour's
      `uv_to_CCT_Robertson1968`.

    The Planckian locus comes from CMFs on 360-780 nm (colour's default), the
    spectra are integrated from 380 nm only: a blackbody sampled on 380-780 nm
    reads about 0.2 K low at 4000 K, 2.6 K at 6500 K and 65 K at 20000 K.

    **Returns:** `(cct_K [K], duv [1], meaningful)`. `meaningful` is False where
    |Duv| > `DUV_MAX`, CCT is outside `CCT_MIN_K`-`CCT_MAX_K`, the point lies
    beyond the method's table, or the spectrum has no light (CCT and Duv NaN).
    """
    return _run(spectra, wavelength_nm, "cct", _resolve(method, _CCT_METHODS, "method"))


def metrics(
    spectra: Real[ArrayLike, "*batch w"], wavelength_nm: Real[ArrayLike, " w"]
) -> dict[str, Array]:
    """Every photometric quantity at once (one pass over the spectra).

    Keys (arrays of shape `*batch`): `"LER"` (380-780 nm) and `"LER_full_range"`
    [lm W⁻¹] as `ler`; `"G"` [1] and `"G_flag"` (True where capped) as `g_index`;
    `"CCT"` [K] and `"Duv"` [1] by Ohno 2013 and `"CCT_flag"` (True where the CCT
    is NOT meaningful) as `cct_duv`.
    """
    return _run(spectra, wavelength_nm, "metrics")
