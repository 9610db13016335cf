"""One convention for every option of the command line that takes a list.

`add_list_option` registers such an option with `ListAction`:

- one or more values (`nargs="+"`): a bare `--lamps` is a usage error (exit 2)
  naming the option, never a silent "use the default";
- values may be space- or comma-separated: `--lamps a,b c` is `--lamps a b c`.
  Options whose values are file paths do not split at commas (a comma is a
  legal file-name character); options taking a name or a file split, except
  a value that exists as a path, which is kept whole;
- the item type is applied to each value after splitting; a bad value is a
  usage error naming the option and the value (`argument --gsd: invalid float
  value: 'x'`); an empty value (`--lamps a,,b`) is refused the same way;
- repeating the option adds to the list: `--lamps a --lamps b` is
  `--lamps a b` (the first occurrence replaces the default, it never adds to
  it);
- the help says all of this in one phrase and states the default.

Fixed-arity tuples (`render --atmosphere ATMOSPHERE AEROSOL VIS_KM`,
`surfaces --percentiles LOW HIGH`) and positional file lists
(`metrics FILE...`) are not list options in this sense.
"""

import argparse
import math
import os
from collections.abc import Callable, Sequence
from typing import Any


SPLIT_PHRASE = "one or more, space- or comma-separated; repeatable"
NO_SPLIT_PHRASE = (
    "one or more, space-separated (not split at commas: a comma may be part of a "
    "file name); repeatable"
)


class ListAction(argparse.Action):
    """argparse action of every list option (see the module docstring)."""

    def __init__(
        self,
        option_strings: Sequence[str],
        dest: str,
        *,
        item_type: Callable[[str], Any] = str,
        type_name: str | None = None,
        split_commas: bool = True,
        keep_paths: bool = False,
        **kwargs,
    ):
        nargs = kwargs.pop("nargs", "+")
        if nargs != "+":
            raise ValueError(f"ListAction: nargs must be '+', got {nargs!r}.")
        if kwargs.get("type") is not None:
            raise ValueError("ListAction: give item_type, not type (applied per item).")
        super().__init__(option_strings, dest, nargs="+", **kwargs)
        self.item_type = item_type
        self.type_name = type_name or getattr(item_type, "__name__", "value")
        self.split_commas = split_commas
        self.keep_paths = keep_paths

    def _split(self, value: str) -> list[str]:
        if not self.split_commas or (self.keep_paths and os.path.exists(value)):
            return [value]
        return value.split(",")

    def __call__(self, parser, namespace, values, option_string=None):
        items = []
        for value in values:
            for part in self._split(value):
                text = part.strip()
                if not text:
                    raise argparse.ArgumentError(
                        self, f"empty value in {value!r} ({self._phrase()})"
                    )
                try:
                    items.append(self.item_type(text))
                except (TypeError, ValueError, argparse.ArgumentTypeError) as err:
                    # int('x') and float('x') say nothing ours does not
                    plain = self.item_type in (int, float) or not str(err)
                    detail = "" if plain else f" ({err})"
                    raise argparse.ArgumentError(
                        self, f"invalid {self.type_name} value: {text!r}{detail}"
                    ) from None
        current = getattr(namespace, self.dest, None)
        if current is None or current is self.default:
            current = []  # the first occurrence replaces the default
        setattr(namespace, self.dest, [*current, *items])

    def _phrase(self) -> str:
        return SPLIT_PHRASE if self.split_commas else NO_SPLIT_PHRASE


def add_list_option(
    parser: argparse.ArgumentParser,
    flag: str,
    *,
    metavar: str,
    help: str,
    type: Callable[[str], Any] = str,
    type_name: str | None = None,
    default: list | None = None,
    default_help: str | None = None,
    required: bool = False,
    split_commas: bool = True,
    keep_paths: bool = False,
) -> argparse.Action:
    """Register list option `flag` on `parser` with `ListAction`.

    `help` says what the values are; the convention and the default are
    appended: `default_help` describes the default in words (for a `None`
    default that means "computed by the command"), else the `default` list
    is shown. `keep_paths`: a value that exists as a path is not split at
    commas (for NAME|FILE options); `split_commas=False` for FILE options.
    """
    if required and default is not None:
        raise ValueError(f"{flag}: a required option has no default.")
    if default is not None:
        default = list(default)
    phrase = SPLIT_PHRASE if split_commas else NO_SPLIT_PHRASE
    if required:
        tail = "required"
    elif default_help is not None:
        tail = f"default: {default_help}"
    elif default is not None:
        tail = "default: " + " ".join(map(str, default))
    else:
        tail = "default: none"
    text = f"{help} ({phrase}; {tail.replace('%', '%%')})"
    return parser.add_argument(
        flag,
        action=ListAction,
        item_type=type,
        type_name=type_name,
        split_commas=split_commas,
        keep_paths=keep_paths,
        default=default,
        required=required,
        metavar=metavar,
        help=text,
    )


