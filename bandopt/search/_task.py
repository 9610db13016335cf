"""One band search as a self-contained, JSON-described task.

A task names a scenario preset, a target (`ler`, `g`, `cct`, `all`), a band
count, a pan mode, an outer fold (or `"final"`: all lamps) and a seed. It
builds (and caches per process) the scenario context, runs the global search
(nlopt) and a local polish (optimistix), then scores the bands on the outer
test lamps with the estimator refitted on the outer training lamps (ridge
strength chosen on the inner folds). Everything it returns is JSON-ready.

The scenario context (`Context`, `get_context`, `PRESETS`) is built in
`_context`, the measurement effects of a preset's spectra in `_perturbed`;
both are re-exported here, where callers and tests have imported them.
"""

import dataclasses
import hashlib
import json
import time

import jax.numpy as jnp
import numpy as np

from ..datasets import atmosphere
from ..estimate import fit_estimator, lamp_abs_errors, resolve_target
from ..sensor.reference import reference_sensor
from ._context import (
    ATMOSPHERES_6S as ATMOSPHERES_6S,
    EVALUATION_SEED_OFFSET as EVALUATION_SEED_OFFSET,
    N_INNER as N_INNER,
    N_OUTER as N_OUTER,
    PRESETS as PRESETS,
    Context as Context,
    _scale_to as _scale_to,
    get_context as get_context,
    parse_noise as parse_noise,
)
from ._global import global_search
from ._local import bandset_losses, fit_local, free_bandset
from ._perturbed import (
    KINDS as KINDS,
    MEASURED_SPECTRA as MEASURED_SPECTRA,
    ScenePerturbations as ScenePerturbations,
    perturbed_lamp_spectra as perturbed_lamp_spectra,
    perturbed_scenes as perturbed_scenes,
)
from ._problem import Space, jitted_losses, make_problem


def task_id(task: dict) -> str:
    """Stable file name of a task: readable prefix + hash of its full spec
    (with its preset's scene perturbations, when it has any, so a cached
    task is never reused after they change)."""
    spec = dict(task)
    pert = PRESETS.get(task.get("preset"), {}).get("perturbations")
    if pert is not None:
        spec["perturbations"] = pert.to_dict()
    h = hashlib.sha1(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:10]
    fold = task.get("fold", "final")
    kind = task.get("kind", "search")
    if kind == "reference":
        return f"ref_{task['sensor']}_{h}"
    if kind == "stability":
        if task.get("sensor"):
            return f"st_ref_{task['sensor']}_{h}"
        return f"st_n{task['n_bands']}_a{task['alpha']:g}_{h}"
    return (
        f"{task['target']}_n{task['n_bands']}_{task['pan']}_f{fold}_s{task['seed']}_{h}"
    )


DEFAULT_TASK = {
    "kind": "search",
    "preset": "search",
    "noise": None,
    "fold_seed": 0,
    "target": "all",
    "n_bands": 3,
    "pan": "fixed",
    "fold": "final",
    "seed": 0,
    "algorithm": "mlsl",
    "max_evals": 600,
    "local_max_evals": 40,
    "polish_steps": 40,
    "degree": 1,
    "max_fwhm_nm": 200.0,
    "atmospheres": "auto",
    "warm_start": True,
}

WARM_NEW_CENTRES_NM = (430.0, 530.0, 630.0, 730.0, 830.0)
"""Where a warm start puts the band added to the n - 1 solution (FWHM 40 nm)."""


def make_task(**kwargs) -> dict:
    unknown = set(kwargs) - set(DEFAULT_TASK)
    if unknown:
        raise ValueError(
            f"Unknown task fields {sorted(unknown)}; expected {sorted(DEFAULT_TASK)}."
        )
    task = {**DEFAULT_TASK, **kwargs}
    task["target"] = resolve_target(task["target"])
    # Resolve now, so the task's hash (its result file) says which was used.
    task["atmospheres"] = atmosphere.resolve_setting(task["atmospheres"])
    return task


def _lamps_and_splits(ctx: Context, fold):
    if fold == "final":
        lamps = np.arange(ctx.table.n_lamps)
        splits = ctx.folds.outer()
        return lamps, splits, None, None
    s = ctx.splits[int(fold)]
    return s.train, list(s.inner), s.train, s.test


