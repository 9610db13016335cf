"""Quantisers between a detection limit and a saturation: linear, two gain
stages, square-root (noise-matched) companding.

Each maps band-averaged radiance to a continuous code `y = g(L)` with `g`
strictly increasing on `[L_min, L_max]`, `g(L_min) = 0`, `g(L_max) = DN_max =
2^bits - 1`; `encode` is `clip(round(g(clip(L))), 0, DN_max)` and `decode` is
`g⁻¹(DN)`. So DN is monotone in radiance, clipped at both ends, and
`decode(encode(L))` is within half a local step of L inside the range.

- `LinearQuantiser`: `g = DN_max (L - L_min)/(L_max - L_min)` (thesis Eqs.
  2.20-2.21 as corrected in `bandopt.sensor.quantise`).
- `TwoGainQuantiser`: two gain stages sharing one code space of `bits` bits
  (the top bit says which stage): the high-gain stage spends the lower half
  of the codes on `[L_min, L_knee]`, the low-gain stage the upper half on
  `[L_knee, L_max]`. A designer's alternative to more bits; the VIIRS Day/Night
  Band switches between three gain stages (`Miller2013`).
- `SqrtQuantiser`: noise-matched companding. With photon and floor noise
  `σ_L(L) = sqrt(R L + σ0²)/R` in radiance (R the responsivity), the code
  `g ∝ sqrt(R L + σ0²)` makes every step the same fraction of the local noise
  (`dL/dy = σ_L · 2 (s_max - s_min)/DN_max`): the generalised Anscombe
  variance-stabilising transform (`Anscombe1948`). Read noise and dark current
  enter through σ0.

All parameters are per band arrays; bit depth is static. Work in float64 for
16 bits and more (float32 has 24 mantissa bits, enough for codes but not for
`g⁻¹` round trips at high dynamic range).
"""

import abc
import itertools

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ..names import canonical_key
from ..sensor import SensorParams


def _dn_max(bits: int) -> float:
    if isinstance(bits, bool) or not isinstance(bits, int) or not 1 <= bits <= 32:
        raise ValueError(f"bits must be an int in [1, 32], got {bits!r}.")
    return float(2**bits - 1)


def _check_order(*arrays_and_names):
    """Raise unless the concrete arrays strictly increase in the given order."""
    try:
        vals = [jnp.asarray(a) for a, _ in arrays_and_names]
        for (a, na), (b, nb) in itertools.pairwise(arrays_and_names):
            if not bool(jnp.all(jnp.asarray(b) > jnp.asarray(a))):
                raise ValueError(f"{nb} must exceed {na} in every band.")
        return vals
    except TypeError:  # traced values: the caller's responsibility
        return None


def _bc(param, like):
    """Broadcast a per-band parameter `(b,)` to `like`'s shape `(*batch, b)`
    explicitly (the project runs with rank promotion set to raise)."""
    like = jnp.asarray(like)
    return jnp.broadcast_to(jnp.asarray(param), like.shape)


class AbstractQuantiser(eqx.Module):
    """A monotone companding quantiser (module docstring)."""

    detection_limit: eqx.AbstractVar[Float[Array, " b"]]
    saturation: eqx.AbstractVar[Float[Array, " b"]]
    bits: eqx.AbstractVar[int]

    @property
    def dn_max(self) -> float:
        return _dn_max(self.bits)

    @abc.abstractmethod
    def transfer(
        self, radiance: Float[ArrayLike, "*batch b"]
    ) -> Float[Array, "*batch b"]:
        """Continuous code `g(L)` for L in `[L_min, L_max]`. [DN]"""

    @abc.abstractmethod
    def inverse(self, code: Float[ArrayLike, "*batch b"]) -> Float[Array, "*batch b"]:
        """`g⁻¹(y)` for y in `[0, DN_max]`. [W m⁻² sr⁻¹ nm⁻¹]"""

    def encode(
        self, radiance: Float[ArrayLike, "*batch b"]
    ) -> Float[Array, "*batch b"]:
        """Digital numbers (integer-valued floats), clipped to `[0, DN_max]`. [DN]"""
        r = jnp.asarray(radiance)
        L = jnp.clip(r, _bc(self.detection_limit, r), _bc(self.saturation, r))
        return jnp.clip(jnp.round(self.transfer(L)), 0.0, self.dn_max)

    def decode(self, dn: Float[ArrayLike, "*batch b"]) -> Float[Array, "*batch b"]:
        """Radiance of each code. [W m⁻² sr⁻¹ nm⁻¹]"""
        return self.inverse(jnp.clip(jnp.asarray(dn), 0.0, self.dn_max))

    def step(self, radiance: Float[ArrayLike, "*batch b"]) -> Float[Array, "*batch b"]:
        """Local radiance step `1/g'(L)` (radiance of one DN at L, L clipped to
        the range). [W m⁻² sr⁻¹ nm⁻¹]"""
        r = jnp.asarray(radiance)
        L = jnp.clip(r, _bc(self.detection_limit, r), _bc(self.saturation, r))
        return self._step(L)

    @abc.abstractmethod
    def _step(self, radiance):
        """`1/g'(L)` inside the range."""

    def __call__(
        self, radiance: Float[ArrayLike, "*batch b"]
    ) -> Float[Array, "*batch b"]:
        """`decode(encode(L))`: the radiance a ground segment reconstructs."""
        return self.decode(self.encode(radiance))


