"""Scoring of candidates: the design matrix of lamp x surface x atmosphere
candidates (`_design`), the closed-form non-negative misfit χ² with the lamp
and Moon brightness solved for, the chunked compiled scoring of pixels
against a prior (`_score`), and the band-error model (`SIGMA_REL_GRID`,
`SIGMA_FLOOR`, `FLOOR_GRID`, `log_evidence`)."""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import logsumexp

from ._conditions import Conditions
from ._surfaces import SurfaceBasis


SIGMA_REL_GRID = (0.003, 0.01, 0.03, 0.1, 0.3)
"""Relative band-error candidates `σ_rel`, chosen on inner folds."""


SIGMA_FLOOR = 1e-3
"""Absolute band-error floor relative to the pixel's mean band radiance (the
default; `fit_inversion(floor_grid=)` chooses it on inner folds)."""


FLOOR_GRID = (1e-3, 3e-3, 1e-2, 3e-2)
"""Band-error floor candidates for `fit_inversion(floor_grid=)`: with
`σ_rel` they set how the bands are weighted, from nearly by relative error
(small floor) to nearly uniformly (a floor above `σ_rel`)."""


CHUNK = 64
"""Pixels scored per compiled call (bounds memory to ~200 MB)."""


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


def _tiny(x):
    """Guard of the misfits' denominators for `x`'s dtype: 1e-300 in float64,
    the smallest normal number in float32 (where 1e-300 is 0)."""
    dt = jnp.result_type(x)
    return 1e-300 if dt == jnp.float64 else float(jnp.finfo(dt).tiny)


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
    tiny = _tiny(spp)
    if beta is not None and q is not None:
        sqq, spq, sqy = dot(q, q), dot(p, q), dot(q, yn)
        return _chi2_known(spp, spy, syy, sqq, spq, sqy, beta)
    a1 = jnp.maximum(spy, 0.0) / jnp.maximum(spp, tiny)
    chi_a = syy - a1 * spy
    if q is None:
        return chi_a
    sqq, spq, sqy = dot(q, q), dot(p, q), dot(q, yn)
    return jnp.maximum(_chi2_both(spp, spy, syy, sqq, spq, sqy, chi_a, tiny), 0.0)


def _chi2_both(spp, spy, syy, sqq, spq, sqy, chi_a, tiny):
    """Misfit of `y ≈ α p + β q` (α, β ≥ 0) from the weighted products
    `Σ w p p`, `Σ w p y`, `Σ w y y`, `Σ w q q`, `Σ w p q`, `Σ w q y` and the
    lamp-only misfit `chi_a`: the two-amplitude least squares where it is
    well conditioned and both amplitudes are non-negative (and no worse),
    else the better of lamp only and Moon only. Not clipped at 0; `tiny`
    guards the denominators."""
    det = spp * sqq - spq**2
    ok = det > 1e-12 * jnp.maximum(spp * sqq, tiny)
    dsafe = jnp.where(ok, det, 1.0)
    a2 = (sqq * spy - spq * sqy) / dsafe
    b2 = (spp * sqy - spq * spy) / dsafe
    both = ok & (a2 >= 0) & (b2 >= 0)
    chi_ab = syy - a2 * spy - b2 * sqy
    b1 = jnp.maximum(sqy, 0.0) / jnp.maximum(sqq, tiny)
    best = jnp.minimum(chi_a, syy - b1 * sqy)
    return jnp.where(both, jnp.minimum(chi_ab, best), best)


def _chi2_known(spp, spy, syy, sqq, spq, sqy, beta):
    """Misfit of `y - β q ≈ α p` (α ≥ 0, β known) from the weighted sums of
    `_chi2`: `Σw(y-βq)² = syy - 2β sqy + β² sqq`, `Σw p(y-βq) = spy - β spq`."""
    r_py = spy - beta * spq
    r_yy = syy - 2.0 * beta * sqy + beta**2 * sqq
    a1 = jnp.maximum(r_py, 0.0) / jnp.maximum(spp, _tiny(spp))
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
    tiny = _tiny(y)

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
            chi = _chi2_both(spp, spy, syy, sqq, spq, sqy, chi, tiny)
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