def evaluate_bands(ctx: Context, bands, *, folds=None, seed: int = 0) -> dict:
    """Outer-fold test errors of the ridge estimator for a fixed band set.

    For each outer fold (all by default) the estimator is fitted on the outer
    training lamps (ridge strength and feature degree by inner CV) and scored
    on its test lamps. Returns `{"lamp_index", "lamp_errors" (l, 3),
    "fold_of_lamp", "lambdas", "degrees"}`.
    """
    rad = ctx.radiance(bands, seed=seed)
    folds = range(len(ctx.splits)) if folds is None else folds
    idx, errs, fold_of, lams, degs = [], [], [], [], []
    for k in folds:
        s = ctx.splits[k]
        est = fit_estimator(rad, ctx.table, s.train, s.inner)
        pred = np.asarray(est.predict(rad))
        errs.append(lamp_abs_errors(pred, ctx.table, s.test))
        idx.append(s.test)
        fold_of.append(np.full(len(s.test), k))
        lams.append(list(est.lam))
        degs.append(list(est.degree))
    return {
        "lamp_index": np.concatenate(idx).tolist(),
        "lamp_errors": np.concatenate(errs).tolist(),
        "fold_of_lamp": np.concatenate(fold_of).tolist(),
        "lambdas": lams,
        "degrees": degs,
    }


EVALUATION_KEYS = ("lamp_index", "lamp_errors", "fold_of_lamp", "lambdas", "degrees")
"""Keys of `evaluate_bands`: the outer-fold test errors of a task's bands."""


@dataclasses.dataclass(frozen=True)
class TaskResult:
    """The result of `run_task`; `to_dict()` is the JSON of its task file.

    Every task: `task` (its description), `bands` (the band set: the
    `BandSet.to_dict()` form for a search, name/centre/FWHM for a reference
    sensor), `context` (scenario settings), `wall_s` [s] and, on an outer
    fold, the test-lamp evaluation (`lamp_index`, `lamp_errors` [LER lm/W,
    G 1, CCT K per lamp], `fold_of_lamp`, `lambdas`, `degrees`; None on the
    `"final"` fold). A search also has `space`, `loss`, `spread`,
    `global_search` (JSON key `"global"`), `local` and `warm_start` (None
    when not run). `from_dict` reads a task file back.
    """

    task: dict
    bands: dict
    context: dict
    wall_s: float
    space: dict | None = None
    loss: float | None = None
    spread: list | None = None
    global_search: dict | None = None
    local: dict | None = None
    warm_start: dict | None = None
    lamp_index: list | None = None
    lamp_errors: list | None = None
    fold_of_lamp: list | None = None
    lambdas: list | None = None
    degrees: list | None = None

    @property
    def is_reference(self) -> bool:
        """A reference sensor scored on the folds (no search)."""
        return self.task.get("kind") == "reference"

    def evaluation(self) -> dict | None:
        """The test-lamp evaluation as `evaluate_bands` returns it."""
        if self.lamp_index is None:
            return None
        return {k: getattr(self, k) for k in EVALUATION_KEYS}

    def to_dict(self) -> dict:
        """The JSON-ready dict of the task file (keys in the order of the
        files written before this class existed)."""
        ev = self.evaluation() or {}
        if self.is_reference:
            return {
                "task": self.task,
                "bands": self.bands,
                **ev,
                "wall_s": self.wall_s,
                "context": self.context,
            }
        return {
            "task": self.task,
            "space": self.space,
            "bands": self.bands,
            "loss": self.loss,
            "spread": self.spread,
            "global": self.global_search,
            "local": self.local,
            "warm_start": self.warm_start,
            "context": self.context,
            **ev,
            "wall_s": self.wall_s,
        }

    @classmethod
    def from_dict(cls, data: dict) -> "TaskResult":
        """A `TaskResult` from a task file's dict (`to_dict` inverted); a
        missing or unknown key is a `ValueError` naming it."""
        keys = {"task", "bands", "context", "wall_s", *EVALUATION_KEYS}
        if not (isinstance(data.get("task"), dict) and data["task"].get("kind")
                == "reference"):  # fmt: skip
            keys |= {"space", "loss", "spread", "global", "local", "warm_start"}
        unknown = set(data) - keys
        missing = {"task", "bands", "context", "wall_s"} - set(data)
        if unknown or missing:
            raise ValueError(
                f"task result: unknown keys {sorted(unknown)}, missing keys "
                f"{sorted(missing)}."
            )
        kw = {k: v for k, v in data.items() if k != "global"}
        if "global" in data:
            kw["global_search"] = data["global"]
        return cls(**kw)