EARTH_CIRCUMFERENCE_M = 2 * math.pi * 6371e3
"""Largest GSD: the circumference of the sensor model's spherical Earth
(`bandopt.sensor`, R = 6371 km); a pixel cannot be wider than the Earth.
Stated here, not imported, so that building the parser imports no JAX."""


def gsd_type() -> Callable[[str], float]:
    """The argparse `type` of every `--gsd`: > 0 and at most the Earth's
    circumference. [m]"""
    return bounded(
        lo=0.0, lo_open=True, hi=EARTH_CIRCUMFERENCE_M, why="m (a pixel on the Earth)"
    )


SEED_MAX = 2**32 - 1
"""Largest seed: numpy's `RandomState` and a 32-bit JAX key take 0..2**32-1."""


def bounded(
    kind: Callable[[str], Any] = float,
    *,
    lo: float | int | None = None,
    hi: float | int | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    why: str = "",
) -> Callable[[str], Any]:
    """An argparse `type` for a number that must be finite and lie in a range.

    The value is parsed with `kind` (`int` or `float`); NaN, infinity and a
    value outside `lo`/`hi` (open ends excluded) raise
    `argparse.ArgumentTypeError`, which argparse reports as a usage error
    (exit 2) naming the option: `argument --moon-zenith: 95 is outside
    [0, 90) deg (the Moon above the horizon)`. `why` says what the range
    means, with its unit.
    """
    left = "(" if lo_open else "["
    right = ")" if hi_open else "]"
    span = f"{left}{'-inf' if lo is None else f'{lo:g}'}, "
    span += f"{'inf' if hi is None else f'{hi:g}'}{right}"
    tail = f" {why}" if why else ""

    def parse(text: str):
        try:
            value = kind(text)
        except (TypeError, ValueError):
            name = "an integer" if kind is int else "a number"
            raise argparse.ArgumentTypeError(
                f"{text!r} is not {name}; expected {span}{tail}"
            ) from None
        x = float(value) if kind is not int else value
        bad = (kind is not int and x != x) or x in (float("inf"), float("-inf"))
        bad = bad or (lo is not None and (x < lo or (lo_open and x == lo)))
        bad = bad or (hi is not None and (x > hi or (hi_open and x == hi)))
        if bad:
            raise argparse.ArgumentTypeError(f"{text} is outside {span}{tail}")
        return value

    parse.__name__ = getattr(kind, "__name__", "number")
    return parse


def add_place_options(
    p: argparse.ArgumentParser, *, required: bool, date_help: str, overpass_help: str
) -> None:
    """`--date`, `--lat`, `--lon` and `--overpass`: where and when a scene is
    seen (`bandopt moon` needs them; `bandopt map` takes them to check the
    Moon)."""
    p.add_argument("--date", required=required, default=None, help=date_help)
    p.add_argument(
        "--lat",
        type=bounded(lo=-90.0, hi=90.0, why="deg"),
        required=required,
        default=None,
        help="latitude, -90 to 90 [deg, north +]",
    )
    p.add_argument(
        "--lon",
        type=bounded(lo=-180.0, hi=360.0, why="deg"),
        required=required,
        default=None,
        help="longitude, -180 to 180, or 0 to 360 east [deg, east +]",
    )
    p.add_argument("--overpass", default=None, metavar="HH:MM", help=overpass_help)


def seed_type() -> Callable[[str], int]:
    """The argparse `type` of every `--seed`: an integer in 0..`SEED_MAX`."""
    return bounded(int, lo=0, hi=SEED_MAX, why="(a random seed)")