class LinearQuantiser(AbstractQuantiser):
    """`g = DN_max (L - L_min)/(L_max - L_min)`."""

    detection_limit: Float[Array, " b"] = eqx.field(converter=jnp.asarray)
    saturation: Float[Array, " b"] = eqx.field(converter=jnp.asarray)
    bits: int = eqx.field(static=True)

    def __check_init__(self):
        _dn_max(self.bits)
        _check_order(
            (self.detection_limit, "detection_limit"), (self.saturation, "saturation")
        )

    def transfer(self, radiance):
        L = jnp.asarray(radiance)
        lo, hi = _bc(self.detection_limit, L), _bc(self.saturation, L)
        return (L - lo) * (self.dn_max / (hi - lo))

    def inverse(self, code):
        y = jnp.asarray(code)
        lo, hi = _bc(self.detection_limit, y), _bc(self.saturation, y)
        return lo + y * ((hi - lo) / self.dn_max)

    def _step(self, radiance):
        L = jnp.asarray(radiance)
        return (_bc(self.saturation, L) - _bc(self.detection_limit, L)) / self.dn_max


class TwoGainQuantiser(AbstractQuantiser):
    """Two gain stages in one code space: codes `0 … H-1` (H = 2^(bits-1)) on
    `[L_min, L_knee]`, codes `H-1 … DN_max` on `[L_knee, L_max]`. The gain
    ratio is `(H / (H-1)) · (L_knee - L_min)⁻¹ (L_max - L_knee)`."""

    detection_limit: Float[Array, " b"] = eqx.field(converter=jnp.asarray)
    knee: Float[Array, " b"] = eqx.field(converter=jnp.asarray)
    saturation: Float[Array, " b"] = eqx.field(converter=jnp.asarray)
    bits: int = eqx.field(static=True)

    def __check_init__(self):
        if _dn_max(self.bits) < 3:
            raise ValueError(f"bits must be >= 2 for two gain stages, got {self.bits}.")
        _check_order(
            (self.detection_limit, "detection_limit"),
            (self.knee, "knee"),
            (self.saturation, "saturation"),
        )

    @property
    def _half(self) -> float:
        return float(2 ** (self.bits - 1))

    def _parts(self, like):
        """Broadcast L_min, knee and the two steps to `like`'s shape."""
        h = self._half
        lo, knee, hi = (
            _bc(a, like) for a in (self.detection_limit, self.knee, self.saturation)
        )
        s_hi = (knee - lo) / (h - 1.0)
        s_lo = (hi - knee) / (self.dn_max - (h - 1.0))
        return lo, knee, s_hi, s_lo

    def transfer(self, radiance):
        L = jnp.asarray(radiance)
        lo, knee, s_hi, s_lo = self._parts(L)
        low = (L - lo) / s_hi
        high = (self._half - 1.0) + (L - knee) / s_lo
        return jnp.where(L <= knee, low, high)

    def inverse(self, code):
        y = jnp.asarray(code)
        lo, knee, s_hi, s_lo = self._parts(y)
        h1 = self._half - 1.0
        return jnp.where(y <= h1, lo + y * s_hi, knee + (y - h1) * s_lo)

    def _step(self, radiance):
        L = jnp.asarray(radiance)
        _, knee, s_hi, s_lo = self._parts(L)
        return jnp.where(L <= knee, s_hi, s_lo)

    @classmethod
    def geometric_knee(
        cls, detection_limit, saturation, bits: int
    ) -> "TwoGainQuantiser":
        """Knee at the geometric mean `sqrt(L_min L_max)` of the limits."""
        lo, hi = jnp.asarray(detection_limit), jnp.asarray(saturation)
        return cls(lo, jnp.sqrt(lo * hi), hi, bits)


