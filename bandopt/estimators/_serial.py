"""A fitted estimator as plain data: a JSON tree for its structure and
scalars, a dict of named arrays for its arrays (stored together in one
`.npz`, `bandopt.estimators.save_fitted`), and back.

Only what a fitted estimator is made of is written: None, bools, ints,
strings, floats (exact: Python's shortest repr round-trips every float64;
non-finite ones by name), lists, tuples, dicts, numpy and JAX arrays (numeric
dtypes only) and numpy scalars, and dataclasses (equinox Modules included)
defined in `bandopt`. Reading back builds classes by name only from
`bandopt`'s own dataclasses and never unpickles, so a model file from
elsewhere cannot run code; anything else is refused with its path in the
object (`ValueError`)."""

import dataclasses
import importlib
import math

import jax.numpy as jnp
import numpy as np


PACKAGE = "bandopt"
"""Dataclasses are written and read back only from this package."""


def encode(obj) -> tuple[object, dict[str, np.ndarray]]:
    """`obj` as (JSON-ready tree, arrays by key); an array object met twice
    (a surface basis shared by the inner folds' models) is stored once."""
    found: dict[str, tuple] = {}  # key -> (the object, its numpy array)
    tree = _encode(obj, found, "fitted")
    return tree, {k: arr for k, (_, arr) in found.items()}


def _put(arrays: dict, value, where: str) -> str:
    """The key of array `value` in `arrays`, added unless the same object is
    there already."""
    for key, stored in arrays.items():
        if stored[0] is value:
            return key
    arr = np.asarray(value)
    if arr.dtype.kind not in "biufc":
        raise ValueError(
            f"{where}: an array of dtype {arr.dtype} cannot be stored (numeric "
            "arrays only: object arrays would need pickle)."
        )
    key = f"a{len(arrays)}"
    arrays[key] = (value, arr)
    return key


def _encode(x, arrays: dict, where: str):
    if x is None or isinstance(x, (bool, int, str)):
        return x
    if isinstance(x, float):
        return x if math.isfinite(x) else {"float": repr(x)}
    if isinstance(x, np.generic):
        return {"scalar": _put(arrays, x, where)}
    if isinstance(x, np.ndarray):
        return {"array": _put(arrays, x, where)}
    if isinstance(x, jnp.ndarray):
        return {"jax": _put(arrays, x, where)}
    if isinstance(x, tuple):
        return {"tuple": [_encode(v, arrays, f"{where}[{i}]") for i, v in enumerate(x)]}
    if isinstance(x, list):
        return {"list": [_encode(v, arrays, f"{where}[{i}]") for i, v in enumerate(x)]}
    if isinstance(x, dict):
        return {
            "items": [
                [
                    _encode(k, arrays, f"{where} key"),
                    _encode(v, arrays, f"{where}[{k!r}]"),
                ]
                for k, v in x.items()
            ]
        }
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        cls = type(x)
        if not cls.__module__.startswith(PACKAGE + "."):
            raise ValueError(
                f"{where}: a {cls.__module__}.{cls.__qualname__} cannot be stored "
                f"(dataclasses of {PACKAGE} only)."
            )
        return {
            "class": f"{cls.__module__}:{cls.__qualname__}",
            "fields": {
                f.name: _encode(getattr(x, f.name), arrays, f"{where}.{f.name}")
                for f in dataclasses.fields(x)
            },
        }
    raise ValueError(
        f"{where}: a {type(x).__module__}.{type(x).__qualname__} cannot be stored "
        "(numbers, strings, arrays, containers and bandopt dataclasses only)."
    )


def decode(tree, arrays) -> object:
    """The object `encode` gave `tree` and `arrays` for (`arrays`: a mapping
    key -> array, e.g. an open `np.load(..., allow_pickle=False)`)."""
    return _decode(tree, arrays, "fitted")


def _array(arrays, key, where: str) -> np.ndarray:
    if not isinstance(key, str) or key not in arrays:
        raise ValueError(f"{where}: array {key!r} is missing.")
    return np.asarray(arrays[key])


def _decode(t, arrays, where: str):
    if t is None or isinstance(t, (bool, int, float, str)):
        return t
    if isinstance(t, dict) and len(t) == 1:
        ((tag, v),) = t.items()
        if tag == "float" and v in ("inf", "-inf", "nan"):
            return float(v)
        if tag == "scalar":
            return _array(arrays, v, where)[()]
        if tag == "array":
            return _array(arrays, v, where)
        if tag == "jax":
            return jnp.asarray(_array(arrays, v, where))
        if tag in ("tuple", "list") and isinstance(v, list):
            out = [_decode(e, arrays, f"{where}[{i}]") for i, e in enumerate(v)]
            return tuple(out) if tag == "tuple" else out
        if tag == "items" and isinstance(v, list):
            return {
                _decode(k, arrays, f"{where} key"): _decode(
                    e, arrays, f"{where}[{k!r}]"
                )
                for k, e in v
            }
    if isinstance(t, dict) and set(t) == {"class", "fields"}:
        return _instance(t["class"], t["fields"], arrays, where)
    raise ValueError(f"{where}: unreadable entry {str(t)[:80]!r}.")


def _instance(name, fields, arrays, where: str):
    """The bandopt dataclass `name` ("module:qualname") with `fields` set as
    stored, without running its constructor (as unpickling does: the
    values are the fitted ones, already checked when they were made)."""
    module, _, qualname = str(name).partition(":")
    if not module.startswith(PACKAGE + ".") or not qualname:
        raise ValueError(f"{where}: class {name!r} is not one of {PACKAGE}'s.")
    try:
        cls = importlib.import_module(module)
        for part in qualname.split("."):
            cls = getattr(cls, part)
    except (ImportError, AttributeError):
        raise ValueError(f"{where}: class {name!r} does not exist.") from None
    if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
        raise ValueError(f"{where}: {name!r} is not a dataclass.")
    expected = {f.name for f in dataclasses.fields(cls)}
    if not isinstance(fields, dict) or set(fields) != expected:
        got = sorted(fields) if isinstance(fields, dict) else fields
        raise ValueError(
            f"{where}: {name} has fields {sorted(expected)}, the file {got}."
        )
    obj = object.__new__(cls)
    for key, value in fields.items():
        object.__setattr__(obj, key, _decode(value, arrays, f"{where}.{key}"))
    return obj
