"""The `bandopt` command line.

Each command lives in its own module `bandopt/cli/_cmd_<name>.py` that defines
`register(subparsers)`; the modules are discovered here, so adding a command
touches no other file.

Start-up time: every module of `bandopt/cli` imports heavy packages (JAX,
colour, scikit-learn, matplotlib, pandas) and the bandopt modules that load
them inside its functions, so `--help` and cached listings start quickly
(`bandopt library --json` in well under 1 s). This is the one place where
function-local imports are the rule; they carry no comment of their own.
Everywhere else in `bandopt` imports sit at the file top, and each
function-local exception names its reason on the line above
(`tests/test_imports.py`).

Errors are one line on stderr, `bandopt COMMAND: error: ...`, naming the file
or option and the problem: exit status 2 for bad input (`ValueError`, a
missing input file), 1 for a file that cannot be written or memory that
cannot be had, 141 for a closed output pipe (as a shell reports SIGPIPE),
130 for Ctrl-C, 143 for SIGTERM (each with a one-line message), 70 for an
internal error (set `BANDOPT_TRACEBACK=1` to see its traceback). `bandopt`
without a command prints the help on stderr and exits 2. Warnings are one
line each, `bandopt COMMAND: warning: ...` (no source file and line).
"""

import argparse
import contextlib
import importlib
import os
import pkgutil
import signal
import sys
import warnings

from ._options import ListAction
from ._output import OutputLock as OutputLock  # one run per --out (experiments)


EXIT_BAD_INPUT = 2
EXIT_IO = 1
EXIT_BROKEN_PIPE = 141
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143  # 128 + SIGTERM, as a shell reports it
EXIT_INTERNAL = 70


class _Terminated(BaseException):
    """Raised in the main thread by the SIGTERM handler of `main`."""


def _on_sigterm(signum, frame):
    raise _Terminated


@contextlib.contextmanager
def _sigterm_as_exception():
    """While a command runs, SIGTERM raises `_Terminated` (a one-line message
    and exit 143 instead of a silent death); the previous handler is put back
    after (an in-process caller keeps its own)."""
    try:
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _show_warning(command: str):
    """`warnings.showwarning` for a command: one line, no file and line."""

    def show(message, category, filename, lineno, file=None, line=None):
        text = " ".join(str(message).split())
        with contextlib.suppress(OSError):
            print(f"bandopt {command}: warning: {text}", file=sys.stderr, flush=True)

    return show


def run_radiometry(bands, label: str, out, **kwargs) -> dict:
    """What `bandopt radiometry --out OUT [--recommend FILE]` does, from Python
    (`make radiometry` runs it): lock `out`, compute, write, and with
    `recommend=FILE` put key "radiometry" of that recommendation file.
    Keyword arguments as `_cmd_radiometry.run_radiometry`; returns the
    `bandopt.radiometry.compute` result."""
    from ._cmd_radiometry import run_radiometry as run

    return run(bands, label, out, **kwargs)


def _version() -> str:
    from .. import __version__

    return __version__


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="bandopt",
        description="Band-selection optimisation for night-time multispectral sensors.",
        epilog="`bandopt COMMAND --help` describes a command and its options.",
    )
    parser.add_argument("--version", action="version", version=f"bandopt {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    names = sorted(
        m.name for m in pkgutil.iter_modules(__path__) if m.name.startswith("_cmd_")
    )
    for name in names:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    for p in sub.choices.values():
        _defaults_in_help(p)
    return parser


def _defaults_in_help(parser: argparse.ArgumentParser) -> None:
    """Append `(default: X)` to every option's help that does not state it."""
    for a in parser._actions:
        if a.help in (None, argparse.SUPPRESS) or a.option_strings == []:
            continue
        if isinstance(a, argparse._HelpAction | argparse._VersionAction | ListAction):
            continue  # a list option states its convention and default itself
        if "default" in a.help.lower():
            continue
        if isinstance(a, argparse._StoreTrueAction):
            a.help += " (default: off)"
        elif a.required:
            a.help += " (required)"
        elif a.default is None:
            a.help += " (default: none)"
        else:
            d = a.default
            d = " ".join(map(str, d)) if isinstance(d, list | tuple) else d
            a.help += f" (default: {d})".replace("%", "%%")


