"""Strict JSON, the one writer of every JSON file bandopt makes.

`json.dumps` writes the non-standard tokens `NaN` and `Infinity` for
non-finite floats; most JSON readers (browsers, `jq`, other languages) reject
them. `strict_dumps` writes `null` for them instead, explicitly
(`json_safe`), and refuses any that remain (`allow_nan=False`), so a value
that is undefined (an F1 with no pixels of a class, a ratio over zero) reads
as missing everywhere.
"""

import json
import math
from pathlib import Path


def json_safe(obj):
    """`obj` with every non-finite float (NaN, ±inf) replaced by None, numpy
    and JAX scalars and arrays converted to Python; containers are copied."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    if hasattr(obj, "tolist") and callable(obj.tolist):  # numpy / JAX array, scalar
        return json_safe(obj.tolist())
    return obj


def _default(o):
    """Anything else JSON has no type for (a path, a date, an enum): its text."""
    if hasattr(o, "tolist"):
        return json_safe(o.tolist())
    if isinstance(o, Path):
        return str(o)
    return str(o)


def strict_dumps(obj, *, indent: int | None = 2, sort_keys: bool = False) -> str:
    """Strict JSON text of `obj`: non-finite floats as null, numpy and JAX
    values as Python numbers and lists, other objects as their text.
    `indent=None` gives one line (a JSON Lines record)."""
    return json.dumps(
        json_safe(obj), indent=indent, sort_keys=sort_keys, allow_nan=False,
        default=_default,
    )
