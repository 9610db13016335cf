"""A fitted estimator as a file: fit once, predict many times.

`save_fitted(path, fitted, fingerprint)` writes a fitted estimator
(`Fitted`) to one `.npz`: its arrays, plus a JSON header (the `header`
array, UTF-8) holding the format, the fingerprint and the estimator's
structure (`_serial`). No pickle: `load_fitted` reads it with
`allow_pickle=False` and builds only bandopt's own dataclasses.

The fingerprint (`fingerprint`) says what the fit depended on: the band set
(centres, FWHMs, shapes and the hash of its response on the library grid),
the estimator's configuration, the surface knowledge, the user's own prior
lamps, the scenario context trained on, the package data (lamp library,
surfaces, atmospheres, Moon; `provenance.data_versions`) and the code
(bandopt version, `provenance.source_hash`, numpy and JAX versions).
`load_fitted(path, expected)` refuses a file whose fingerprint differs
from `expected`, naming the file and the fields that differ; a file it
cannot read (truncated, not a model, bad CRC) raises `ModelFileError`
naming it.

`fit_cached` fits an estimator or loads it from the user's cache
(`cache_dir`), keyed by what was asked (bands, configuration, surface,
own lamps, context): an entry whose fingerprint differs (other code or data)
or that cannot be read is refitted and replaced, never trusted."""

import contextlib
import dataclasses
import hashlib
import json
import os
import tempfile
import zipfile
from importlib import metadata
from pathlib import Path

import numpy as np

from .. import __version__, search
from ..forward import band_weights_on
from ..provenance import data_versions, git_commit, source_hash
from ..spectra import GRID_1NM
from ._serial import decode, encode


FORMAT = "bandopt-fitted-estimator"
FORMAT_VERSION = 1

EVALUATE_CONTEXT = ("search", None, 0, "none")
"""`search.get_context` arguments of the scenes `bandopt evaluate`'s
estimators train on (preset, noise, fold seed, atmospheres)."""

ENV_KEYS = ("BANDOPT_LSPDD",)
"""Environment variables that change the lamp library (hence the fit)."""


class ModelFileError(ValueError):
    """A model file that cannot be read as a fitted estimator."""


class FingerprintMismatchError(ValueError):
    """A model file fitted for other bands, configuration, data or code;
    `fields` lists the differing fingerprint fields (dotted paths)."""

    def __init__(self, message: str, fields: tuple[str, ...]):
        super().__init__(message)
        self.fields = fields


def _jsonable(x):
    """`x` as plain JSON values (tuples as lists, numpy scalars as Python)."""
    return json.loads(json.dumps(x, default=lambda v: np.asarray(v).tolist()))


def _sha(values) -> str:
    arr = np.ascontiguousarray(np.asarray(values, np.float64))
    return hashlib.sha256(repr(arr.shape).encode() + arr.tobytes()).hexdigest()[:16]


def _floats(values) -> list[float]:
    return [float(v) for v in np.asarray(values, float).ravel()]


def fingerprint(
    config,
    bands,
    *,
    surface_mode: str,
    own=None,
    context: tuple = EVALUATE_CONTEXT,
) -> dict:
    """What a fit of `config` (a registered estimator's configuration) on
    `bands` depends on (see the module docstring); `own` the user's prior
    lamps (names, values on GRID_1NM, level-2 classes) or None. JSON-ready,
    compared field by field by `check_fingerprint`."""
    versions = {}
    for dist in ("numpy", "jax", "jaxlib"):
        try:
            versions[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[dist] = None
    grid = np.asarray(GRID_1NM, float)
    shape = getattr(bands, "shape_k", None)
    has_own = bool(own) and bool(own[0])
    return _jsonable(
        {
            "bands": {
                "centre_nm": _floats(bands.centre_nm),
                "fwhm_nm": _floats(bands.fwhm_nm),
                "shape_k": None if shape is None else _floats(shape),
                "response_sha256": _sha(band_weights_on(bands, grid)),
            },
            "estimator": {
                "name": config.name,
                **{f.name: getattr(config, f.name) for f in dataclasses.fields(config)},
            },
            "surface_mode": surface_mode,
            "own_lamps": (
                {
                    "names": list(own[0]),
                    "classes": list(own[2]),
                    "values_sha256": _sha(own[1]),
                }
                if has_own
                else None
            ),
            "context": list(context),
            "data": {
                **data_versions(),
                **{k: os.environ.get(k) for k in ENV_KEYS},
            },
            "code": {"bandopt": __version__, "source": source_hash(), **versions},
        }
    )


def _flat(d, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict) and v:
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def check_fingerprint(path, stored: dict, expected: dict) -> None:
    """Raise `FingerprintMismatchError` naming `path` and every field where the
    file's fingerprint `stored` differs from `expected`."""
    a, b = _flat(stored), _flat(_jsonable(expected))
    diff = tuple(k for k in dict.fromkeys([*b, *a]) if a.get(k) != b.get(k))
    if not diff:
        return

    def show(v) -> str:
        text = json.dumps(v)
        return text if len(text) <= 60 else text[:57] + "..."

    parts = [f"{k} (model: {show(a.get(k))}, asked: {show(b.get(k))})" for k in diff]
    more = f" and {len(parts) - 3} more" if len(parts) > 3 else ""
    raise FingerprintMismatchError(
        f"{path}: the model was fitted for other {', '.join(diff[:3])}{more}: "
        + "; ".join(parts[:3])
        + ". Fit it again (bandopt fit) with these bands and options.",
        diff,
    )


def save_fitted(path, fitted, fingerprint: dict) -> Path:
    """Write `fitted` with its `fingerprint` to `path` (`.npz`), atomically
    (a reader never sees half a file)."""
    path = Path(path)
    tree, arrays = encode(fitted)
    header = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "fingerprint": _jsonable(fingerprint),
        "git_commit": git_commit(),
        "fitted": tree,
    }
    blob = np.frombuffer(json.dumps(header).encode(), np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}-", suffix=".npz")
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, header=blob, **arrays)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600: a model is data
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
    return path


