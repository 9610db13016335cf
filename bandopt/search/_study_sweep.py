"""The stability study's task lists and their cached sweeps, with progress.

`study_tasks` lists the search tasks of some band counts and objective
weights (and the reference sensors); `study_sweep` runs them through
`run_sweep`, reusing cached results of the identical configuration (the task
hash is in the file name) unless `force`, and says on stderr what it reuses
and how long the phase has left."""

import sys
import time
from pathlib import Path

from ..sensor.reference import REFERENCE_SENSORS
from ._options import STUDY, SearchOptions
from ._study import make_study_task
from ._sweep import run_sweep, task_path


RUNNER = "bandopt.search:run_study_task"
"""The function a sweep worker calls on each study task."""


def study_tasks(options: SearchOptions, *, ns=None, alphas=(0.0,), refs=False):
    """Study tasks of band counts `ns` x objective weights `alphas` (the
    largest band count first: the slowest), and every reference sensor when
    `refs`."""
    common = dict(
        preset=options.preset,
        noise=STUDY["noise"],
        partitions=options.partitions,
        seed=options.seed,
        restarts=STUDY["restarts"],
        max_steps=options.max_steps,
        scorer=options.scorer,
    )
    tasks = [
        make_study_task(n_bands=n, alpha=float(a), **common)
        for n in sorted(ns or (), reverse=True)
        for a in alphas
    ]
    if refs:
        tasks += [make_study_task(sensor=k, **common) for k in REFERENCE_SENSORS]
    return tasks


def task_cost(task) -> float:
    """Relative cost of a study task, measured on 2 cores with the inversion
    judge: a search task 100-200 s whatever its band count (12 resamples x 12
    restarts in one compiled function, then 12 inversion fits), a reference
    sensor 10-30 s (judging only)."""
    return 0.2 if task.get("sensor") else 1.0 + 0.05 * float(task["n_bands"])


class StudyProgress:
    """Progress with an estimate of the time left in the phase (stderr): the
    elapsed time per unit of expected cost (`task_cost`) times the expected
    cost left."""

    def __init__(self, tasks, out):
        self.t0 = time.perf_counter()
        self.cost = {str(task_path(out, t)): task_cost(t) for t in tasks}
        self.total = sum(self.cost.values())
        self.done_cost = 0.0

    def __call__(self, done, total, status):
        el = time.perf_counter() - self.t0
        self.done_cost += self.cost.get(status["path"], 1.0)
        rate = el / max(self.done_cost, 1e-9)
        left = rate * max(self.total - self.done_cost, 0.0)
        name = Path(status["path"]).stem
        mark = "ok" if status.get("ok") else f"FAILED {status.get('error')}"
        print(
            f"[{done}/{total}] {name}: {mark} | elapsed {el:5.0f} s, "
            f"about {left:4.0f} s left in this phase",
            file=sys.stderr,
            flush=True,
        )


def study_sweep(tasks, options: SearchOptions, label: str, reused: list) -> list:
    """Run `tasks` into `options.out` (cached results reused unless
    `options.force`); appends `(tasks reused, tasks)` to `reused`. Raises
    `RuntimeError` when a task failed."""
    out = Path(options.out)
    cached = [t for t in tasks if task_path(out, t).is_file()]
    if cached and options.force:
        for t in cached:
            task_path(out, t).unlink()
        print(
            f"{label}: --force: recomputing {len(cached)} cached tasks", file=sys.stderr
        )
    elif cached:
        print(
            f"{label}: REUSING {len(cached)} of {len(tasks)} task results of the "
            f"identical configuration (task hash in the file name) from "
            f"{out}/tasks; pass --force to recompute them",
            file=sys.stderr,
        )
    todo = len(tasks) - (0 if options.force else len(cached))
    where = (
        "Dask " + options.scheduler
        if options.scheduler
        else f"{options.workers} workers"
    )
    print(f"{label}: {todo} tasks to run on {where}", file=sys.stderr, flush=True)
    res = run_sweep(
        tasks,
        out,
        workers=options.workers,
        scheduler=options.scheduler,
        runner=RUNNER,
        progress=StudyProgress(
            [t for t in tasks if options.force or not task_path(out, t).is_file()],
            out,
        ),
    )
    reused.append((0 if options.force else len(cached), len(tasks)))
    missing = [t for t, r in zip(tasks, res, strict=True) if r is None]
    if missing:
        raise RuntimeError(
            f"{label}: {len(missing)} tasks failed; see {out}/tasks/*.failed.json"
        )
    return res
