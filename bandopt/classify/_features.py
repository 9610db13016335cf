"""Brightness-free features of band radiances and de-duplication of scenarios.

A pixel's band radiances scale with the lamp's illuminance, the albedo and
the pixel fill; only their *shape* tells the lamp type. Two scale-free
feature kinds:

- `"log_ratio"` (default): centred log band ratios (the centred log-ratio
  transform, `Aitchison1982`), `x_j = log(L_j/L̄ + δ) - mean_k log(L_k/L̄ + δ)`
  with `L̄` the mean band radiance of the pixel and
  `δ = bandopt.estimate.LOG_FLOOR`. Chosen because Euclidean distance
  between log ratios weighs a ratio change of 2x the same whether the bands
  are bright or dim: a sodium lamp's weak blue band (1 % of its red) and a
  warm LED's (20 %) are far apart, while in sum-normalised radiance both sit
  near 0 and their difference is swamped by the bright bands. It is
  `bandopt.estimate.log_ratio_features` (one copy).
- `"sum_normalised"`: `L_j / Σ_k L_k` (compositional, bounded in [0, 1]; more
  robust to a noisy band near zero, less sensitive to weak bands).

Both are invariant to multiplying the radiance by any positive factor. Band
radiance below zero (photon noise on a dark band) counts as 0.
"""

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..estimate import log_ratio_features
from ..names import validate_method


FEATURE_KINDS = ("log_ratio", "sum_normalised")


def resolve_kind(kind: str) -> str:
    """Canonical feature kind (case and separators ignored)."""
    return validate_method(kind, FEATURE_KINDS, "feature kind")


def features(
    radiance: Float[ArrayLike, "*batch b"], kind: str = "log_ratio"
) -> Float[Array, "*batch b"]:
    """Scale-free features of band radiances (see module docstring). [1]

    Works in JAX (differentiable; double-where at a dark pixel, whose
    features are all 0 / uniform).
    """
    kind = resolve_kind(kind)
    r = jnp.maximum(jnp.asarray(radiance), 0.0)
    if kind == "sum_normalised":
        total = jnp.sum(r, axis=-1, keepdims=True)
        ok = total > 0
        return jnp.where(ok, r / jnp.where(ok, total, 1.0), 1.0 / r.shape[-1])
    return log_ratio_features(r)


def deduplicate(
    feats: Float[ArrayLike, "n p"], groups: ArrayLike, *, rtol: float = 1e-9
) -> np.ndarray:
    """Indices (sorted) of the first row of every group of identical feature
    rows within each `groups` value (e.g. the lamp).

    Scenarios that differ only by the lighting-class scale factor (no Moon,
    no path radiance) have identical noise-free features; a nearest-neighbour
    classifier fed all of them sees copies of one point. Rows count as equal
    when they agree after rounding to `rtol` of the largest absolute feature.
    """
    x = np.asarray(feats, float)
    g = np.asarray(groups)
    if x.ndim != 2 or g.shape != (x.shape[0],):
        raise ValueError(
            f"feats must be (n, p) and groups (n,), got {x.shape} and {g.shape}."
        )
    if x.shape[0] == 0:
        return np.zeros(0, int)
    step = rtol * max(float(np.max(np.abs(x))), 1e-300)
    q = np.round(x / step).astype(np.int64)
    _, gi = np.unique(g, return_inverse=True)
    key = np.concatenate([gi[:, None].astype(np.int64), q], axis=1)
    _, first = np.unique(key, axis=0, return_index=True)
    return np.sort(first)