def _header(npz, path) -> dict:
    if "header" not in npz.files:
        raise ModelFileError(f"{path}: not a bandopt model (no header).")
    try:
        header = json.loads(bytes(npz["header"]).decode())
    except (ValueError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{path}: unreadable model header ({exc}).") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ModelFileError(f"{path}: not a bandopt model (format {FORMAT!r}).")
    if header.get("format_version") != FORMAT_VERSION:
        raise ModelFileError(
            f"{path}: model format version {header.get('format_version')!r}, this "
            f"bandopt reads {FORMAT_VERSION}: fit it again (bandopt fit)."
        )
    return header


_READ_ERRORS = (OSError, EOFError, zipfile.BadZipFile, ValueError, KeyError)


def read_fingerprint(path) -> dict:
    """The fingerprint stored in model file `path`."""
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as npz:
            return _header(npz, path)["fingerprint"]
    except ModelFileError:
        raise
    except _READ_ERRORS as exc:
        raise ModelFileError(f"{path}: unreadable model file ({exc}).") from None


def load_fitted(path, expected: dict | None = None):
    """The fitted estimator in `path`, after checking its fingerprint against
    `expected` (None: unchecked). Raises `FingerprintMismatchError` or
    `ModelFileError` (both `ValueError`) naming the file."""
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as npz:
            header = _header(npz, path)
            if expected is not None:
                check_fingerprint(path, header["fingerprint"], expected)
            arrays = {k: npz[k] for k in npz.files if k != "header"}
        return decode(header["fitted"], arrays)
    except (ModelFileError, FingerprintMismatchError):
        raise
    except _READ_ERRORS as exc:
        raise ModelFileError(f"{path}: unreadable model file ({exc}).") from None


def cache_dir() -> Path:
    """Where fitted estimators are cached: `$BANDOPT_CACHE_DIR`, else
    `$XDG_CACHE_HOME/bandopt`, else `~/.cache/bandopt`; models in `models/`."""
    if os.environ.get("BANDOPT_CACHE_DIR"):
        return Path(os.environ["BANDOPT_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "bandopt"


def cache_path(fp: dict) -> Path:
    """The cache file of a fit asked for with fingerprint `fp`: keyed by what
    was asked (every field but data and code), so a fit made by other code
    or data is found, found stale and replaced."""
    asked = {k: v for k, v in fp.items() if k not in ("data", "code")}
    key = hashlib.sha256(json.dumps(asked, sort_keys=True).encode()).hexdigest()
    return cache_dir() / "models" / f"{fp['estimator']['name']}-{key[:24]}.npz"


def cache_enabled() -> bool:
    """False when `BANDOPT_NO_CACHE` is set (to anything but 0)."""
    return os.environ.get("BANDOPT_NO_CACHE", "") in ("", "0")


@dataclasses.dataclass(frozen=True)
class CacheOutcome:
    """How `fit_cached` got its estimator: `action` "loaded", "fitted"
    (nothing cached), "refitted" (the entry was stale or unreadable:
    `reason` says which field or error) or "uncached" (cache off or not
    writable: `reason`); `path` the cache file; `fingerprint` the fit's."""

    action: str
    path: Path | None
    fingerprint: dict
    reason: str = ""


def fit_cached(
    config,
    bands,
    *,
    surface_mode: str,
    own=None,
    context: tuple = EVALUATE_CONTEXT,
    fit=None,
):
    """(`config` fitted on `bands` as `config.fit` does on the scenes of
    `search.get_context(*context)`, `CacheOutcome`): loaded from the cache
    when an entry with the same fingerprint is there, else fitted and
    stored. A stale or unreadable entry is refitted and replaced. `fit`
    (context -> fitted estimator): how to fit when fitting, for a caller
    that wraps `config.fit`; it must fit what the fingerprint describes."""
    fp = fingerprint(config, bands, surface_mode=surface_mode, own=own, context=context)
    if fit is None:

        def fit(ctx):
            return config.fit(ctx, bands, surface_mode=surface_mode, own=own)

    def fit_now():
        return fit(search.get_context(*context))

    if not cache_enabled():
        return fit_now(), CacheOutcome("uncached", None, fp, "BANDOPT_NO_CACHE is set")
    path = cache_path(fp)
    action, reason = "fitted", ""
    if path.exists():
        try:
            return load_fitted(path, fp), CacheOutcome("loaded", path, fp)
        except FingerprintMismatchError as exc:
            action, reason = "refitted", f"was stale (other {', '.join(exc.fields)})"
        except ModelFileError as exc:
            action, reason = "refitted", f"was unreadable ({exc})"
    fitted = fit_now()
    try:
        save_fitted(path, fitted, fp)
    except OSError as exc:
        return fitted, CacheOutcome("uncached", path, fp, f"cannot write: {exc}")
    return fitted, CacheOutcome(action, path, fp, reason)
