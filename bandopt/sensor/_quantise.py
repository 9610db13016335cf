"""Radiometric quantisation: band radiance to digital numbers and back.

    DN = clip(round((L - L_min) · DN_max / (L_max - L_min)), 0, DN_max),
    DN_max = 2^bits - 1,

with detection limit `L_min`, saturation `L_max`. This is what thesis Eqs.
2.20-2.21 intend: as printed, `DN = (L - b) · c` with offset `b = L_min` and
gain `c = (L_max - L_min) / DN_max`, which is dimensionally muddled (c is
radiance per DN, so `(L - b) · c` has units radiance² per DN); the gain must
be its reciprocal, `DN_max / (L_max - L_min)`, and the result rounded and
clipped to `[0, DN_max]`.

DNs are returned as floats holding integer values (so they stay in the JAX
dtype of the input and can pass through `quantise_ste`).
"""

import jax.lax as lax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float


def _dn_max(bit_depth: int) -> float:
    if (
        isinstance(bit_depth, bool)
        or not isinstance(bit_depth, int)
        or not (1 <= bit_depth <= 32)
    ):
        raise ValueError(f"bit_depth must be an int in [1, 32], got {bit_depth!r}.")
    return float(2**bit_depth - 1)


def _check_range(detection_limit, saturation):
    try:
        ok = float(saturation) > float(detection_limit)
    except TypeError:  # traced values: the caller's responsibility
        return
    if not ok:
        raise ValueError(
            f"saturation ({saturation}) must exceed detection_limit "
            f"({detection_limit})."
        )


def _scaled(radiance, detection_limit, saturation, bit_depth):
    dn_max = _dn_max(bit_depth)
    _check_range(detection_limit, saturation)
    gain = dn_max / (jnp.asarray(saturation) - jnp.asarray(detection_limit))  # [DN/L]
    return (jnp.asarray(radiance) - detection_limit) * gain, dn_max


def quantise(
    radiance: Float[ArrayLike, "*batch"],
    detection_limit: ArrayLike,
    saturation: ArrayLike,
    bit_depth: int,
) -> Float[Array, "*batch"]:
    """Digital numbers `clip(round((L - L_min) DN_max / (L_max - L_min)), 0, DN_max)`.

    Monotone non-decreasing in radiance; 0 at and below `detection_limit`,
    `2^bit_depth - 1` at and above `saturation`. Zero gradient almost
    everywhere: use `quantise_ste` inside a loss.

    **Arguments:**

    - `radiance`: band-averaged radiance. [W m-2 sr-1 nm-1]
    - `detection_limit`: `L_min`. [W m-2 sr-1 nm-1]
    - `saturation`: `L_max`. [W m-2 sr-1 nm-1]
    - `bit_depth`: bits per sample (Python int). [bit]
    """
    y, dn_max = _scaled(radiance, detection_limit, saturation, bit_depth)
    return jnp.clip(jnp.round(y), 0.0, dn_max)


def quantise_ste(
    radiance: Float[ArrayLike, "*batch"],
    detection_limit: ArrayLike,
    saturation: ArrayLike,
    bit_depth: int,
) -> Float[Array, "*batch"]:
    """`quantise` forward; straight-through gradient backward.

    The rounding is treated as the identity in the backward pass, the clip is
    kept: the gradient is the gain `DN_max / (L_max - L_min)` inside the
    range and 0 where the sensor is below its detection limit or saturated.
    """
    y, dn_max = _scaled(radiance, detection_limit, saturation, bit_depth)
    y_clip = jnp.clip(y, 0.0, dn_max)
    return y_clip + lax.stop_gradient(jnp.round(y_clip) - y_clip)


def dequantise(
    dn: Float[ArrayLike, "*batch"],
    detection_limit: ArrayLike,
    saturation: ArrayLike,
    bit_depth: int,
) -> Float[Array, "*batch"]:
    """Radiance `L_min + DN (L_max - L_min) / DN_max` (inverse of `quantise`
    within half a step inside the range). [W m-2 sr-1 nm-1]"""
    dn_max = _dn_max(bit_depth)
    _check_range(detection_limit, saturation)
    step = (jnp.asarray(saturation) - jnp.asarray(detection_limit)) / dn_max
    return jnp.asarray(detection_limit) + jnp.asarray(dn) * step


def radiance_step(
    detection_limit: ArrayLike,
    saturation: ArrayLike,
    bit_depth: int,
) -> Float[Array, "..."]:
    """Radiance of one DN, `(L_max - L_min) / DN_max` (radiometric resolution).
    Times `responsivity` it gives `electrons_per_dn` for the noise model.
    [W m-2 sr-1 nm-1]"""
    _check_range(detection_limit, saturation)
    return (jnp.asarray(saturation) - jnp.asarray(detection_limit)) / _dn_max(bit_depth)
