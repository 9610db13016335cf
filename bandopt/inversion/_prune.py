"""Pruned scoring: score each pixel only against the prior lamps whose log
evidence can come within a margin `D` of the best lamp's, with the posterior
mass left out bounded (`PRUNE_TOLERANCE`, `prune_margin`).

A first pass computes every candidate's misfit under one band-error model,
the broadest (`_broad`: the largest `σ_rel` and floor of the models
scored), whose band errors are at least every model's, so its misfit `χ²_B`
is at most every model's, candidate by candidate (a larger error lowers
every weighted residual, so also the least one). With `lps_c` the surface
and atmosphere candidates' log prior, each lamp's log evidence under every
model is then at most `U_k = log π_k + log Σ_c exp(lps_c) - min_c χ²_B,kc/2`.
The lamp with the largest `U` is scored exactly under each model: its log
evidence `L⁰_m` is a lower bound of the best lamp's. A lamp is pruned when
`U_k < min_m L⁰_m - D` and its least `χ²_B` is no lower than the top
lamp's least misfit under any model, so the misfit (the least χ² over the
whole prior) is unchanged, and the mass left out under model `m`, relative
to the best lamp's, is `Σ_pruned exp(U_k - L_m) ≤ n_pruned e^{-D}`;
`_score_pruned` returns it per pixel and model. The survivors are gathered
per pixel (rows sorted by their count, padded to a power of two of lamps)
and scored exactly. It needs no Moon amplitude to fit (then the least
squares over two amplitudes has no such closed-form bound here): no Moon
term, or every pixel's told."""

import math

import jax
import jax.numpy as jnp
import numpy as np

from ._scoring import _finite, _log_sum_chi, _score, _score_dtype, _tiny


PRUNE_TOLERANCE = 1e-6
"""Default bound on the posterior mass pruning leaves out, relative to the
most probable lamp's (so also to the whole posterior's): the margin is
`prune_margin(k, PRUNE_TOLERANCE)`, `log(k / tolerance)` (21.8 in log
evidence, 43.6 in χ², for a prior of 2968 lamps)."""


PRUNE_ROWS = 16
"""Pixels per compiled call of the survivors' scoring (pixels sorted by
their survivor count, so a call's padding follows its own pixels)."""


PRUNE_FIRST_ROWS = 128
"""Pixels per compiled call of the first pass (the centres' scoring)."""


def prune_margin(k: int, tolerance: float) -> float:
    """Margin `D` [log evidence] below the best lamp under which a prior of
    `k` lamps leaves out at most `tolerance` of the posterior mass,
    relative to the best lamp's: `k e^{-D} = tolerance`."""
    if not 0 < tolerance < 1:
        raise ValueError(f"prune tolerance must be in (0, 1) (got {tolerance}).")
    return math.log(max(k, 1) / tolerance)


def _broad(noise) -> np.ndarray:
    """The band-error model with the largest `σ_rel` and the largest floor of
    `noise (S, 2)`: its band errors are at least every model's, so its
    misfits are at most theirs, candidate by candidate."""
    return np.asarray(noise, float).max(axis=0)


@jax.jit
def _first_pass(y, pf, pq, qf, lps, log_pk, lse_ps, broad, noise, beta):
    """Per pixel of `y (n, b)`: the bound `U (n, k)` of each lamp's log
    evidence under every model of `noise`, its least χ² under the `broad`
    model `(n, k)`, and the exact log evidence and least χ² of the lamp with
    the largest bound under each model (n, S) (a lower bound of the best
    lamp's). `pf`, `pq (k c, b)`: the candidates' lamp terms and their
    products with the Moon's `qf (c, b)`; `beta (n,)` the told Moon."""
    k = log_pk.shape[0]
    c = lps.shape[0]
    hi = jax.lax.Precision.HIGHEST
    m = jnp.mean(jnp.abs(y), axis=1, keepdims=True)
    mm = jnp.where(m > 0, m, 1.0)
    yn = y / mm
    bt = (beta / mm[:, 0])[:, None]
    tiny = _tiny(y)

    def chi_of(nf):  # (n, k, c) misfits over every candidate, model nf
        w = 1.0 / (nf[0] * jnp.abs(yn) + nf[1]) ** 2
        wy = w * yn
        spp = jnp.matmul(w, (pf * pf).T, precision=hi)
        r_py = jnp.matmul(
            jnp.concatenate([wy, -bt * w], axis=1),
            jnp.concatenate([pf, pq], axis=1).T,
            precision=hi,
        )
        syy = jnp.sum(wy * yn, axis=1)[:, None]
        sqq = jnp.matmul(w, (qf * qf).T, precision=hi)
        sqy = jnp.matmul(wy, qf.T, precision=hi)
        r_yy = syy - 2.0 * bt * sqy + bt**2 * sqq  # (n, c)
        chi = r_yy[:, None, :] - jnp.square(
            jnp.maximum(r_py.reshape(-1, k, c), 0.0)
        ) / jnp.maximum(spp.reshape(-1, k, c), tiny)
        return jnp.maximum(chi, 0.0)

    chimin = jnp.min(chi_of(broad), axis=-1)  # (n, k)
    u = log_pk[None] + lse_ps - 0.5 * chimin
    top = jnp.argmax(u, axis=1)  # (n,)
    pt = pf.reshape(k, c, -1)[top]  # (n, c, b)
    yc = yn[:, None, :] - bt[:, :, None] * qf[None]  # (n, c, b)

    def exact(nf):  # the top lamp's log evidence and least χ²
        w = (1.0 / (nf[0] * jnp.abs(yn) + nf[1]) ** 2)[:, None, :]
        syy = jnp.sum(w * yc * yc, axis=-1)
        spy = jnp.sum(w * yc * pt, axis=-1)
        spp = jnp.sum(w * pt * pt, axis=-1)
        chi = syy - jnp.square(jnp.maximum(spy, 0.0)) / jnp.maximum(spp, tiny)
        lk, cmin = _log_sum_chi(jnp.maximum(chi, 0.0), lps[None])
        return lk + log_pk[top], cmin

    l0, c0 = jax.lax.map(exact, noise)
    return u, chimin, top, l0.T, c0.T


