"""A library-free estimate of LER, G and CCT from contiguous bands.

The inversion (`bandopt.inversion`) answers with lamps of its library, so a
lamp unlike every library lamp is estimated no better than the nearest one:
`make study NAME=estimate-bands` found its error the same with 6 and with 52 bands.
With enough contiguous bands the spectrum itself can be read instead. A
pixel's band radiance is modelled as in the inversion,

    y_b = Σ_λ W_bλ T_e(λ) ρ(λ) S(λ)/π + β Σ_λ W_bλ [T ρ M/π + P](λ),

and, with the surface reflectance `ρ` given (known or measured: this
estimate has no surface prior to fall back on), the Moon's brightness `β`
told and the transmittances averaged over the candidate atmospheres, each
band value less the Moon's term over the band average of `T_e ρ/π` is the
band average of the lamp spectrum `S`. Read as a spectrum constant over each
band (the bands must tile 380-780 nm), it gives LER, G and CCT through
`bandopt.photometry`: physical by construction (a non-negative spectrum;
noise that leaves a band negative is clipped to no light). No lamp trains
it: a lamp the library holds is as new to it as one it lacks.

Measured on the scenes of `make estimate` (`results/estimate_bands/`): with
26 bands of 20 nm, 2.2 lm/W and 65 K class-balanced with the surface known,
6.8 lm/W and 164 K with it measured by Sentinel-2 in daytime, 17 lm/W with
it unknown (the prior's mean reflectance); G is set by amber LEDs, whose
light below 500 nm is under the noise. Intervals (`fit_direct`) are the
class-balanced 90 % quantile of the absolute error (LER, G, CCT in mired) of
every measured library lamp on those scenes with the same surface
knowledge: split-conformal with the library as calibration set, valid
because no library lamp trained the estimate.
"""

import dataclasses

import numpy as np

from . import inversion as inv_mod
from .datasets import surfaces as surf_mod
from .estimate import CCT_RANGE_K, METRICS, MIRED, MODEL_BOUNDS, lamp_truth
from .folds import class_balanced_weights
from .forward import band_values


TILING_TOLERANCE_NM = 1.0
"""How far apart one band's upper half-maximum edge and the next band's lower
one may be for the bands to count as contiguous. [nm]"""

PHOTOMETRIC_RANGE_NM = (380.0, 780.0)
"""The range the bands must tile: where LER, G and CCT are integrated. [nm]"""


def tiling_edges(bands) -> np.ndarray:
    """The half-maximum edges `(b, 2)` [nm] of a band set whose bands, sorted
    by centre, tile `PHOTOMETRIC_RANGE_NM`: each band's upper edge within
    `TILING_TOLERANCE_NM` of the next band's lower edge, the first starting at
    or below 380 nm and the last ending at or above 780 nm. Raises
    `ValueError` naming the first band pair or end that does not."""
    names = list(bands.names)
    edges = np.asarray(bands.edges_nm, float)
    order = np.argsort(edges.mean(axis=1))
    edges, names = edges[order], [names[i] for i in order]
    need = (
        "the direct estimate needs contiguous bands tiling "
        f"{PHOTOMETRIC_RANGE_NM[0]:g}-{PHOTOMETRIC_RANGE_NM[1]:g} nm (e.g. "
        "BandSet.contiguous)"
    )
    tol = TILING_TOLERANCE_NM
    for i in range(len(names) - 1):
        gap = edges[i + 1, 0] - edges[i, 1]
        if abs(gap) > tol:
            what = "a gap" if gap > 0 else "an overlap"
            raise ValueError(
                f"band {names[i]!r} ends at {edges[i, 1]:.1f} nm and "
                f"{names[i + 1]!r} starts at {edges[i + 1, 0]:.1f} nm ({what} "
                f"of {abs(gap):.1f} nm > {tol:g}): {need}."
            )
    if edges[0, 0] > PHOTOMETRIC_RANGE_NM[0] + tol:
        raise ValueError(f"the first band starts at {edges[0, 0]:.1f} nm: {need}.")
    if edges[-1, 1] < PHOTOMETRIC_RANGE_NM[1] - tol:
        raise ValueError(f"the last band ends at {edges[-1, 1]:.1f} nm: {need}.")
    back = np.empty_like(order)
    back[order] = np.arange(order.size)
    return edges[back]


