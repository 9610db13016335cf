"""CCT and Duv from CIE 1960 (u, v) for `bandopt.photometry`: Ohno 2013
(`Ohno2014`) and Robertson 1968 (`Robertson1968`) as colour-science computes
them (`Mansencal2025`), and the safe division and root they share with it.

Pure JAX; every division and root is a double `where`, so gradients stay finite.
"""

import functools

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Bool, Float


def safe_div(num: ArrayLike, den: Array, ok: Array) -> Array:
    """`num / den` where `ok`, 0 elsewhere, with finite gradients."""
    return jnp.where(ok, num / jnp.where(ok, den, 1.0), 0.0)


def safe_sqrt(x: Array) -> Array:
    pos = x > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, x, 1.0)), 0.0)


def _first_argmin(distance, count: int) -> Array:
    """`jnp.argmin` over j < `count` of `distance(j)` (first minimum), as a
    loop of elementwise minima: XLA on CPU vectorises those, not the (value,
    index) reduction of `argmin`, which is ~10x slower here."""

    def step(carry, j):
        best, index = carry
        d = distance(j)
        closer = d < best
        return (jnp.where(closer, d, best), jnp.where(closer, j, index)), None

    first = distance(0)
    init = (first, jnp.zeros(first.shape, jnp.int32))
    (_, index), _ = jax.lax.scan(
        step, init, jnp.arange(1, count, dtype=jnp.int32), unroll=8
    )
    return index


@functools.partial(jax.jit, static_argnames="stride")
def ohno2013(
    u: Float[Array, " n"],
    v: Float[Array, " n"],
    table: Float[Array, "t 3"],
    stride: int,
) -> tuple[Float[Array, " n"], Float[Array, " n"], Bool[Array, " n"]]:
    """CCT, Duv and "nearest row not at the table ends", as colour's
    `uv_to_CCT_Ohno2013` (colour 0.4.7) computes them.

    Nearest table row by a two-level search: every `stride`-th row, then the
    `2 stride + 1` rows around the coarse winner. Exact whenever the distance to
    the table rows is unimodal along the locus within ± `stride` rows of the
    nearest one, as it is for |Duv| <= 0.05 (checked against a brute-force search
    in the tests). Then Ohno's triangular solution, replaced by the parabolic one
    where the triangular |Duv| >= 0.002. The parabola is written about the middle
    row (algebraically colour's global form, better conditioned in float32).
    """
    t_k, t_u, t_v = table[:, 0], table[:, 1], table[:, 2]
    n_rows = table.shape[0]
    width = 2 * stride + 1
    su, sv = jax.lax.stop_gradient(u), jax.lax.stop_gradient(v)  # an index

    def squared(rows):
        return (su - t_u[rows]) ** 2 + (sv - t_v[rows]) ** 2

    coarse = _first_argmin(lambda j: squared(j * stride), -(-n_rows // stride))
    start = jnp.clip(coarse * stride - stride, 0, n_rows - width)
    nearest = start + _first_argmin(lambda k: squared(start + k), width)
    interior = (nearest > 0) & (nearest < n_rows - 1)
    i = jnp.clip(nearest, 1, n_rows - 2)

    def row(k):
        d = safe_sqrt((u - t_u[k]) ** 2 + (v - t_v[k]) ** 2)
        return t_k[k], t_u[k], t_v[k], d

    tp, up, vp, dp = row(i - 1)
    ti, _, _, di = row(i)
    tn, un, vn, dn = row(i + 1)

    # Triangular solution.
    ell = jnp.hypot(un - up, vn - vp)
    x = (dp**2 - dn**2 + ell**2) / (2.0 * ell)
    cct_t = tp + (tn - tp) * (x / ell)
    v_tx = vp + (vn - vp) * (x / ell)
    sign = jnp.sign(v - v_tx)
    duv_t = safe_sqrt(dp**2 - x**2) * sign

    # Parabolic solution, d(T) = a (T - ti)² + b (T - ti) + di.
    h1, h2 = tp - ti, tn - ti
    a = ((dn - di) / h2 - (dp - di) / h1) / (h2 - h1)
    b = (dp - di) / h1 - a * h1
    a_ok = a != 0
    cct_p = ti - safe_div(b, 2.0 * a, a_ok)
    duv_p = (di - safe_div(b**2, 4.0 * a, a_ok)) * sign

    parabolic = jnp.abs(duv_t) >= 0.002
    return (
        jnp.where(parabolic, cct_p, cct_t),
        jnp.where(parabolic, duv_p, duv_t),
        interior,
    )


@jax.jit
def robertson1968(
    u: Float[Array, " n"], v: Float[Array, " n"], lines: Float[Array, "31 4"]
) -> tuple[Float[Array, " n"], Float[Array, " n"], Bool[Array, " n"]]:
    """CCT, Duv and "a crossing isotemperature line was found", as colour's
    `uv_to_CCT_Robertson1968` (colour 0.4.7) computes them: the first line
    (from 100000 K down) the point lies on or beyond, linear interpolation in
    mired with the previous line, Duv along the interpolated line direction.
    Without a crossing (below 1667 K) colour returns 1667 K: flagged here.
    """
    mired, lu, lv, slope = lines[:, 0], lines[:, 1], lines[:, 2], lines[:, 3]
    length = jnp.hypot(1.0, slope)
    du, dv = 1.0 / length, slope / length
    uu = u[:, None] - lu[None, 1:]
    vv = v[:, None] - lv[None, 1:]
    dt = -uu * dv[None, 1:] + vv * du[None, 1:]  # (n, 30)
    crossed = dt <= 0
    found = jnp.any(crossed, -1)
    i = jnp.where(found, jnp.argmax(crossed, -1) + 1, 30)

    def at(k):
        return jnp.take_along_axis(dt, jnp.clip(k, 0, 29)[:, None], -1)[:, 0]

    dt_cur = -jnp.minimum(at(i - 1), 0.0)
    dt_prev = at(i - 2)
    ok = (i > 1) & (dt_prev + dt_cur > 0)
    f = safe_div(dt_cur, dt_prev + dt_cur, ok)

    m = mired[i - 1] * f + mired[i] * (1.0 - f)
    cct = safe_div(1.0e6, m, m > 0)
    u_i = lu[i - 1] * f + lu[i] * (1.0 - f)
    v_i = lv[i - 1] * f + lv[i] * (1.0 - f)
    du_i = du[i] * (1.0 - f) + du[i - 1] * f
    dv_i = dv[i] * (1.0 - f) + dv[i - 1] * f
    norm = jnp.hypot(du_i, dv_i)
    duv = -((u - u_i) * du_i + (v - v_i) * dv_i) / norm
    return cct, duv, found