@jax.jit
def _score_gathered(y, pg, logp, lps, noise, beta, qf):
    """Exact log evidence (n, S, K) and least χ² (n, S) of each pixel of
    `y (n, b)` against its own gathered lamps `pg (n, b, K, c)` (bands
    first, so the elementwise work runs along `K c`) with log prior
    `logp (n, K)` (-inf: padding): the shared path's told misfit (Moon
    amplitude `beta (n,)`, terms `qf (c, b)`), per pixel."""
    m = jnp.mean(jnp.abs(y), axis=1, keepdims=True)
    mm = jnp.where(m > 0, m, 1.0)
    yn = y / mm
    bt = beta / mm[:, 0]
    yc = (yn[:, :, None] - bt[:, None, None] * qf.T[None])[:, :, None, :]
    pad = ~jnp.isfinite(logp)
    tiny = _tiny(y)

    def at(nf):
        w = (1.0 / (nf[0] * jnp.abs(yn) + nf[1]) ** 2)[:, :, None, None]
        syy = jnp.sum(w * yc * yc, axis=1)  # (n, 1, c)
        spp = jnp.sum(w * pg * pg, axis=1)  # (n, K, c)
        spy = jnp.sum(w * yc * pg, axis=1)
        chi = syy - jnp.square(jnp.maximum(spy, 0.0)) / jnp.maximum(spp, tiny)
        lk, cmin = _log_sum_chi(jnp.maximum(chi, 0.0), lps[None, None])
        lk = jnp.where(pad, -jnp.inf, lk + jnp.where(pad, 0.0, logp))
        return lk, jnp.min(jnp.where(pad, jnp.inf, cmin), axis=1)

    lk, chi = jax.lax.map(at, noise)
    return jnp.moveaxis(lk, 0, 1), jnp.moveaxis(chi, 0, 1)


