"""Progress for long phases: a line on stderr every few seconds with the time
elapsed and, when known, the time left.

The time left comes from the last run of the same phase on this machine
(stored beside the listing cache, `bandopt.cli._cache.cache_dir()`), or from
a rate measured in this run; when neither exists the line says so instead
of guessing.
"""

import contextlib
import json
import sys
import threading
import time


def enabled() -> bool:
    """Progress lines go to a terminal only (as git and rio do), or anywhere
    with `BANDOPT_PROGRESS=1`; `BANDOPT_PROGRESS=0` silences them."""
    import os

    flag = os.environ.get("BANDOPT_PROGRESS", "")
    if flag in ("0", "1"):
        return flag == "1"
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


def key_for(argv) -> str:
    """The timing key of a command line (the same command and options)."""
    import hashlib

    return "argv:" + hashlib.sha256("\0".join(argv).encode()).hexdigest()[:16]


FIRST_REPORT_S = 5.0
"""A phase shorter than this prints nothing."""

EVERY_S = 10.0


def _timings_path():
    from ._cache import cache_dir

    return cache_dir() / "timings.json"


def last_duration(key: str) -> float | None:
    try:
        return float(json.loads(_timings_path().read_text())[key])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def record_duration(key: str, seconds: float) -> None:
    from ._cache import enabled
    from ._output import atomic_write_json

    if not enabled():
        return
    try:
        data = json.loads(_timings_path().read_text())
        if not isinstance(data, dict):
            data = {}
    except (OSError, ValueError):
        data = {}
    data[key] = round(float(seconds), 2)
    try:
        atomic_write_json(_timings_path(), data)
    except OSError:
        pass


def _fmt(s: float) -> str:
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.1f} min"


@contextlib.contextmanager
def phase(label: str, key: str, *, expected_s: float | None = None, stream=None):
    """`with phase("training estimators", "evaluate:train:search"):` prints
    `label: 15 s elapsed, about 25 s left` to stderr every `EVERY_S` after
    `FIRST_REPORT_S`, and stores the duration under `key` when it succeeds."""
    stream = sys.stderr if stream is None else stream
    expected = expected_s if expected_s is not None else last_duration(key)
    done = threading.Event()
    t0 = time.perf_counter()

    def beat():
        wait = FIRST_REPORT_S
        while not done.wait(wait):
            el = time.perf_counter() - t0
            if expected is None:
                left = "time left unknown (first run of this phase here)"
            elif expected > el:
                left = f"about {_fmt(expected - el)} left (last run: {_fmt(expected)})"
            else:
                left = f"longer than the last run ({_fmt(expected)})"
            try:
                print(f"[{label}] {_fmt(el)} elapsed, {left}", file=stream, flush=True)
            except (OSError, ValueError):
                return
            wait = EVERY_S

    th = threading.Thread(target=beat, daemon=True) if enabled() else None
    if th is not None:
        th.start()
    try:
        yield
    finally:
        done.set()
        if th is not None:
            th.join(timeout=1.0)
    elapsed = time.perf_counter() - t0
    if elapsed >= FIRST_REPORT_S:  # only phases worth a progress line
        record_duration(key, elapsed)


class Steps:
    """Progress of a phase made of `total` equal steps (tiles of a map):
    `step(done)` prints `label: done of total, 5 s elapsed, about 20 s left`
    to stderr at most every `EVERY_S` (first after `FIRST_REPORT_S`), the
    time left from the rate of the steps done in this run (steps skipped on
    resuming do not count). Silent unless `enabled()`."""

    def __init__(self, label: str, total: int, *, skipped: int = 0, stream=None):
        self.label, self.total, self.skipped = label, int(total), int(skipped)
        self.stream = sys.stderr if stream is None else stream
        self.t0 = time.perf_counter()
        self.next_s = FIRST_REPORT_S
        self.on = enabled()

    def step(self, done: int) -> None:
        el = time.perf_counter() - self.t0
        if not self.on or el < self.next_s:
            return
        self.next_s = el + EVERY_S
        ran = done - self.skipped
        left = (
            f"about {_fmt(el / ran * (self.total - done))} left"
            if ran > 0
            else "time left unknown (no step finished yet)"
        )
        with contextlib.suppress(OSError, ValueError):
            print(
                f"[{self.label}] {done} of {self.total}, {_fmt(el)} elapsed, {left}",
                file=self.stream,
                flush=True,
            )
