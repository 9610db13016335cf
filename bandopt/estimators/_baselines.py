"""The estimators beside the inversion, under the same contract: the
regression baselines on centred log band ratios (`RidgeConfig`,
`KernelConfig`; `bandopt.estimate`) with split-conformal intervals and a
band-ratio novelty flag (`bandopt.novelty`), and the library-free direct
estimate (`DirectConfig`; `bandopt.direct`)."""

import dataclasses
from typing import ClassVar

import numpy as np

from ..classify import predict_lamp_types
from ..direct import DirectEstimator, fit_direct, tiling_edges
from ..estimate import (
    METRICS,
    MIRED,
    MODEL_BOUNDS,
    fit_estimator,
    fit_kernel_estimator,
    to_model_space,
)
from ..folds import class_balanced_weights
from ..inversion import Conditions, surface_basis, weighted_quantile
from ..novelty import RatioNovelty, fit_ratio_novelty
from ._contract import Estimates, Surface, no_report


def conformal_halfwidth(fit, rad, ctx) -> np.ndarray:
    """Class-balanced 90 % quantile of |error| (model space) of the
    regression `fit` on held-out lamps of `ctx`'s outer splits. (3,)"""
    errs, wts = [], []
    y, valid = ctx.table.scenario_truth()
    for s in ctx.splits:
        est = fit(rad, ctx.table, s.train, s.inner)
        rows = np.flatnonzero(np.isin(ctx.table.lamp_of, s.test))
        p = np.asarray(to_model_space(est.predict(rad[rows])))
        errs.append(np.where(valid[rows], np.abs(p - y[rows]), np.nan))
        lw = dict(
            zip(s.test, class_balanced_weights(ctx.table.classes[s.test]), strict=True)
        )
        per = np.bincount(ctx.table.lamp_of)[ctx.table.lamp_of[rows]]
        wts.append(np.array([lw[l] for l in ctx.table.lamp_of[rows]]) / per)
    e, w = np.vstack(errs), np.concatenate(wts)
    q = np.empty(3)
    for m in range(3):
        ok = ~np.isnan(e[:, m])
        q[m] = weighted_quantile(e[ok, m], w[ok][None], (0.9,))[0, 0]
    return q


@dataclasses.dataclass(frozen=True)
class FittedRegression:
    """A fitted regression baseline: the estimator, its interval half-widths
    `q` (model space), its novelty flag, the band set (for the lamp types,
    `classify.predict_lamp_types`) and its description."""

    estimator: object
    q: np.ndarray
    novelty: RatioNovelty
    bands: object
    description: str

    def predict(self, radiance, surface: Surface) -> Estimates:
        """Bounded estimates, estimate ± q intervals clipped to the model
        space's bounds, types from the band features; a pixel whose band
        ratios are unlike every training pixel's is flagged and given no
        type. The surface is not used: the features are band ratios."""
        pred = np.asarray(self.estimator.predict(radiance))
        model = np.asarray(to_model_space(pred))
        lo = np.clip(model - self.q, MODEL_BOUNDS[0], MODEL_BOUNDS[1])
        hi = np.clip(model + self.q, MODEL_BOUNDS[0], MODEL_BOUNDS[1])
        cct = METRICS.index("CCT")  # intervals in K: the mired bounds swap
        lo_k, hi_k = lo.copy(), hi.copy()
        lo_k[:, cct], hi_k[:, cct] = MIRED / hi[:, cct], MIRED / lo[:, cct]
        flags = [bool(f) for f in self.novelty.flags(radiance)]
        level1, level2 = predict_lamp_types(radiance, self.bands)
        reasons = [
            {"type": "unexplained: its band ratios are unlike every library lamp's"}
            if f
            else {}
            for f in flags
        ]
        return Estimates(
            values=pred.astype(float),
            interval90=np.stack([lo_k, hi_k], axis=-1),
            null_reasons=tuple(reasons),
            unexplained=tuple(flags),
            level1=tuple(None if f else a for f, a in zip(flags, level1, strict=True)),
            level2=tuple(None if f else b for f, b in zip(flags, level2, strict=True)),
            level1_probabilities=(None,) * len(flags),
            extra=({},) * len(flags),
        )

    def report(self) -> dict:
        return no_report()