def run_task(task: dict, progress=None, *, results: dict | None = None) -> TaskResult:
    """Run one task (see module docstring) and return its `TaskResult`
    (`to_dict()` is JSON-ready).

    `results`: results of tasks already run, by `task_id`, as task-file dicts
    (a dict, or anything with `get` and item assignment, e.g.
    `bandopt.search.TaskResults` reading a sweep's finished files). A warm
    start takes the n - 1 task's result from it, running it (and adding its
    `to_dict()`) when missing. Default: a new dict for this call, so nothing
    is shared between calls."""
    results = {} if results is None else results

    t0 = time.perf_counter()
    ctx = get_context(
        task["preset"], task["noise"], task["fold_seed"], task["atmospheres"]
    )
    if task.get("kind") == "reference":
        bands = reference_sensor(task["sensor"])
        ev = evaluate_bands(ctx, bands, seed=task["seed"])
        return TaskResult(
            task=task,
            bands=_describe(bands),
            context=ctx.config,
            wall_s=time.perf_counter() - t0,
            **ev,
        )
    space = Space(task["n_bands"], pan=task["pan"], max_fwhm_nm=task["max_fwhm_nm"])
    lamps, splits, _, _ = _lamps_and_splits(ctx, task["fold"])
    problem = make_problem(
        ctx.toa,
        ctx.wavelength_nm,
        ctx.table,
        lamps,
        splits,
        target=task["target"],
        space=space,
        degree=task["degree"],
        noise=ctx.noise,
        noise_radiance=ctx.noise_radiance,
        seed=task["seed"],
        pad_to=ctx.toa.shape[0] * ctx.toa.shape[1],
    )
    value, vg, _ = jitted_losses(problem, space)
    g = global_search(
        value,
        vg,
        space.dim,
        algorithm=task["algorithm"],
        max_evals=task["max_evals"],
        seed=task["seed"],
        local_max_evals=task["local_max_evals"],
    )
    centre, fwhm = (np.asarray(a) for a in space.physical(jnp.asarray(g.x)))
    local = None
    if task["polish_steps"] > 0:
        loss_b, _ = bandset_losses(space.n_free)
        lo, _ = space.fwhm_range()
        init = free_bandset(
            centre,
            np.clip(fwhm, lo[0] + 1e-3, None),
            space.shape_k,
            min_fwhm_nm=float(lo.min()),
        )
        lr = fit_local(
            loss_b, init, args=problem, solver="bfgs", max_steps=task["polish_steps"]
        )
        local = lr.to_dict()
        if lr.loss < g.loss:
            centre, fwhm = np.asarray(lr.bands.centre_nm), np.asarray(lr.bands.fwhm_nm)
    warm = None
    if task.get("warm_start") and task["n_bands"] > 1 and space.pan != "free":
        # Nested warm start: the n - 1 solution of the same fold plus one new
        # band, polished with BFGS. Keeps the loss from rising with n when the
        # global search stops in a worse basin (deterministic: the n - 1 task
        # is the same computation whether cached or recomputed).
        n = task["n_bands"]
        # Budgets scale with the dimension, so the n - 1 task is the sweep's own.
        prev_task = dict(
            task, n_bands=n - 1, max_evals=round(task["max_evals"] * (n - 1) / n)
        )
        prev = results.get(task_id(prev_task))
        if prev is None:
            prev = run_task(prev_task, results=results).to_dict()
            results[task_id(prev_task)] = prev
        free = [b for b in prev["bands"]["bands"] if b["name"] != "PAN"]
        pc = [b["centre_nm"] for b in free]
        pf = [b["fwhm_nm"] for b in free]
        loss_b, _ = bandset_losses(space.n_free)
        lo, _ = space.fwhm_range()
        best = None
        for c_new in WARM_NEW_CENTRES_NM:
            init = free_bandset(
                [*pc, c_new],
                np.clip([*pf, 40.0], lo[0] + 1e-3, None),
                space.shape_k,
                min_fwhm_nm=float(lo.min()),
            )
            lr = fit_local(
                loss_b,
                init,
                args=problem,
                solver="bfgs",
                max_steps=task["polish_steps"],
            )
            if best is None or lr.loss < best.loss:
                best = lr
        warm = {
            "from_n_bands": task["n_bands"] - 1,
            "loss": best.loss,
            "starts": len(WARM_NEW_CENTRES_NM),
            "result": best.to_dict(),
        }
        current = g.loss if local is None else min(g.loss, local["loss"])
        warm["used"] = bool(best.loss < current)
        if warm["used"]:
            centre = np.asarray(best.bands.centre_nm)
            fwhm = np.asarray(best.bands.fwhm_nm)
    bands = space.band_set(
        centre, fwhm, name=f"bandopt-{task['target']}-n{task['n_bands']}"
    )
    loss = (
        float(value(jnp.asarray(space.unit(centre, fwhm))))
        if local is None
        else min(g.loss, local["loss"])
    )
    if warm is not None and warm["used"]:
        loss = warm["loss"]
    ev = {}
    if task["fold"] != "final":
        ev = evaluate_bands(ctx, bands, folds=[int(task["fold"])], seed=task["seed"])
    return TaskResult(
        task=task,
        space=space.to_dict(),
        bands=bands.to_dict(),
        loss=loss,
        spread=np.asarray(problem.spread).tolist(),
        global_search=g.to_dict(),
        local=local,
        warm_start=warm,
        context=ctx.config,
        wall_s=time.perf_counter() - t0,
        **ev,
    )


def _describe(bands) -> dict:
    c = np.asarray(bands.centre_nm, float)
    f = np.asarray(bands.fwhm_nm, float)
    return {
        "name": bands.name,
        "bands": [
            {"name": n, "centre_nm": float(c[i]), "fwhm_nm": float(f[i])}
            for i, n in enumerate(bands.names)
        ],
    }