PREDICT_MEMORY_BYTES = 128 * 2**20
"""Default budget [bytes] of the posteriors of one chunk of
`Inversion.predict` (`predict_chunk_bytes`): pixels are predicted in chunks
that fit it, so peak memory does not grow with the pixel count. The compiled
calls add their own temporaries, bounded independently of the pixel count
(`SHARED_CHUNK`, `CHUNK` and `_chunk`'s rows for scoring, `METRIC_ROWS` rows
for the posterior metrics)."""


def _score_rows(k: int) -> int:
    """Most pixels one compiled scoring call takes for a prior of `k` lamps,
    either path: a call's input is padded up to a multiple of it."""
    kp = -(-k // K_BUCKET) * K_BUCKET
    return max(_chunk(CHUNK, kp), _chunk(SHARED_CHUNK, kp))


def predict_chunk_bytes(k: int, n_noise: int, n_pixels: int) -> int:
    """Bytes [bytes] that bound the posterior-sized arrays alive at once when
    `n_pixels` pixels are scored against a prior of `k` lamps under `n_noise`
    band-error models (float64, (S, k) per pixel each). While scoring: the
    compiled calls' log weights and their concatenation, padded to
    `K_BUCKET` lamps and to a multiple of `_score_rows` pixels (fewer than
    `n_pixels + _score_rows(k)`); while normalising: that concatenation,
    its unpadded copy, one temporary of the log-sum-exp and the posterior.
    The sum of both stages bounds each. Everything later in a prediction
    (posterior metrics, types, flag) holds less per pixel."""
    if k < 1 or n_noise < 1 or n_pixels < 0:
        raise ValueError(
            f"k ({k}) and n_noise ({n_noise}) must be >= 1, n_pixels ({n_pixels}) >= 0."
        )
    kp = -(-k // K_BUCKET) * K_BUCKET
    padded = n_pixels + _score_rows(k) - 1
    return 8 * n_noise * (2 * kp * padded + 3 * k * n_pixels)


def predict_chunk_pixels(
    k: int, n_noise: int, memory_bytes: int = PREDICT_MEMORY_BYTES
) -> int:
    """Most pixels [1] whose posterior-sized arrays (`predict_chunk_bytes`)
    fit `memory_bytes` [bytes]; at least 1 (then one pixel's own arrays
    are the bound)."""
    if memory_bytes <= 0:
        raise ValueError(f"memory_bytes must be > 0 (got {memory_bytes}).")
    fixed = predict_chunk_bytes(k, n_noise, 0)
    per_pixel = predict_chunk_bytes(k, n_noise, 1) - fixed
    return max(1, (int(memory_bytes) - fixed) // per_pixel)


def _chunk(base: int, k: int) -> int:
    """Pixels per compiled call for a prior of `k` lamps: `base` up to
    `CHUNK_PRIOR` lamps, then halved until `base·CHUNK_PRIOR/k` (at least 8)."""
    c = base
    while c > 8 and c * k > base * CHUNK_PRIOR:
        c //= 2
    return c


def _score(
    y, cand, log_ps, a, q, log_pk, noise, moon_b=None, shared=None, dtype=None,
):  # fmt: skip
    """Chunked, padded `_score_chunk`: (log evidence (n, S, k), χ² (n, S));
    `noise (S, 2)`: (`σ_rel`, floor) per band-error model.
    `moon_b` (n,): known Moon amplitudes (relative to `q`'s Moon state; NaN:
    fitted), or None (all fitted). `shared`: whether every pixel has the
    same surface candidates (`_score_chunk_shared` runs; the caller vouches
    for it); None: decided from these pixels (more than one, all the same), so
    a caller that splits an image into chunks passes the whole image's answer
    and every chunk, even of one pixel, runs the path the whole image would.
    `dtype`: of the compiled scoring, float64 (default) or float32
    (`SCORE_DTYPES`; see `Inversion.predict` for what float32 changes); the
    results are float64 either way. A float32 score that is not finite
    raises `FloatingPointError` instead of becoming a NaN posterior.
    Pruned scoring is `_prune.score`, which falls back to this."""
    dt = _score_dtype(dtype)
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
    if shared is None:
        shared = bool(
            n > 1 and np.all(cand == cand[:1]) and np.all(log_ps == log_ps[:1])
        )
    all_known = moon_b is not None and bool(np.all(np.isfinite(moon_b)))
    if shared:
        # one set of surface candidates for every pixel (mode 'unknown')
        p = jnp.einsum("kabr,sr->ksab", jnp.asarray(a), jnp.asarray(cand[0]))
        qq = None if q is None else jnp.einsum("abr,sr->sab", q, cand[0])[None]
        p = p.astype(dt)
        npad = -(-n // shared_chunk) * shared_chunk
        y = np.concatenate([y, np.ones((npad - n, y.shape[1]))]).astype(dt)
        mb = (
            None
            if moon_b is None
            else np.concatenate(
                [moon_b, np.full(npad - n, 0.0 if all_known else np.nan)]
            ).astype(dt)
        )
        # the per-chunk arguments go in as numpy slices: `jnp.asarray` of each
        # is an eager op, ~0.3 ms a call, ~8 % of evaluate's predict at 32
        # pixels per chunk; the constant ones are converted once
        const = (
            None if qq is None else jnp.asarray(qq, dt),
            jnp.asarray(log_ps[0], dt),
            jnp.asarray(log_pk, dt),
            jnp.asarray(noise, dt),
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
            lks.append(np.asarray(lk, float))
            chis.append(np.asarray(chi, float))
        return _finite(np.concatenate(lks)[:n, :, :k], np.concatenate(chis)[:n], dt)
    y, cand, log_ps = padded(y, 1.0), padded(cand, 0.0), padded(log_ps, 0.0)
    mb = None if moon_b is None else padded(moon_b, np.nan)
    cand[n:, :, 0] = 1.0
    args = (
        jnp.asarray(a, dt),
        None if q is None else jnp.asarray(q, dt),
        jnp.asarray(log_pk, dt),
        jnp.asarray(noise, dt),
    )
    lks, chis = [], []
    for i in range(0, npad, chunk):
        sl = slice(i, i + chunk)
        lk, chi = _score_chunk(
            jnp.asarray(y[sl], dt),
            jnp.asarray(cand[sl], dt),
            jnp.asarray(log_ps[sl], dt),
            *args,
            None if mb is None else jnp.asarray(mb[sl], dt),
        )
        lks.append(np.asarray(lk, float))
        chis.append(np.asarray(chi, float))
    return _finite(np.concatenate(lks)[:n, :, :k], np.concatenate(chis)[:n], dt)


SCORE_DTYPES = ("float64", "float32")
"""Dtypes the compiled scoring runs in (`_score(dtype=)`)."""


FLOAT32_TOLERANCE = {
    "posterior": 0.02,
    "type_probability": 1e-3,
    "estimate_rel": 0.01,
    "interval_rel": 0.05,
}
"""Most a float32 scoring moves a prediction from the float64 one, as
tested (`tests/test_inversion_chunked.py`): lamp posterior probabilities and
level-1/level-2 type probabilities [absolute], estimates and interval
bounds [relative]. 2-13x the largest differences measured on `bandopt
evaluate`'s default inversion (see `Inversion.predict`). The misfit has no
relative bound: where a lamp fits far better than the band error it is a
difference of nearly equal float32 sums."""


def _score_dtype(dtype):
    """`dtype` (None: float64) as a numpy dtype of `SCORE_DTYPES`."""
    dt = np.dtype(np.float64 if dtype is None else dtype)
    if dt.name not in SCORE_DTYPES:
        raise ValueError(f"dtype {dtype!r}: expected one of {SCORE_DTYPES}.")
    return dt


def _finite(lk, chi, dt):
    """`lk`, `chi`, checked finite when scored in float32 (where a misfit can
    overflow; -inf, a pruned lamp, is allowed where some lamp of the row is
    finite); float64 scores are returned as they are."""
    if dt != np.float64 and not (
        np.isfinite(lk.max(axis=-1)).all() and not np.isnan(lk).any()
        and np.isfinite(chi).all()
    ):  # fmt: skip
        raise FloatingPointError(
            "float32 scoring gave a non-finite score; use dtype=float64."
        )
    return lk, chi
