"""Global band search with nlopt (`Johnson2007`), and the one JAX <-> nlopt adapter.

Algorithms (all on the unit box `[0, 1]^d` of `Space`):

- `"mlsl"`: `G_MLSL_LDS` (multi-level single linkage, low-discrepancy starts,
  `Kucherenko2005`) with `LD_LBFGS` local searches on JAX gradients;
- `"direct"`: `GN_DIRECT_L` (locally biased DIRECT, `Gablonsky2001`);
- `"crs2"`: `GN_CRS2_LM` (controlled random search with local mutation,
  `Kaelo2006`).

Every run is seeded (`nlopt.srand`) and budgeted by objective evaluations
(never time). nlopt's exceptions (`RoundoffLimited`, `ForcedStop`, generic
failures) are caught: the adapter keeps the best point it has seen, which is
what is returned, with the exception's name recorded.
"""

import dataclasses
import threading
import time
from collections.abc import Callable

import jax
import nlopt
import numpy as np

from ..names import validate_method


ALGORITHMS = ("mlsl", "direct", "crs2")

_NLOPT_LOCK = threading.Lock()
"""nlopt's random state is global: runs in threads of one process are
serialised so a seed gives the same result (processes are independent)."""


class NloptObjective:
    """Adapt JAX `value(u)` / `value_and_grad(u)` to nlopt's `f(x, grad)`.

    nlopt passes float64 NumPy arrays and expects `grad` filled in place (size 0
    for derivative-free algorithms, which need no `value_and_grad`). Counts
    evaluations, keeps the best point and a short history; `max_evals` stops
    the run (`nlopt.ForcedStop`) once reached, so local searches inside MLSL
    cannot overrun the budget.
    `keep_points`: also keep every evaluated point and its value in `points`
    (a list of `(x (d,), f)`), e.g. to draw starting points from a global run.
    Requires `jax_enable_x64` (nlopt's float64 points would be rounded).
    """

    def __init__(
        self,
        value: Callable,
        value_and_grad: Callable | None,
        max_evals: int,
        *,
        keep_points: bool = False,
    ):
        if not jax.config.jax_enable_x64:  # pyright: ignore
            raise RuntimeError("The nlopt adapter needs jax_enable_x64=True.")
        self.value, self.value_and_grad, self.max_evals = (
            value,
            value_and_grad,
            max_evals,
        )
        self.n_evals = 0
        self.n_grads = 0
        self.best_f = np.inf
        self.best_x: np.ndarray | None = None
        self.trace: list[
            tuple[int, float]
        ] = []  # (evaluation, best loss) at improvements
        self.trace_s: list[float] = []  # seconds since the first call, same points
        self._t0: float | None = None
        self.points: list[tuple[np.ndarray, float]] | None = [] if keep_points else None

    def __call__(self, x: np.ndarray, grad: np.ndarray) -> float:
        if self.n_evals >= self.max_evals:
            raise nlopt.ForcedStop("evaluation budget reached")
        if self._t0 is None:
            self._t0 = time.perf_counter()
        self.n_evals += 1
        if grad.size > 0:
            f, g = self.value_and_grad(x)
            g = np.asarray(g, float)
            self.n_grads += 1
            grad[:] = np.where(np.isfinite(g), g, 0.0)
        else:
            f = self.value(x)
        f = float(f)
        if not np.isfinite(f):
            f = 1e30  # nlopt cannot handle NaN: a huge value, never a best point
        if self.points is not None:
            self.points.append((np.array(x, float), f))
        if f < self.best_f:
            self.best_f, self.best_x = f, np.array(x, float)
            self.trace.append((self.n_evals, f))
            self.trace_s.append(time.perf_counter() - self._t0)
        return f


@dataclasses.dataclass
class GlobalResult:
    """Outcome of one nlopt run (all fields JSON-ready)."""

    algorithm: str
    x: list[float]
    loss: float
    n_evals: int
    n_grads: int
    wall_s: float
    status: str
    seed: int
    trace: list[tuple[int, float]]
    trace_s: list[float] = dataclasses.field(default_factory=list)
    """Wall time [s] since the first evaluation at each `trace` point (not
    reproducible, unlike `trace`)."""

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def global_search(
    value: Callable,
    value_and_grad: Callable,
    dim: int,
    *,
    algorithm: str = "mlsl",
    max_evals: int = 1000,
    seed: int = 0,
    local_max_evals: int = 60,
    local_ftol_rel: float = 1e-7,
    population: int = 0,
) -> GlobalResult:
    """Minimise `value` over `[0, 1]^dim` with nlopt. See module docstring.

    `local_max_evals`, `local_ftol_rel`: stopping rules of each LBFGS local
    search in MLSL. `population`: nlopt's population (0: its default).
    """
    key = validate_method(algorithm, ALGORITHMS, "algorithm")
    if max_evals < 1:
        raise ValueError(f"max_evals must be >= 1, got {max_evals}.")
    obj = NloptObjective(value, value_and_grad, max_evals)
    code = {
        "mlsl": nlopt.G_MLSL_LDS,
        "direct": nlopt.GN_DIRECT_L,
        "crs2": nlopt.GN_CRS2_LM,
    }[key]
    with _NLOPT_LOCK:
        nlopt.srand(int(seed))
        opt = nlopt.opt(code, dim)
        opt.set_lower_bounds(np.zeros(dim))
        opt.set_upper_bounds(np.ones(dim))
        opt.set_min_objective(obj)
        opt.set_maxeval(int(max_evals))
        if population:
            opt.set_population(int(population))
        if key == "mlsl":
            local = nlopt.opt(nlopt.LD_LBFGS, dim)
            local.set_ftol_rel(local_ftol_rel)
            local.set_xtol_rel(1e-6)
            local.set_maxeval(int(local_max_evals))
            opt.set_local_optimizer(local)
        x0 = np.full(dim, 0.5)
        t0 = time.perf_counter()
        status = "ok"
        try:
            opt.optimize(x0)
            status = {
                nlopt.SUCCESS: "success",
                nlopt.STOPVAL_REACHED: "stopval",
                nlopt.FTOL_REACHED: "ftol",
                nlopt.XTOL_REACHED: "xtol",
                nlopt.MAXEVAL_REACHED: "maxeval",
                nlopt.MAXTIME_REACHED: "maxtime",
            }.get(opt.last_optimize_result(), str(opt.last_optimize_result()))
        except nlopt.ForcedStop:
            status = "maxeval (forced stop by adapter)"
        except Exception as err:  # nlopt raises SWIG-wrapped std::runtime_error too
            status = f"exception {type(err).__name__}: {err}"
        wall = time.perf_counter() - t0
    x = obj.best_x if obj.best_x is not None else x0
    return GlobalResult(
        key,
        [float(v) for v in x],
        float(obj.best_f),
        obj.n_evals,
        obj.n_grads,
        wall,
        status,
        int(seed),
        [(int(i), float(f)) for i, f in obj.trace],
        [float(t) for t in obj.trace_s],
    )
