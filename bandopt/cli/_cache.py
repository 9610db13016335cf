"""A small on-disk cache for command output that is slow to build and
depends only on the installed package (`bandopt library --json` builds and
classifies the whole lamp library: seconds; read back: milliseconds).

The key hashes the bandopt version, the size and modification time of every
file of the package (code and data), the versions of colour-science, numpy
and JAX, the command's options and the
environment variables that change the library (`BANDOPT_LSPDD`), so any
edit, reinstall or option change misses. Stored in `$BANDOPT_CACHE` or
`~/.cache/bandopt/cli`; `BANDOPT_NO_CACHE=1` switches it off.
"""

import hashlib
import json
import os
from pathlib import Path


ENV_KEYS = ("BANDOPT_LSPDD",)


def cache_dir() -> Path:
    return Path(
        os.environ.get("BANDOPT_CACHE", Path.home() / ".cache" / "bandopt" / "cli")
    )


def package_fingerprint() -> str:
    """Hash of (relative path, size, mtime) of every file of the package."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
        for name in sorted(filenames):
            if name.endswith((".pyc", ".pyo")):
                continue
            p = os.path.join(dirpath, name)
            st = os.stat(p)
            rel = os.path.relpath(p, root)
            h.update(f"{rel}|{st.st_size}|{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def key(command: str, options: dict) -> str:
    from .. import __version__

    h = hashlib.sha256()
    from importlib import metadata

    h.update(f"{command}|{__version__}|{package_fingerprint()}|".encode())
    for dist in ("colour-science", "numpy", "jax"):  # the library is built with them
        try:
            h.update(f"{dist}={metadata.version(dist)}|".encode())
        except metadata.PackageNotFoundError:
            pass
    h.update(json.dumps(options, sort_keys=True).encode())
    for k in ENV_KEYS:
        h.update(f"|{k}={os.environ.get(k)}".encode())
    return h.hexdigest()[:32]


def enabled() -> bool:
    return os.environ.get("BANDOPT_NO_CACHE", "") in ("", "0")


def load(command: str, k: str) -> str | None:
    """The cached text, or None."""
    if not enabled():
        return None
    p = cache_dir() / f"{command}-{k}.json"
    try:
        return p.read_text()
    except OSError:
        return None


def store(command: str, k: str, text: str) -> None:
    """Store `text` (best effort: a read-only home just means no cache)."""
    if not enabled():
        return
    from ._output import atomic_write_text

    try:
        atomic_write_text(cache_dir() / f"{command}-{k}.json", text)
    except OSError:
        pass