@dataclasses.dataclass(frozen=True)
class RidgeConfig:
    """Ridge regression on centred log band ratios (`estimate.fit_estimator`:
    feature degree and strength chosen by inner cross-validation)."""

    name: ClassVar[str] = "ridge"
    own_lamps: ClassVar[bool] = False
    needs_surface: ClassVar[bool] = False

    def check(self, bands) -> None:
        """Every band set will do."""

    def fit(self, ctx, bands, *, surface_mode: str, own=None) -> FittedRegression:
        return _fit_regression(self.name, fit_estimator, ctx, bands)


@dataclasses.dataclass(frozen=True)
class KernelConfig:
    """Kernel ridge regression on centred log band ratios
    (`estimate.fit_kernel_estimator`)."""

    name: ClassVar[str] = "kernel"
    own_lamps: ClassVar[bool] = False
    needs_surface: ClassVar[bool] = False

    def check(self, bands) -> None:
        """Every band set will do."""

    def fit(self, ctx, bands, *, surface_mode: str, own=None) -> FittedRegression:
        return _fit_regression(self.name, fit_kernel_estimator, ctx, bands)


def _fit_regression(name, fit, ctx, bands) -> FittedRegression:
    """A regression baseline trained on every scored lamp of `ctx` (inner
    folds: its outer splits), its intervals and its novelty flag."""
    all_lamps = np.arange(ctx.table.n_lamps)
    splits = ctx.folds.outer()
    rad = ctx.radiance(bands)
    est = fit(rad, ctx.table, all_lamps, splits)
    q = conformal_halfwidth(fit, rad, ctx)
    novelty = fit_ratio_novelty(rad, ctx.table, all_lamps, splits)
    desc = (
        f"{name} regression on centred log band ratios trained on "
        f"{ctx.table.n_lamps} scored library lamps, bounded to their range; 90 % "
        "intervals: estimate +- the class-balanced 90 % quantile of held-out "
        "lamps' |error| (split-conformal); unexplained: band ratios farther "
        "from every training pixel than the class-balanced "
        f"{novelty.quantile:.0%} of held-out lamps' pixels are (bandopt.novelty), "
        "and then no type is given"
    )
    return FittedRegression(est, q, novelty, bands, desc)


@dataclasses.dataclass(frozen=True)
class FittedDirect:
    """A fitted direct estimate (`direct.DirectEstimator`) with the grid of
    its scenes and its description."""

    model: DirectEstimator
    wavelength_nm: np.ndarray
    description: str

    def predict(self, radiance, surface: Surface) -> Estimates:
        """The scene has no atmosphere and no Moon; the surface divided out is
        what the estimator knows of it (unknown: the library's mean)."""
        grid = self.wavelength_nm
        known = (
            surface_basis(grid).mean
            if surface.mode == "unknown"
            else surface.reflectance
        )
        return Estimates.from_rows(
            self.model.rows(radiance, Conditions.clear(grid), known)
        )

    def report(self) -> dict:
        return no_report()


@dataclasses.dataclass(frozen=True)
class DirectConfig:
    """The library-free direct estimate (`bandopt.direct`): contiguous bands
    tiling 380-780 nm read as a spectrum once the surface is divided out."""

    name: ClassVar[str] = "direct"
    own_lamps: ClassVar[bool] = False
    needs_surface: ClassVar[bool] = True

    def check(self, bands) -> None:
        """Refuses bands that do not tile 380-780 nm (`direct.tiling_edges`)."""
        tiling_edges(bands)

    def fit(self, ctx, bands, *, surface_mode: str, own=None) -> FittedDirect:
        model = fit_direct(ctx, bands, surface_mode)
        half = model.halfwidth
        desc = (
            "library-free direct estimate (bandopt.direct): the band values read "
            "as a spectrum constant over each band once the surface is divided "
            + (
                "out (surface unknown: divided by the library's mean reflectance; "
                "expect large errors, results/estimate_bands)"
                if surface_mode == "unknown"
                else f"out (surface {surface_mode})"
            )
            + "; no lamp trains it; 90 % intervals: estimate +- the class-balanced "
            f"90 % quantile of the absolute error of the {model.calibration['lamps']} "
            "scored library lamps on the search scenes with the same surface "
            f"knowledge (LER {half[0]:.3g} lm/W, G {half[1]:.3g}, CCT "
            f"{half[2]:.3g} mired)"
        )
        return FittedDirect(model, np.asarray(ctx.wavelength_nm, float), desc)