def direct_bands(radiance, weights, cond, reflectance, moon) -> np.ndarray:
    """The band averages of the lamp spectrum per pixel, `(N, b)`.

    `radiance` (N, b) band values, `weights` (b, w) the bands' averaging
    weights on `cond`'s grid (`inversion.band_weights_on`), `cond` an
    `inversion.Conditions` (transmittances averaged over its atmospheres),
    `reflectance` (N, w) or (w,) the surface under each pixel, `moon` (N,) the
    Moon's told brightness relative to `cond.moon` (None: no Moon). Each
    band's value, less the Moon's term, over the band average of `T_e ρ/π`,
    clipped at 0 (a band without surface light is 0)."""
    grid = np.asarray(cond.wavelength_nm, float)
    y = np.asarray(radiance, float)
    rho = np.broadcast_to(np.asarray(reflectance, float), (len(y), grid.size))
    te = cond.lamp_transmittance.mean(axis=0)
    lamp_term = np.asarray(band_values(rho * te / np.pi, weights))  # (N, b)
    if cond.moon is not None and moon is not None:
        tm = cond.t_up.mean(axis=0) * cond.moon.mean(axis=0)
        q = np.asarray(band_values(rho * tm / np.pi, weights))
        if cond.path is not None:
            q = q + np.asarray(band_values(cond.path.mean(axis=0), weights))
        y = y - np.asarray(moon, float)[:, None] * q
    ok = lamp_term > 0
    band = np.where(ok, y / np.where(ok, lamp_term, 1.0), 0.0)
    return np.clip(band, 0.0, None)


def piecewise(band, edges, wavelength_nm) -> np.ndarray:
    """Band values `(N, b)` as a spectrum `(N, w)` on `wavelength_nm`, each
    held constant from its band's lower half-maximum edge (`edges` (b, 2)
    [nm]) to the next band's."""
    grid = np.asarray(wavelength_nm, float)
    lower = np.asarray(edges, float)[:, 0]
    order = np.argsort(lower)
    pos = np.clip(np.searchsorted(lower[order], grid, side="right") - 1, 0, None)
    return np.asarray(band)[:, order[pos]]


def direct_spectra(radiance, weights, cond, reflectance, moon, edges) -> np.ndarray:
    """The lamp spectrum per pixel, `(N, w)` on `cond`'s grid: `direct_bands`
    read as a spectrum (`piecewise`; `edges` (b, 2) the bands' half-maximum
    edges [nm], `tiling_edges`)."""
    band = direct_bands(radiance, weights, cond, reflectance, moon)
    return piecewise(band, edges, cond.wavelength_nm)


def _shape(band) -> np.ndarray:
    """Band values as fractions of their sum (rows without light stay 0)."""
    b = np.asarray(band, float)
    tot = b.sum(axis=1, keepdims=True)
    return np.where(tot > 0, b / np.where(tot > 0, tot, 1.0), 0.0)


def direct_metrics(spectra, wavelength_nm) -> tuple[np.ndarray, list[dict]]:
    """LER, G, CCT `(N, 3)` of direct spectra (`bandopt.estimate.lamp_truth`),
    NaN where a metric cannot be given, and per pixel the reasons why: no
    light left once the surface and the Moon are divided out, or a CCT that
    is not meaningful (> 0.05 Duv off the Planckian locus) or outside
    1000-25000 K."""
    values, valid = lamp_truth(spectra, wavelength_nm)
    reasons: list[dict] = [{} for _ in range(len(values))]
    cct = values[:, 2]
    out_of_range = valid[:, 2] & ((cct < CCT_RANGE_K[0]) | (cct > CCT_RANGE_K[1]))
    for i in range(len(values)):
        if not valid[i, 0]:
            for name in METRICS:
                reasons[i][name] = (
                    "no light: every band is at or below the Moon's and the "
                    "noise's level once the surface is divided out"
                )
        elif not valid[i, 2]:
            reasons[i]["CCT"] = (
                "no meaningful CCT: the spectrum read from the bands is > 0.05 "
                "Duv off the Planckian locus"
            )
        elif out_of_range[i]:
            reasons[i]["CCT"] = (
                f"CCT {cct[i]:.0f} K of the spectrum read from the bands is "
                f"outside {CCT_RANGE_K[0]:g}-{CCT_RANGE_K[1]:g} K"
            )
    values = values.copy()
    values[~valid[:, 0]] = np.nan
    values[out_of_range, 2] = np.nan
    return values, reasons


