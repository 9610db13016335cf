"""What is estimated and its truth: the metrics LER [lm W⁻¹], G [1] and
CCT [K], the search targets, the one rule for an undefined photometric
truth, and the model space (CCT as mired [10⁶/K]) with its physical range.

The lowest module of `bandopt.estimate`: every estimator is fitted and
bounded in this model space, and every error is measured against this
truth.
"""

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..names import CanonicalMapping
from ..photometry import (
    CCT_MAX_K,
    CCT_MIN_K,
    DUV_MAX,
    G_CAP,
    K_M_LM_PER_W,
    metrics as photometric_metrics,
)


METRICS: tuple[str, ...] = ("LER", "G", "CCT")
"""Estimated metrics, in the order of every `(..., 3)` array here."""

UNITS = {"LER": "lm/W", "G": "1", "CCT": "K"}

TARGETS: dict[str, tuple[str, ...]] = {
    "ler": ("LER",),
    "g": ("G",),
    "cct": ("CCT",),
    "all": METRICS,
}
"""Search targets and the metrics each one scores."""

MIRED = 1e6
"""`mired = MIRED / CCT[K]`."""

CCT_RANGE_K = (CCT_MIN_K, CCT_MAX_K)
"""Predicted CCTs are clipped to the range where a CCT is meaningful
(`photometry.CCT_MIN_K`-`CCT_MAX_K`), i.e. mired to 40-1000. [K]"""


def resolve_target(name: str) -> str:
    """Canonical target name (`ler`, `g`, `cct`, `all`; case and separators
    ignored, the `bandopt.names` rule)."""
    targets = CanonicalMapping({k: k for k in TARGETS})
    if name not in targets:
        raise ValueError(f"Unknown target {name!r}; expected one of {list(TARGETS)}.")
    return targets[name]


def metric_mask(target: str) -> np.ndarray:
    """Boolean (3,) mask of the metrics a target scores."""
    used = TARGETS[resolve_target(target)]
    return np.array([m in used for m in METRICS])


# ------------------------------------------------------------------------------
# Ground truth


def lamp_truth(
    spectra: Float[ArrayLike, "l w"], wavelength_nm: Float[ArrayLike, " w"]
) -> tuple[np.ndarray, np.ndarray]:
    """Photometric truth per lamp from its full spectrum.

    Returns `(values, valid)`, both `(l, 3)` in `METRICS` order: LER [lm W⁻¹]
    (380-780 nm), G [1] (capped at `photometry.G_CAP` where flagged; the cap is
    kept as a valid value) and CCT [K] (valid only where meaningful, i.e.
    `CCT_flag` False). A metric is invalid (NaN) by the rule of
    `truth_with_reasons`. Spectra must cover 380-780 nm on a 1 nm grid.
    """
    values, _ = truth_with_reasons(spectra, wavelength_nm)
    return values, np.isfinite(values)


NO_VISIBLE_LIGHT = "no light in 380-780 nm (visible power 0): undefined"


def truth_with_reasons(
    spectra: Float[ArrayLike, "l w"], wavelength_nm: Float[ArrayLike, " w"]
) -> tuple[np.ndarray, list[dict[str, str]]]:
    """The one rule for an undefined photometric truth, with its reason.

    Returns `(values, reasons)`: values `(l, 3)` in `METRICS` order, NaN where
    undefined, and per lamp a dict metric -> why it is undefined:

    - LER: no light in 380-780 nm (0/0);
    - G: no light the eye sees (∫ V S = 0 over 380-780 nm: G compares the
      blue light with it); without blue light but with visible light G is
      `G_CAP`, flagged, and valid (low-pressure sodium);
    - CCT: no light, or not meaningful: outside `CCT_MIN_K`-`CCT_MAX_K` or
      |Duv| > `DUV_MAX` (the reason gives the number).

    `bandopt metrics` and `bandopt evaluate` both report truth by this rule.
    Spectra must cover 380-780 nm on a 1 nm grid.
    """
    w = np.asarray(wavelength_nm, float)
    vis = (w >= 380.0) & (w <= 780.0)
    m = photometric_metrics(np.asarray(spectra, float)[:, vis], w[vis])
    ler, g, cct, duv = (np.asarray(m[k], float) for k in ("LER", "G", "CCT", "Duv"))
    flag = np.asarray(m["CCT_flag"], bool)
    values = np.stack([ler, g, cct], 1)
    reasons: list[dict[str, str]] = []
    for i in range(values.shape[0]):
        why: dict[str, str] = {}
        if not np.isfinite(ler[i]):
            why["LER"] = NO_VISIBLE_LIGHT
        if not ler[i] > 0:
            why["G"] = why.get("LER") or (
                "no light the eye sees (V-weighted power 0 in 380-780 nm): undefined"
            )
        if "LER" in why:
            why["CCT"] = NO_VISIBLE_LIGHT
        elif not np.isfinite(cct[i]):
            why["CCT"] = "no chromaticity for this spectrum (computation gave NaN)"
        elif flag[i] and not CCT_MIN_K <= cct[i] <= CCT_MAX_K:
            why["CCT"] = (
                f"not meaningful: {cct[i]:.0f} K lies outside {CCT_MIN_K:g}-"
                f"{CCT_MAX_K:g} K"
            )
        elif flag[i]:
            why["CCT"] = (
                f"not meaningful: |Duv| {abs(duv[i]):.3f} > {DUV_MAX:g} (too far "
                "from the Planckian locus)"
            )
        for k, name in enumerate(METRICS):
            if name in why:
                values[i, k] = np.nan
        reasons.append(why)
    return values, reasons


def to_model_space(values: ArrayLike) -> Array:
    """(…, 3) metric values -> the space models are fitted in (CCT as mired)."""
    v = jnp.asarray(values)
    cct = v[..., 2]
    ok = cct > 0
    mired = jnp.where(ok, MIRED / jnp.where(ok, cct, 1.0), jnp.nan)
    return v.at[..., 2].set(mired)


def from_model_space(values: ArrayLike) -> Array:
    """Inverse of `to_model_space` (mired -> K; a non-positive mired is NaN)."""
    return to_model_space(values)  # 10⁶/x is its own inverse


MODEL_BOUNDS = (
    (0.0, -G_CAP, MIRED / CCT_RANGE_K[1]),
    (K_M_LM_PER_W, G_CAP, MIRED / CCT_RANGE_K[0]),
)
"""Physical range in model space: LER 0-683 lm/W, G within ±its cap, CCT
1000-25000 K (as mired 40-1000). No prediction ever leaves it."""


def bound_model_space(model, lower=None, upper=None):
    """Clip (…, 3) model-space predictions to [lower, upper] (default: the
    physical range)."""
    model = jnp.asarray(model)
    lead = (1,) * (model.ndim - 1)
    lo = jnp.asarray(MODEL_BOUNDS[0] if lower is None else lower).reshape(*lead, 3)
    hi = jnp.asarray(MODEL_BOUNDS[1] if upper is None else upper).reshape(*lead, 3)
    return jnp.clip(model, lo, hi)
