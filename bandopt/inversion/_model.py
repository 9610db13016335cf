"""The fitted inversion: `Inversion` (prior, surface basis, conditions and the
band-error model chosen on inner folds) with its posterior and its `predict`
in chunks of bounded memory, and `build_inversion` to build one on a lamp
set."""

import dataclasses

import jax.numpy as jnp
import numpy as np

from ..calibration import MISFIT_FLOOR, temper
from ..datasets.lamps import LEVEL1, LEVEL2, LEVEL2_PARENT
from ..estimate import METRICS, MIRED
from . import _prune
from ._conditions import Conditions
from ._lamps import LampSet
from ._metrics import _metrics_per_posterior, _widened
from ._prior import LampPrior, lamp_prior
from ._result import InversionResult
from ._scoring import (
    PREDICT_MEMORY_BYTES,
    SIGMA_FLOOR,
    _design,
    _normalise,
    log_evidence,
    predict_chunk_pixels,
)
from ._surfaces import SURFACE_MODES, SurfaceBasis, surface_candidates


@dataclasses.dataclass(frozen=True)
class FlagFold:
    """One inner fold of a fitted inversion's `unexplained` test: the fold's
    inversion (`model`, its prior without the fold's held-out lamps), and
    the reduced χ² at `FLAG_NOISE` of those held-out lamps' rows (`scores`)
    with their class-balanced weights (`weights`) and level-2 classes
    (`classes`)."""

    model: "Inversion"
    scores: np.ndarray
    weights: np.ndarray
    classes: tuple[str, ...]


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
    flag_folds: tuple[FlagFold, ...] = ()
    flag_level: float = 0.05
    conformal_unexplained: np.ndarray | None = None
    interval_offset_unexplained: tuple[float, ...] = ()

    @property
    def offsets(self) -> np.ndarray:
        """Offset added to each metric's posterior half-width before conformal
        scaling (3,), model space (`fit_inversion(interval_offsets=)`; zeros
        by default)."""
        return np.asarray(self.interval_offset or (0.0,) * 3, float)

    @property
    def offsets_unexplained(self) -> np.ndarray:
        """`offsets` of the intervals of pixels flagged `unexplained` when
        they have their own (`conformal_unexplained`, `fit_inversion(
        calibration="flagged")`)."""
        return np.asarray(self.interval_offset_unexplained or (0.0,) * 3, float)

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
        out = dataclasses.replace(
            self,
            conformal=np.array([c["conformal"][m] for m in METRICS]),
            interval_offset=tuple(float(c["offset"][m]) for m in METRICS),
        )
        u = self.diagnostics.get("interval_candidates_unexplained", {}).get(key)
        if u is None:  # one calibration for every pixel
            return out
        return dataclasses.replace(
            out,
            conformal_unexplained=np.array([u["conformal"][m] for m in METRICS]),
            interval_offset_unexplained=tuple(float(u["offset"][m]) for m in METRICS),
        )

    def restricted(self, keep) -> "Inversion":
        """This inversion with only the prior entries where `keep` (k,) is
        true: the same band-error model, intervals, temperatures and flag
        calibration, the prior's log weights renormalised over what is kept.
        Entries are removed, not given zero weight: the misfit is the best χ²
        over the prior's entries whatever their weight, so a zero-weight
        entry would still explain a pixel."""
        keep = np.asarray(keep, bool)
        if keep.shape != (len(self.prior.ids),):
            raise ValueError(
                f"keep: expected {len(self.prior.ids)} flags, got shape {keep.shape}."
            )
        if not keep.any():
            raise ValueError("keep: the prior would be empty.")
        pr = self.prior
        idx = np.flatnonzero(keep)
        lp = pr.log_prior[idx]
        top = float(np.max(lp))
        lp = lp - (top + np.log(np.sum(np.exp(lp - top))))
        prior = dataclasses.replace(
            pr,
            ids=tuple(pr.ids[i] for i in idx),
            spectra=pr.spectra[idx],
            level1=tuple(pr.level1[i] for i in idx),
            level2=tuple(pr.level2[i] for i in idx),
            truth=pr.truth[idx],
            valid=pr.valid[idx],
            log_prior=lp,
        )
        a, q = self.design
        return dataclasses.replace(self, prior=prior, design=(np.asarray(a)[idx], q))

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
        shared=None,
        dtype=None,
        prune=None,
    ):
        """Posterior over prior lamps (n, k) and reduced χ² (n,); with `sigmas`
        (S,) one of each per `σ_rel`: (n, S, k), (n, S) (`floors`: the band-
        error floor of each, default `sigma_floor`). With `evidence`, also
        the log marginal likelihood of each pixel's mean-normalised band
        radiances under the prior, (n,) or (n, S) (`log_evidence`).

        `moon` (n,): the Moon's brightness when it is known (from the time and
        place of the acquisition), relative to the conditions' Moon state
        (`Conditions.moon`: 0 moonless, 1 that state); NaN where unknown.
        Known, it is not fitted. Default None: fitted for every pixel.
        `shared`: whether every pixel has the same surface candidates, as
        `shared_surface` decides for a whole image of which these pixels are
        a chunk (default None: decided from these pixels). `dtype`: of the
        scoring, float64 (default None) or float32 (see `predict`).
        `prune`: see `predict`."""
        y = np.atleast_2d(np.asarray(radiance, float))
        cand, lps = self.candidates(y.shape[0], surface)
        a, q = self.design
        sig = [self.sigma_rel] if sigmas is None else list(sigmas)
        fl = np.broadcast_to(
            np.asarray(self.sigma_floor if floors is None else floors, float),
            (len(sig),),
        )
        noise = np.column_stack([np.asarray(sig, float), fl])
        lk, chi = _prune.score_pruned(
            y, cand, lps, a, q, self.prior.log_prior, noise, moon,
            shared=shared, dtype=dtype, prune=prune,
        )  # fmt: skip
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

    def known_type_p_value(
        self, radiance, surface=None, moon=None, *, shared=None, dtype=None,
        prune=None,
    ) -> np.ndarray:  # fmt: skip
        """Cross-conformal, class-conditional p-value (`Vovk2015`; Mondrian
        by level-1 type, `Vovk2005` ch. 4) that each pixel's lamp is as well
        explained as a new lamp of the type it is called, (n,). Under each
        inner fold's inversion the pixel's misfit at `flag_noise` is ranked
        among the misfits of that fold's held-out rows whose true level-1
        type is the type that fold's posterior calls the pixel (all held-out
        rows when the fold held out fewer than 1/α of that type, too few
        ever to give p < α); class-balanced weights, pooled over folds, the
        pixel counting as one more row of its reference rows' mean weight.
        Pixel and held-out rows were scored by a prior that lacks them, so on
        new lamps of known types p < α with probability about α.
        Conditioning on the called type matters: a new type is explained by
        some known type with a misfit ordinary for the pool but high for
        that type (partition 0 of the robustness suite, our bands: types left
        out of the prior flagged on 24 % of pixels against 15 % for the
        pooled ranking, at 2 % and 1 % on known types).
        The final prior's own misfits are not comparable with the folds'
        (it has more lamps, so it explains every pixel better). NaN without
        `flag_folds` (an inversion not made by `fit_inversion`). `shared`,
        `dtype`, `prune`: see `posterior`."""
        y = np.atleast_2d(np.asarray(radiance, float))
        if not self.flag_folds:
            return np.full(y.shape[0], np.nan)
        sig, floor = self.flag_noise or (self.sigma_rel, self.sigma_floor)
        above = np.zeros(y.shape[0])
        total = np.zeros(y.shape[0])
        for fold in self.flag_folds:
            post, mis = fold.model.posterior(
                y, surface, [sig], moon=moon, floors=[floor], shared=shared,
                dtype=dtype, prune=prune,
            )  # fmt: skip
            post, mis = post[:, 0], mis[:, 0]
            types = [LEVEL2_PARENT.get(c, c) for c in fold.model.prior.level2]
            labels = sorted(set(types))
            member = np.array([[t == c for c in labels] for t in types], float)
            called = np.asarray(labels, dtype=object)[np.argmax(post @ member, 1)]
            held = np.asarray(
                [LEVEL2_PARENT.get(c, c) for c in fold.classes], dtype=object
            )
            w = np.asarray(fold.weights, float)
            for c in set(called):
                px = called == c
                ref = held == c
                # fewer than 1/α rows of the type could never give p < α: then
                # the pixel is ranked among all held-out rows
                if ref.sum() + 1 <= 1.0 / self.flag_level:
                    ref = np.ones(held.size, bool)
                w_self = float(np.mean(w[ref]))
                order = np.argsort(fold.scores[ref])
                srt, wr = fold.scores[ref][order], w[ref][order]
                # weight of the reference rows with a misfit >= the pixel's
                tail = np.concatenate([np.cumsum(wr[::-1])[::-1], [0.0]])
                above[px] += tail[np.searchsorted(srt, mis[px], side="left")] + w_self
                total[px] += wr.sum() + w_self
        return np.minimum(above / np.maximum(total, 1e-300), 1.0)

    def reconstruct(self, radiance, surface=None, moon=None) -> np.ndarray:
        """Posterior-mean lamp spectrum per lumen, (n, w) [W nm⁻¹ lm⁻¹]
        (`moon`: known Moon brightness per pixel, see `posterior`)."""
        post, _ = self.posterior(radiance, surface, moon=moon)
        return post @ self.prior.spectra

    def shared_surface(self, n: int, surface=None) -> bool:
        """Whether `n` pixels with surface input `surface` (as `candidates`
        takes it) all have the same surface candidates, so that scoring
        runs its shared-candidate path: more than one pixel, and the same
        candidates for each (mode 'unknown'; one class, or classes whose
        candidates are equal; equal basis coefficients). Decided without
        building every pixel's candidates."""
        if n <= 1:
            return False
        if self.surface_mode == "unknown":
            return True
        if self.surface_mode == "class":
            if surface is None or len(surface) != n:
                return False  # `candidates` refuses it with its message
            cands = [self.basis.class_coords(t) for t in dict.fromkeys(surface)]
            return all(
                c.shape == cands[0].shape and np.all(c == cands[0]) for c in cands
            )
        coords = None if surface is None else np.asarray(surface, float)
        if coords is None or coords.ndim != 2 or coords.shape[0] != n:
            return False  # `candidates` refuses it with its message
        return bool(np.all(coords == coords[:1]))

    def type_labels(self) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """The level-1 and level-2 labels of `predict`'s probabilities (its
        `InversionResult.level1_labels`, `level2_labels`): the prior's
        level-2 classes sorted, their level-1 parents in `LEVEL1` order."""
        l2 = sorted(set(self.prior.level2))
        parents = {LEVEL2_PARENT.get(c, c) for c in l2}
        return tuple(c for c in LEVEL1 if c in parents), tuple(l2)

    def predict_chunk_pixels(self, memory_bytes: int = PREDICT_MEMORY_BYTES) -> int:
        """Pixels per chunk [1] of `predict` whose posteriors fit
        `memory_bytes` [bytes] (`predict_chunk_pixels` for this prior's size
        and the number of band-error models `predict` scores)."""
        return predict_chunk_pixels(
            len(self.prior.ids), len(self._predict_noise()), memory_bytes
        )

    def _predict_noise(self) -> list:
        """The distinct (`σ_rel`, floor) models `predict` scores, sorted."""
        joint = (self.sigma_rel, self.sigma_floor)
        return sorted({joint, self.flag_noise or joint, *self.metric_noise})

    def predict(
        self,
        radiance,
        surface=None,
        moon=None,
        *,
        chunk_pixels: int | None = None,
        memory_bytes: int = PREDICT_MEMORY_BYTES,
        dtype=None,
        prune=None,
    ) -> InversionResult:
        """Invert band radiances (n, b) (any brightness; `moon`: known Moon
        brightness per pixel, see `posterior`). Types, misfit and flag come
        from the posterior at `sigma_rel`, each metric from the posterior at
        its own `metric_noise` (one scoring per distinct value).

        Pixels go in chunks of `chunk_pixels` (default: as many as fit
        `memory_bytes` [bytes], `predict_chunk_pixels`), each reduced to its
        estimates, intervals, probabilities and flags before the next is
        scored: no posterior outlives its chunk, so memory does not grow
        with `n` beyond the results. Every pixel's result is the one an
        unchunked prediction gives (pixels are scored independently, and
        each chunk runs the scoring path the whole input would,
        `shared_surface`).

        `dtype`: of the compiled scoring, float64 (default None) or float32
        (`SCORE_DTYPES`); everything after the scoring stays float64.
        Measured on `bandopt evaluate`'s default inversion (2968 prior lamps,
        four band-error models, three flag folds; 600 moonless pixels of its
        lamp library), float32 was 1.6-1.7x faster and moved lamp posterior
        probabilities by at most 6.0e-3, level-1/level-2 type probabilities
        by 7.9e-5, the estimates by 1.4e-5 (LER, CCT) and 4.7e-3 (G)
        relative, interval bounds by 1.4e-2 relative and the `unexplained`
        p-value by 0.024; every type call and flag was the same.
        `FLOAT32_TOLERANCE` is the tested bound. The misfit is a difference
        of nearly equal weighted sums where a lamp fits far better than the
        band error, so float32 loses most there; float64 stays the default
        (the estimates' difference is above 0.1 %).

        `prune`: a tolerance in (0, 1), e.g. `PRUNE_TOLERANCE`, to score each
        pixel only against the lamps that can carry more than it of the
        posterior mass relative to the best lamp's (`_prune`: a bound, not
        an estimate; the misfit stays exact), where the surface candidates
        are shared and no Moon amplitude is fitted; None (default): every
        lamp. Lamp and type probabilities move by at most the tolerance,
        the estimates by at most it times each metric's range over the
        prior; an interval bound moves only where a posterior's cumulative
        weight lies within the tolerance of its 5 % or 95 % level
        (`PRUNE_TOLERANCE` states what is tested)."""
        y = np.atleast_2d(np.asarray(radiance, float))
        step = self._step(chunk_pixels, memory_bytes)
        if y.shape[0] <= step:
            return self._predict_chunk(y, surface, moon, None, dtype, prune)
        return InversionResult.concatenate(
            [
                r
                for _, r in self.predict_chunks(
                    y, surface, moon, chunk_pixels=step, dtype=dtype, prune=prune
                )
            ]
        )

    def predict_chunks(
        self, radiance, surface=None, moon=None, chunk_pixels=None, dtype=None,
        prune=None,
    ):  # fmt: skip
        """`predict` one chunk at a time: yields (first pixel's index,
        `InversionResult` of the chunk), so a caller that writes each chunk
        out (e.g. a map, tile by tile) holds one chunk's results at a time.
        The chunks' results are `predict`'s rows. `chunk_pixels`: default
        `predict_chunk_pixels()`; `dtype`, `prune`: see `predict`."""
        y = np.atleast_2d(np.asarray(radiance, float))
        n = y.shape[0]
        step = self._step(chunk_pixels, PREDICT_MEMORY_BYTES)
        for name, x in (("surface", surface), ("moon", moon)):
            if x is not None and len(x) != n:
                raise ValueError(f"{name}: {len(x)} entries for {n} pixels.")
        shared = self.shared_surface(n, surface)
        for i in range(0, n, step):
            yield (
                i,
                self._predict_chunk(
                    y[i : i + step],
                    None if surface is None else surface[i : i + step],
                    None if moon is None else moon[i : i + step],
                    shared,
                    dtype,
                    prune,
                ),
            )

    def _step(self, chunk_pixels, memory_bytes) -> int:
        """Pixels per chunk: `chunk_pixels`, or what fits `memory_bytes`."""
        step = (
            self.predict_chunk_pixels(memory_bytes)
            if chunk_pixels is None
            else int(chunk_pixels)
        )
        if step < 1:
            raise ValueError(f"chunk_pixels must be >= 1 (got {chunk_pixels}).")
        return step

    def _predict_chunk(
        self, y, surface, moon, shared, dtype=None, prune=None
    ) -> InversionResult:
        """`predict` of one chunk of pixels `y` (n, b) (`shared`, `dtype`,
        `prune`: see `posterior`)."""
        joint = (self.sigma_rel, self.sigma_floor)
        flag = self.flag_noise or joint
        noise = self._predict_noise()
        p_known = self.known_type_p_value(
            y, surface, moon, shared=shared, dtype=dtype, prune=prune
        )
        if len(noise) == 1:
            post, misfit = self.posterior(
                y, surface, moon=moon, shared=shared, dtype=dtype, prune=prune
            )
            return _result(self, post, misfit, p_known=p_known)
        posts, misfits = self.posterior(
            y, surface, [n[0] for n in noise], moon=moon,
            floors=[n[1] for n in noise], shared=shared, dtype=dtype,
            prune=prune,
        )  # fmt: skip
        j = noise.index(joint)
        by_metric = [posts[:, noise.index(x)] for x in self.metric_noise]
        return _result(
            self, posts[:, j], misfits[:, j], by_metric, misfits[:, noise.index(flag)],
            p_known=p_known,
        )  # fmt: skip


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