def _model(values) -> np.ndarray:
    """(…, 3) metric values with CCT as mired (NaN stays NaN)."""
    v = np.array(values, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        v[..., 2] = MIRED / v[..., 2]
    return v


@dataclasses.dataclass(frozen=True)
class DirectEstimator:
    """The direct estimate of a band set with calibrated 90 % intervals.

    `edges` (b, 2) the bands' tiling edges [nm], `weights` (b, w) their
    averaging weights on `cond`'s grid, `halfwidth` (3,) the interval
    half-widths in model space (LER [lm W⁻¹], G [1], CCT [mired]),
    `calibration` what they were calibrated on; `library_shapes` (L, b) the
    scored library lamps' noise-free band values as fractions of their sum,
    with their ids and types, for the lamp type (`nearest_lamps`)."""

    edges: np.ndarray
    weights: np.ndarray
    halfwidth: np.ndarray
    calibration: dict
    library_shapes: np.ndarray
    library_ids: tuple[str, ...]
    library_level1: tuple[str, ...]
    library_level2: tuple[str, ...]

    def nearest_lamps(self, band) -> np.ndarray:
        """Index of the library lamp whose noise-free band values, as
        fractions of their sum, are nearest (Euclidean) to each pixel's
        `direct_bands`. (N,)"""
        x = _shape(band)
        d = ((x[:, None, :] - self.library_shapes[None, :, :]) ** 2).sum(axis=-1)
        return np.argmin(d, axis=1)

    def rows(self, radiance, cond, reflectance, moon=None) -> list[dict]:
        """JSON-ready results per pixel, as `InversionResult.row` gives them:
        `estimate`, `interval90` (estimate ± half-width, clipped to the
        physical range), `null_reasons`; the types of the library lamp whose
        band values are nearest in shape (`nearest_lamps`, also named); no
        lamp model, so `unexplained` and `level1_probabilities` are None."""
        band = direct_bands(radiance, self.weights, cond, reflectance, moon)
        spectra = piecewise(band, self.edges, cond.wavelength_nm)
        values, reasons = direct_metrics(spectra, cond.wavelength_nm)
        nearest = self.nearest_lamps(band)
        model = _model(values)
        lo = np.clip(model - self.halfwidth, MODEL_BOUNDS[0], MODEL_BOUNDS[1])
        hi = np.clip(model + self.halfwidth, MODEL_BOUNDS[0], MODEL_BOUNDS[1])
        out = []
        for i in range(len(values)):
            est, iv = {}, {}
            for m, name in enumerate(METRICS):
                if not np.isfinite(values[i, m]):
                    est[name], iv[name] = None, None
                elif name == "CCT":
                    est[name] = float(values[i, m])
                    iv[name] = [float(MIRED / hi[i, m]), float(MIRED / lo[i, m])]
                else:
                    est[name] = float(values[i, m])
                    iv[name] = [float(lo[i, m]), float(hi[i, m])]
            out.append(
                {
                    "estimate": est,
                    "interval90": iv,
                    "null_reasons": reasons[i],
                    "unexplained": None,
                    "level1_probabilities": None,
                    "predicted_level1": self.library_level1[nearest[i]],
                    "predicted_level2": self.library_level2[nearest[i]],
                    "nearest_library_lamp": self.library_ids[nearest[i]],
                }
            )
        return out


def context_reflectance(ctx, mode: str, *, seed: int = 0):
    """The reflectance the direct estimate divides each row of a
    `search.Context` by: `"unknown"` the inversion's prior mean, `"class"`
    the row's surface type's mean (in those scenes the surface itself),
    `"measured"` the inversion's Sentinel-2 daytime retrieval (`seed`)."""
    _, _, _, row_types = inv_mod.context_setup(ctx)
    basis = inv_mod.surface_basis(ctx.wavelength_nm)
    if mode == "unknown":
        return basis.mean
    if mode == "class":
        types = sorted(set(row_types))
        _, refl = surf_mod.mean_reflectance(types, ctx.wavelength_nm)
        return refl[[types.index(t) for t in row_types]]
    if mode == "measured":
        return basis.reflectance(inv_mod.measured_surfaces(row_types, basis, seed=seed))
    raise ValueError(f"surface mode {mode!r}: expected one of {inv_mod.SURFACE_MODES}.")


def fit_direct(ctx, bands, mode: str, *, seed: int = 0) -> DirectEstimator:
    """The direct estimate of `bands` (which must tile 380-780 nm,
    `tiling_edges`) with interval half-widths calibrated on every scored
    library lamp of a `search.Context`'s scenes, surface knowledge `mode`:
    per metric the class-balanced 90 % quantile of the lamps' absolute
    errors over their pixels (each lamp the same weight within its class; a
    null estimate where the truth exists counts as a miss of the metric's
    whole range). No lamp trains the estimate, so every library lamp is a
    fair calibration lamp."""
    edges = tiling_edges(bands)
    lamps, _, cond, _ = inv_mod.context_setup(ctx)
    weights = inv_mod.band_weights_on(bands, ctx.wavelength_nm)
    spectra = direct_spectra(
        ctx.radiance(bands),
        weights,
        cond,
        context_reflectance(ctx, mode, seed=seed),
        inv_mod.context_moon(ctx),
        edges,
    )
    values, _ = direct_metrics(spectra, ctx.wavelength_nm)
    est, truth = _model(values), _model(ctx.table.truth)
    lamp_of = np.asarray(ctx.table.lamp_of)
    span = np.asarray(MODEL_BOUNDS[1]) - np.asarray(MODEL_BOUNDS[0])
    err = np.where(np.isfinite(est), np.abs(est - truth[lamp_of]), span)
    lamp_w = class_balanced_weights(np.asarray(lamps.level2, object))
    row_w = lamp_w[lamp_of] / np.bincount(lamp_of)[lamp_of]
    half = np.empty(3)
    for m in range(3):
        ok = ctx.table.valid[lamp_of, m]
        half[m] = inv_mod.weighted_quantile(err[ok, m], row_w[ok][None], (0.9,))[0, 0]
    return DirectEstimator(
        edges,
        weights,
        half,
        {
            "lamps": len(lamps.ids),
            "surface": mode,
            "scenes": "the search context's (surfaces, atmospheres, Moon, noise)",
            "quantile": 0.9,
        },
        _shape(band_values(lamps.spectra, weights)),
        tuple(lamps.ids),
        tuple(lamps.level1),
        tuple(lamps.level2),
    )
