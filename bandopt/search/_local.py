"""Local band fits with optimistix (`Rader2024`): BFGS on the loss or
Levenberg-Marquardt on the residuals, over the raw leaves of a `BandSet`.

Only `raw_centre` and `raw_fwhm` are optimised (`eqx.partition`); the shape
exponent stays fixed. Bounds are built into the `BandSet` parametrisation
(sigmoids), so an optimum on a bound shows as a saturated raw value, never as
"converged" in a box. Solver outcomes are recorded with `throw=False`: a
"successful" stop at a local minimum is still a local minimum.
"""

import dataclasses
import functools
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from ..names import canonical_key
from ..sensor import BandSet


SOLVERS = ("bfgs", "lm")


def _filter(bands: BandSet):
    spec = jax.tree_util.tree_map(lambda _: False, bands)
    return eqx.tree_at(lambda b: (b.raw_centre, b.raw_fwhm), spec, (True, True))


@dataclasses.dataclass
class LocalResult:
    """Outcome of one optimistix fit (`bands` is the fitted `BandSet`)."""

    bands: BandSet
    loss: float
    initial_loss: float
    solver: str
    result: str
    successful: bool
    steps: int
    saturated: list[bool]

    def to_dict(self) -> dict:
        d = {k: v for k, v in dataclasses.asdict(self).items() if k != "bands"}
        d["bands"] = self.bands.to_dict()
        return d


def fit_local(
    loss_fn: Callable[[BandSet, object], jax.Array],
    init: BandSet,
    *,
    args=None,
    solver: str = "bfgs",
    residual_fn: Callable[[BandSet, object], jax.Array] | None = None,
    max_steps: int = 100,
    rtol: float = 1e-8,
    atol: float = 1e-8,
) -> LocalResult:
    """Fit `raw_centre` and `raw_fwhm` of `init` (shape k fixed).

    `solver="bfgs"` minimises `loss_fn(bands, args)`; `"lm"` runs
    Levenberg-Marquardt on `residual_fn(bands, args)` (a vector whose squared
    sum is the loss). Pass data through `args` (a pytree, e.g. a `Problem`) so
    one compilation serves every call with the same shapes. Saturation: a raw
    leaf with |raw| > 8 (sigmoid within 3e-4 of a bound) is reported per band.
    The fit never returns a worse point than `init`.
    """
    key = canonical_key(solver)  # the `bandopt.names` rule
    if key not in SOLVERS:
        raise ValueError(f"Unknown solver {solver!r}; expected one of {list(SOLVERS)}.")
    diff, static = eqx.partition(init, _filter(init))
    initial = float(loss_fn(init, args))
    if key == "bfgs":
        sol = optx.minimise(
            _wrapped(loss_fn),
            optx.BFGS(rtol=rtol, atol=atol),
            diff,
            args=(args, static),
            max_steps=max_steps,
            throw=False,
        )
    else:
        if residual_fn is None:
            raise ValueError("solver='lm' needs residual_fn.")
        sol = optx.least_squares(
            _wrapped(residual_fn),
            optx.LevenbergMarquardt(rtol=rtol, atol=atol),
            diff,
            args=(args, static),
            max_steps=max_steps,
            throw=False,
        )
    fitted = eqx.combine(sol.value, static)
    final = float(loss_fn(fitted, args))
    if not np.isfinite(final) or final > initial:  # never return a worse point
        fitted, final = init, initial
    raw = np.abs(np.stack([np.asarray(fitted.raw_centre), np.asarray(fitted.raw_fwhm)]))
    saturated = [bool(v) for v in (raw > 8.0).any(axis=0)]
    return LocalResult(
        fitted,
        final,
        initial,
        key,
        result_name(sol.result),
        bool(sol.result == optx.RESULTS.successful),
        int(sol.stats["num_steps"]),
        saturated,
    )


@functools.lru_cache(maxsize=32)
def _wrapped(fn):
    def objective(diff, args):
        user_args, static = args
        return fn(eqx.combine(diff, static), user_args)

    return objective


def result_name(result) -> str:
    """The name of an `optx.RESULTS` item (e.g. `"successful"`)."""
    for name in optx.RESULTS._name_to_item:
        if bool(result == getattr(optx.RESULTS, name)):
            return name
    return "unknown"


def bandset_losses(n_free: int):
    """`(loss(bands, problem), residuals(bands, problem))` for a `Problem`: the
    first `n_free` bands of the `BandSet` are the free ones (the problem adds
    its fixed pan). Cached per `n_free`, so compilations are reused."""
    return _bandset_fns(n_free)


@functools.lru_cache(maxsize=16)
def _bandset_fns(n_free: int):
    def phys(b):
        return b.centre_nm[:n_free], b.fwhm_nm[:n_free], b.shape_k[:n_free]

    return (
        eqx.filter_jit(lambda b, p: p.loss(*phys(b))),
        eqx.filter_jit(lambda b, p: p.residuals(*phys(b))),
    )


def free_bandset(centre_nm, fwhm_nm, shape_k: float = 6.0, **kwargs) -> BandSet:
    """A `BandSet` of free bands only (for `fit_local` with `bandset_losses`)."""
    c = jnp.asarray(centre_nm, float)
    return BandSet.from_physical(
        np.asarray(c), np.asarray(fwhm_nm, float), shape_k, **kwargs
    )
