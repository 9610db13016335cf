"""Parallel, resumable sweeps of search tasks: local spawned processes or Dask.

Each finished task is written atomically as `<out_dir>/tasks/<task_id>.json`;
a rerun skips every task whose file exists, so an interrupted sweep keeps what
finished and continues. A task that raises is recorded in
`<out_dir>/tasks/<task_id>.failed.json` (with the traceback) and retried on
the next run.

Executors, one code path (`_execute` -> `run_and_write`):

- `workers <= 1`, no scheduler: in this process, one task after another;
- `workers > 1`: a `multiprocessing` pool of *spawned* processes whose XLA runs
  single-threaded (`WORKER_XLA_FLAGS` set in the environment the workers are
  started with, before they import JAX);
- `scheduler`: a Dask distributed `Client` (an address string or an existing
  client); the same `run_and_write` function is mapped over the tasks.
"""

import contextlib
import functools
import importlib
import json
import multiprocessing as mp
import os
import sys
import tempfile
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path

from .._config import configure
from ..strict_json import strict_dumps
from ._task import run_task, task_id


WORKER_XLA_FLAGS = "--xla_cpu_multi_thread_eigen=false"
"""XLA flags of spawned workers. `--xla_cpu_multi_thread_eigen=false` keeps
Eigen's matmuls single-threaded; `intra_op_parallelism_threads=1` is not an
XLA flag (it is TensorFlow's) and this jaxlib ignores it silently, so it is
not set."""


def task_path(out_dir: str | Path, task: dict) -> Path:

    return Path(out_dir) / "tasks" / f"{task_id(task)}.json"


def _write_json(path: Path, data) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".json")
    with os.fdopen(fd, "w") as fh:
        fh.write(strict_dumps(data, indent=1))
        fh.write("\n")
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(tmp, 0o666 & ~mask)  # mkstemp makes 0600; outputs are 0644
    os.replace(tmp, path)


def run_and_write(task: dict, out_dir: str, runner: str | None = None) -> dict:
    """Run one task and write its JSON (or a `.failed.json`). Returns a short
    status dict. `runner`: "module:function" to run instead of `run_task`
    (used by tests to inject failures)."""
    configure()
    path = task_path(out_dir, task)
    fn = functools.partial(run_task_default, out_dir=out_dir)
    if runner:
        mod, name = runner.split(":")
        fn = getattr(importlib.import_module(mod), name)
    try:
        result = fn(task)
    except Exception as err:  # recorded, retried on the next run
        fail = path.with_suffix(".failed.json")
        _write_json(
            fail,
            {"task": task, "error": repr(err), "traceback": traceback.format_exc()},
        )
        return {"path": str(path), "ok": False, "error": repr(err)}
    _write_json(path, result)
    failed = path.with_suffix(".failed.json")
    if failed.exists():
        failed.unlink()
    return {"path": str(path), "ok": True, "wall_s": result.get("wall_s")}


class TaskResults(dict):
    """Task results by `task_id`: those added in this process, then the
    finished task files of a sweep's `out_dir` (read on first use). Warm
    starts of `run_task` look up the n - 1 task here."""

    def __init__(self, out_dir: str | Path | None = None):
        super().__init__()
        self.out_dir = None if out_dir is None else Path(out_dir)

    def get(self, key, default=None):
        if key in self:
            return self[key]
        if self.out_dir is not None:
            path = self.out_dir / "tasks" / f"{key}.json"
            if path.is_file():
                self[key] = json.loads(path.read_text())
                return self[key]
        return default


def run_task_default(task: dict, out_dir: str | Path | None = None) -> dict:
    """`run_task(task).to_dict()`, warm-starting from the finished tasks of
    `out_dir`."""

    return run_task(task, results=TaskResults(out_dir)).to_dict()


@contextlib.contextmanager
def _worker_env(flags: str = WORKER_XLA_FLAGS):
    old = {
        k: os.environ.get(k) for k in ("XLA_FLAGS", "JAX_PLATFORMS", "JAX_ENABLE_X64")
    }
    os.environ["XLA_FLAGS"] = flags
    os.environ["JAX_PLATFORMS"] = "cpu"
    os.environ["JAX_ENABLE_X64"] = "1"
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _star(args):
    return run_and_write(*args)


def run_sweep(
    tasks: Sequence[dict],
    out_dir: str | Path,
    *,
    workers: int = 1,
    scheduler=None,
    runner: str | None = None,
    progress: Callable[[int, int, dict], None] | None = None,
) -> list[dict | None]:
    """Run every task not yet done and return all results in task order (None
    for tasks that failed). See module docstring for the executors."""
    out_dir = Path(out_dir)
    (out_dir / "tasks").mkdir(parents=True, exist_ok=True)
    todo = [t for t in tasks if not task_path(out_dir, t).is_file()]
    total, done = len(todo), 0

    def report(status):
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total, status)

    args = [(t, str(out_dir), runner) for t in todo]
    if scheduler is not None:
        # start-up time: dask.distributed (~0.4 s) only for a cluster run
        from distributed import Client, as_completed

        client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
        try:
            futures = (
                client.map(run_and_write, *zip(*args, strict=True), pure=False)
                if args
                else []
            )
            for fut in as_completed(futures):
                report(fut.result())
        finally:
            if client is not scheduler:
                client.close()
    elif workers > 1 and len(args) > 1:
        ctx = mp.get_context("spawn")
        with _worker_env():
            pool = ctx.Pool(processes=min(workers, len(args)))  # workers start here
        try:
            for status in pool.imap_unordered(_star, args):
                report(status)
        finally:
            pool.close()
            pool.join()
    else:
        for a in args:
            report(run_and_write(*a))
    return load_results(tasks, out_dir)


def read_task_file(path: str | Path, task: dict) -> dict:
    """The result stored in task file `path` for `task`; `ValueError` naming
    the file when it does not parse (truncated, edited, not UTF-8), is not a
    JSON object, or carries another task's key (a file copied from another
    run): a task file is reused only for the task it was written for."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as err:
        raise ValueError(f"{path}: corrupt task file ({err}).") from None
    if not isinstance(data, dict) or not isinstance(data.get("task"), dict):
        raise ValueError(
            f"{path}: corrupt task file (not a task result: expected a JSON "
            f"object with a 'task' key, found {type(data).__name__})."
        )
    if task_id(data["task"]) != task_id(task):
        raise ValueError(
            f"{path}: corrupt task file (it holds task {task_id(data['task'])}, "
            f"not {task_id(task)}: copied from another run?)."
        )
    return data


def load_results(tasks: Sequence[dict], out_dir: str | Path) -> list[dict | None]:
    """Every task's stored result in task order (None where a task has no
    file); a file that is not its task's result raises (`read_task_file`)."""
    out = []
    for t in tasks:
        p = task_path(out_dir, t)
        out.append(read_task_file(p, t) if p.is_file() else None)
    return out


def print_progress(done: int, total: int, status: dict) -> None:
    """A one-line progress printer for `run_sweep(progress=...)` (stderr)."""
    name = Path(status["path"]).stem
    mark = "ok" if status.get("ok") else f"FAILED {status.get('error')}"
    wall = status.get("wall_s")
    extra = f" {wall:.1f}s" if wall else ""
    print(f"[{done}/{total}] {name}: {mark}{extra}", file=sys.stderr, flush=True)