def _score_pruned(y, p, lps, log_pk, noise, tolerance, beta=None, qf=None, dtype=None):
    """Pruned scoring of pixels `y (n, b)` against the shared candidates'
    band terms `p (k, c, b)` (`lps (c,)` their log prior, `log_pk (k,)` the
    lamps'), under each band-error model of `noise (S, 2)`; `beta (n,)`: the
    told Moon amplitudes with its band terms `qf (c, b)` (None: no Moon
    term). Returns the log evidence (n, S, k), -inf for pruned lamps, the
    least χ² (n, S), exact, and the pruned mass relative to the best lamp's
    (n, S), each at most `tolerance`. The first pass runs in float64; the
    survivors in `dtype`."""
    y = np.asarray(y, float)
    n, (k, c, b) = y.shape[0], p.shape
    noise = np.asarray(noise, float)
    margin = prune_margin(k, tolerance)
    if qf is None:  # no Moon term: a zero one, told zero
        qf, beta = np.zeros((c, b)), np.zeros(n)
    beta = np.asarray(beta, float)
    top_lps = float(np.max(lps))
    lse_ps = top_lps + math.log(float(np.sum(np.exp(lps - top_lps))))
    f64 = jnp.float64
    pf = np.asarray(p, float).reshape(k * c, b)
    const = (
        jnp.asarray(pf, f64),
        jnp.asarray((p * qf[None]).reshape(k * c, b), f64),
        jnp.asarray(qf, f64),
        jnp.asarray(lps, f64),
        jnp.asarray(log_pk, f64),
        lse_ps,
        jnp.asarray(_broad(noise), f64),
        jnp.asarray(noise, f64),
    )
    rows = PRUNE_FIRST_ROWS
    npad = -(-n // rows) * rows
    yp = np.concatenate([y, np.ones((npad - n, b))])
    bp = np.concatenate([beta, np.zeros(npad - n)])
    parts = [
        [np.asarray(x) for x in _first_pass(yp[i : i + rows], *const, bp[i : i + rows])]
        for i in range(0, npad, rows)
    ]
    u, chimin, top, l0, c0 = (np.concatenate(x)[:n] for x in zip(*parts, strict=True))
    # pruned: bound below every model's margin under the top lamp, and
    # misfits no lower than the top lamp's least under any model
    alive = (u >= np.min(l0, axis=1, keepdims=True) - margin) | (
        chimin < np.max(c0, axis=1, keepdims=True)
    )
    alive[np.arange(n), top] = True
    count = alive.sum(axis=1)
    order = np.argsort(count, kind="stable")
    idx = np.argsort(~alive, axis=1, kind="stable")  # survivors first
    lk = np.full((n, noise.shape[0], k), -np.inf)
    chi = np.empty((n, noise.shape[0]))
    dt = np.dtype(dtype or np.float64)
    pt = np.ascontiguousarray(np.asarray(p, dt).transpose(0, 2, 1))  # (k, b, c)
    const = (jnp.asarray(lps, dt), jnp.asarray(noise, dt))
    qd = jnp.asarray(qf, dt)
    for i in range(0, n, PRUNE_ROWS):
        rows = order[i : i + PRUNE_ROWS]
        width = min(k, 1 << max(3, int(count[rows].max() - 1).bit_length()))
        sel = idx[rows, :width]  # (r, K)
        keep = np.arange(width)[None] < count[rows][:, None]
        pad = PRUNE_ROWS - rows.size
        sel_p = np.concatenate([sel, np.zeros((pad, width), int)])
        logp = np.where(keep, log_pk[sel], -np.inf)
        logp = np.concatenate([logp, np.zeros((pad, width))])  # padding rows
        ys = np.concatenate([y[rows], np.ones((pad, b))])
        bs = np.concatenate([beta[rows], np.zeros(pad)])
        lks, chis = _score_gathered(
            jnp.asarray(ys, dt),
            jnp.asarray(pt[sel_p].transpose(0, 2, 1, 3)),
            jnp.asarray(logp, dt),
            *const,
            jnp.asarray(bs, dt),
            qd,
        )
        lks = np.asarray(lks, float)[: rows.size]  # (r, S, K)
        chi[rows] = np.asarray(chis, float)[: rows.size]
        r_i, k_i = np.nonzero(keep)
        lk[rows[r_i], :, sel[r_i, k_i]] = lks[r_i, :, k_i]
    best = lk.max(axis=-1, keepdims=True)  # (n, S, 1), >= l0
    mass = np.sum(np.exp(np.where(alive[:, None], -np.inf, u[:, None] - best)), axis=-1)
    return lk, chi, mass


def score_pruned(
    y, cand, log_ps, a, q, log_pk, noise, moon_b=None, shared=None, dtype=None,
    prune=None,
):  # fmt: skip
    """`_scoring._score` with `prune`: a tolerance in (0, 1) to score only the
    lamps that can carry more than it of the posterior mass (pruned lamps'
    log evidence is -inf, the misfit stays exact), where every pixel shares
    its surface candidates and no Moon amplitude is fitted (no Moon term, or
    every pixel's told); elsewhere, or with `prune` None, `_score` of every
    lamp."""
    if prune is None:
        return _score(
            y, cand, log_ps, a, q, log_pk, noise, moon_b, shared=shared, dtype=dtype
        )
    y = np.asarray(y, float)
    cand = np.asarray(cand, float)
    noise = np.asarray(noise, float)
    n, k = y.shape[0], a.shape[0]
    if shared is None:
        shared = bool(
            n > 1 and np.all(cand == cand[:1]) and np.all(log_ps == log_ps[:1])
        )
    mb = None if moon_b is None else np.asarray(moon_b, float).reshape(-1)
    if q is None and mb is not None and not np.any(np.nan_to_num(mb, nan=0.0) != 0):
        mb = None  # no Moon term and no amplitude: as `_score` reads it
    all_known = mb is not None and bool(np.all(np.isfinite(mb)))
    if not (shared and (q is None or all_known)) or noise.ndim != 2:
        return _score(
            y, cand, log_ps, a, q, log_pk, noise, moon_b, shared=shared, dtype=dtype
        )
    dt = _score_dtype(dtype)
    c0 = np.asarray(cand[0], float)
    pk = np.einsum("kabr,sr->ksab", np.asarray(a[:k], float), c0)
    s_, a_ = pk.shape[1:3]
    qf = None if q is None else np.einsum("abr,sr->sab", q, c0)
    qf = None if qf is None else qf.reshape(s_ * a_, -1)
    lk, chi, _ = _score_pruned(
        y,
        pk.reshape(k, s_ * a_, -1),
        np.repeat(np.asarray(log_ps[0], float), a_),
        np.asarray(log_pk[:k], float),
        noise,
        prune,
        None if qf is None else mb,
        qf,
        dt,
    )
    return _finite(lk, chi, dt)
