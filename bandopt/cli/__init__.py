"""The `bandopt` command line.

Each command lives in its own module `bandopt/cli/_cmd_<name>.py` that defines
`register(subparsers)`; the modules are discovered here, so adding a command
touches no other file.
"""

import argparse
import importlib
import pkgutil
import sys


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="bandopt",
        description="Band-selection optimisation for night-time multispectral sensors.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    names = sorted(
        m.name for m in pkgutil.iter_modules(__path__) if m.name.startswith("_cmd_")
    )
    for name in names:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    from .._config import configure

    configure()
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (ValueError, FileNotFoundError) as err:
        print(f"bandopt {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