class SqrtQuantiser(AbstractQuantiser):
    """Noise-matched square-root companding:
    `g = DN_max (s(L) - s(L_min)) / (s(L_max) - s(L_min))`,
    `s(L) = sqrt(R L + σ0²)` (R responsivity [e- per W m⁻² sr⁻¹ nm⁻¹], σ0² the
    signal-independent noise variance [e-²])."""

    detection_limit: Float[Array, " b"] = eqx.field(converter=jnp.asarray)
    saturation: Float[Array, " b"] = eqx.field(converter=jnp.asarray)
    responsivity_e: Float[Array, " b"] = eqx.field(converter=jnp.asarray)
    floor_variance_e2: Float[Array, ""] = eqx.field(converter=jnp.asarray)
    bits: int = eqx.field(static=True)

    def __check_init__(self):
        _dn_max(self.bits)
        _check_order(
            (self.detection_limit, "detection_limit"), (self.saturation, "saturation")
        )
        try:
            ok = bool(jnp.all(self.responsivity_e > 0)) and bool(
                jnp.all(self.floor_variance_e2 >= 0)
            )
        except TypeError:
            return
        if not ok:
            raise ValueError("responsivity_e must be > 0 and floor_variance_e2 >= 0.")
        if not bool(
            jnp.all(
                self.responsivity_e * self.detection_limit + self.floor_variance_e2 > 0
            )
        ):
            raise ValueError(
                "Need R·L_min + σ0² > 0 (a positive detection limit or "
                "a noise floor) for square-root companding."
            )

    @classmethod
    def for_sensor(
        cls,
        detection_limit,
        saturation,
        responsivity_e,
        params: SensorParams,
        bits: int,
    ) -> "SqrtQuantiser":
        """σ0² from `params`: dark current over t_eff plus read noise squared."""
        s0 = (
            params.dark_current_e_s * params.effective_integration_time_s
            + params.read_noise_e**2
        )
        return cls(detection_limit, saturation, responsivity_e, s0, bits)

    def _s(self, L, r):
        return jnp.sqrt(r * L + self.floor_variance_e2)

    def _parts(self, like):
        r = _bc(self.responsivity_e, like)
        s0 = self._s(_bc(self.detection_limit, like), r)
        s1 = self._s(_bc(self.saturation, like), r)
        return r, s0, s1

    def transfer(self, radiance):
        L = jnp.asarray(radiance)
        r, s0, s1 = self._parts(L)
        return self.dn_max * (self._s(L, r) - s0) / (s1 - s0)

    def inverse(self, code):
        y = jnp.asarray(code)
        r, s0, s1 = self._parts(y)
        s = s0 + y * (s1 - s0) / self.dn_max
        return (s**2 - self.floor_variance_e2) / r

    def _step(self, radiance):
        L = jnp.asarray(radiance)
        r, s0, s1 = self._parts(L)
        # dL/dy = 2 s(L) / R · (s1 - s0) / DN_max
        return 2.0 * self._s(L, r) / r * ((s1 - s0) / self.dn_max)

    def step_over_noise(self) -> Float[Array, " b"]:
        """The constant ratio of the radiance step to the photon-model noise
        `sqrt(R L + σ0²)/R`: `2 (s(L_max) - s(L_min)) / DN_max`. [1]"""
        r = self.responsivity_e
        return (
            2.0
            * (self._s(self.saturation, r) - self._s(self.detection_limit, r))
            / (self.dn_max)
        )


SCHEMES: tuple[str, ...] = ("linear", "two-gain", "sqrt")
"""Quantiser names accepted by `make_quantiser`."""


def make_quantiser(
    scheme: str,
    detection_limit,
    saturation,
    bits: int,
    *,
    responsivity_e=None,
    params: SensorParams | None = None,
) -> AbstractQuantiser:
    """A quantiser by name (case and separators ignored): `linear`,
    `two-gain` (knee at the geometric mean of the limits) or `sqrt`
    (needs `responsivity_e`; noise floor from `params`)."""
    key = canonical_key(scheme)
    if key == "linear":
        return LinearQuantiser(detection_limit, saturation, bits)
    if key in ("twogain", "dualgain"):
        return TwoGainQuantiser.geometric_knee(detection_limit, saturation, bits)
    if key in ("sqrt", "squareroot"):
        if responsivity_e is None:
            raise ValueError("scheme 'sqrt' needs responsivity_e.")
        return SqrtQuantiser.for_sensor(
            detection_limit,
            saturation,
            responsivity_e,
            SensorParams() if params is None else params,
            bits,
        )
    raise ValueError(f"Unknown scheme {scheme!r}; expected one of {list(SCHEMES)}.")