def _refuse_empty_values(parser: argparse.ArgumentParser, args) -> None:
    """An option given an empty or blank string (`--plot ''`) is a usage
    error naming it: no option of bandopt takes an empty name."""
    sub = next(
        a for a in parser._actions if isinstance(a, argparse._SubParsersAction)
    ).choices[args.command]
    for a in sub._actions:
        value = getattr(args, a.dest, None)
        values = value if isinstance(value, list | tuple) else [value]
        if a.option_strings and any(
            isinstance(v, str) and not v.strip() for v in values
        ):
            sub.error(f"argument {a.option_strings[0]}: empty value")


def _one_line(err: BaseException) -> str:
    if isinstance(err, OSError) and err.filename is not None:
        what = err.strerror or str(err)
        return f"{err.filename}: {what}"
    text = str(err) or type(err).__name__
    return text


def _user_words(message: str, field_options: dict[str, str]) -> str:
    """`message` with the library's argument names (`gsd_m`) replaced by the
    options that set them (`--gsd`): a user reads the names they typed."""
    import re

    for field, option in field_options.items():
        # backticked always; bare only for identifier-like names (`gsd_m`), so
        # an English word ("after 30 nights") or an option already written
        # (`--nights`) stays as it is
        bare = rf"|(?<![-\w]){field}\b" if "_" in field else ""
        message = re.sub(rf"`{field}`{bare}", option, message)
    return message


def _report(command: str, message: str) -> None:
    try:
        print(f"bandopt {command}: error: {message}", file=sys.stderr, flush=True)
    except OSError:
        pass


def _silence_stdout() -> None:
    """After a broken pipe: point stdout at /dev/null so the interpreter's
    final flush does not raise again (Python docs, "Note on SIGPIPE")."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def _configure_environment() -> None:
    """`bandopt.configure()` without importing JAX: the same settings (CPU,
    float64, persistent compilation cache) as environment variables, which
    JAX reads when a command first imports it. A command that needs no JAX
    (a cached listing, `--help`) then starts in a fraction of a second. If
    JAX is already imported (tests, a Python session), configure it now."""
    from pathlib import Path

    os.environ.setdefault("JAX_PLATFORMS", "cpu")
    cache = os.environ.get(
        "BANDOPT_JAX_CACHE", str(Path.home() / ".cache" / "bandopt" / "jax")
    )
    if "jax" in sys.modules:
        from .._config import configure

        configure()
        return
    Path(cache).mkdir(parents=True, exist_ok=True)
    os.environ["JAX_ENABLE_X64"] = "1"
    os.environ["JAX_COMPILATION_CACHE_DIR"] = cache
    # here, not at the top: the module's import stays light (`--help`); the
    # constant's module imports JAX only inside `configure()`
    from .._config import CACHE_MIN_COMPILE_S

    os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = str(CACHE_MIN_COMPILE_S)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser()
    if not argv:
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    _refuse_empty_values(parser, args)
    _configure_environment()
    from . import _progress

    try:
        with (
            _sigterm_as_exception(),
            warnings.catch_warnings(),
            _progress.phase(f"bandopt {args.command}", _progress.key_for(argv)),
        ):
            warnings.showwarning = _show_warning(args.command)
            rc = int(args.func(args) or 0)
        sys.stdout.flush()
        return rc
    except _Terminated:
        _report(args.command, "terminated (SIGTERM)")
        return EXIT_TERMINATED
    except BrokenPipeError:
        _silence_stdout()
        _report(args.command, "stdout: broken pipe (the reading process closed it)")
        return EXIT_BROKEN_PIPE
    except KeyboardInterrupt:
        _report(args.command, "interrupted")
        return EXIT_INTERRUPTED
    except (ValueError, FileNotFoundError) as err:
        names = getattr(args, "field_options", {})
        _report(args.command, _user_words(_one_line(err), names))
        return EXIT_BAD_INPUT
    except OSError as err:
        _report(args.command, _one_line(err))
        return EXIT_IO
    except MemoryError as err:
        _report(
            args.command,
            f"out of memory ({_one_line(err)}); reduce the problem size",
        )
        return EXIT_IO
    except Exception as err:  # a bug: one line, the traceback on request
        if os.environ.get("BANDOPT_TRACEBACK"):
            raise
        import traceback

        where = traceback.extract_tb(err.__traceback__)[-1]
        _report(
            args.command,
            f"internal error {type(err).__name__}: {_one_line(err)} (at "
            f"{os.path.basename(where.filename)}:{where.lineno}; set "
            "BANDOPT_TRACEBACK=1 for the traceback, and please report it)",
        )
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