def _result(
    inv: Inversion, post, misfit, by_metric=None, flag_misfit=None, p_known=None
) -> InversionResult:
    """Estimates, intervals, flags and types of the posterior `post` (n, k);
    `by_metric`: one posterior per metric for the estimates and intervals
    (default: `post` for all three); `p_known`: the cross-conformal p-value
    (`Inversion.known_type_p_value`) that decides `unexplained` (p <
    `flag_level`) where it is finite; else `flag_misfit`, the misfit at
    `Inversion.flag_noise` (default `misfit`), above `Inversion.threshold`."""
    mean, rng, p_cct = _metrics_per_posterior(
        [post] * 3 if by_metric is None else by_metric, inv.prior
    )
    unexplained = (misfit if flag_misfit is None else flag_misfit) > inv.threshold
    if p_known is not None:
        p_known = np.asarray(p_known, float)
        unexplained = np.where(
            np.isfinite(p_known), p_known < inv.flag_level, unexplained
        )
    else:
        p_known = np.full(unexplained.shape, np.nan)
    mean_w, lo, hi = _widened(mean, rng, inv.conformal, inv.offsets)
    if inv.conformal_unexplained is not None and np.any(unexplained):
        # the prior cannot explain these pixels: intervals calibrated on
        # lamp types held out of it (fit_inversion(calibration="flagged"))
        _, lo_u, hi_u = _widened(
            mean, rng, inv.conformal_unexplained, inv.offsets_unexplained
        )
        u = np.asarray(unexplained, bool)[:, None]
        lo, hi = np.where(u, lo_u, lo), np.where(u, hi_u, hi)
    mean = mean_w
    est = mean.copy()
    est[:, 2] = np.where(p_cct >= 0.5, MIRED / mean[:, 2], np.nan)
    # mired interval [lo, hi] is CCT [MIRED/hi, MIRED/lo]
    iv = np.stack([lo, hi], axis=-1)
    iv[:, 2] = np.stack([MIRED / hi[:, 2], MIRED / lo[:, 2]], axis=-1)
    l1, l2 = (list(x) for x in inv.type_labels())
    m2 = np.array([[x == c for c in l2] for x in inv.prior.level2], float)
    p2 = post @ m2
    parents = [LEVEL2_PARENT.get(c, c) for c in l2]
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
        p_known,
    )
