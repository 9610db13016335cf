"""Safe output for the command line: valid JSON, atomic files, one run per folder.

- `dump_json` / `print_json`: strict JSON (`allow_nan=False`); NaN and infinity
  become `null` (`json_safe`), so a reader never meets the non-standard `NaN`.
- `atomic_write_text`, `atomic_path`: a file appears complete or not at all
  (written to a temporary name in the same folder, then `os.replace`).
- `prepare_file`, `prepare_dir`: create the parent folder and check that it
  is writable *before* a long computation, with a one-line error naming it.
- `OutputLock`: refuse a second run writing into the same `--out` folder
  while the first is alive (an `fcntl` lock on `<out>/.bandopt.lock`; the
  kernel releases it when the process dies, so a killed run never blocks).
  The lock file is removed when the run ends, and a folder the run created
  is removed again when the run fails before writing anything into it
  (`made_dir`).
- `refuse_existing`: a data file the user names (`simulate --out FILE`,
  `bands --export-csv FILE`) is never replaced without `--force`.
"""

import contextlib
import os
import sys
import tempfile
from pathlib import Path

from ..strict_json import (
    json_safe as json_safe,  # re-export: the CLI's name
    strict_dumps,
)


LOCK_NAME = ".bandopt.lock"


def dumps(obj, *, indent: int | None = 2) -> str:
    """Strict JSON text of `obj` (non-finite floats as null)."""
    return strict_dumps(obj, indent=indent)


def print_json(obj, *, indent: int | None = 2, stream=None) -> None:
    """Print `obj` as strict JSON on stdout (or `stream`)."""
    stream = sys.stdout if stream is None else stream
    stream.write(dumps(obj, indent=indent) + "\n")


def _writable_dir(directory: Path, what: str) -> None:
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise NotADirectoryError(
            20, f"{what}: not a folder (a file has that name)", str(directory)
        ) from None
    if not directory.is_dir():
        raise NotADirectoryError(20, f"{what}: not a folder", str(directory))
    if not os.access(directory, os.W_OK | os.X_OK):
        raise PermissionError(13, f"{what}: folder is not writable", str(directory))


def prepare_file(path, what: str = "output") -> Path:
    """Create the parent folder of output file `path` and check it is writable
    and that `path` is not a folder. Raises `OSError` naming the path."""
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(21, f"{what}: is a folder, expected a file", str(path))
    _writable_dir(path.parent if str(path.parent) else Path("."), what)
    if path.exists() and not os.access(path, os.W_OK):
        raise PermissionError(13, f"{what}: file is not writable", str(path))
    return path


def prepare_dir(path, what: str = "--out") -> Path:
    """Create output folder `path` and check it is writable."""
    path = Path(path)
    _writable_dir(path, what)
    return path


def refuse_existing(path, option: str, force: bool) -> None:
    """`ValueError` when output file `path` exists and `force` is off: a
    user's file is replaced only when they say so."""
    path = Path(path)
    if path.exists() and not force:
        raise ValueError(
            f"{option} {path}: the file exists; add --force to replace it, or "
            "choose another name."
        )


@contextlib.contextmanager
def made_dir(path, what: str = "--out"):
    """`prepare_dir(path)` for the body; when the body raises and the folder
    did not exist before, the folder is removed again if it is still empty
    (a failed run leaves nothing behind)."""
    path = Path(path)
    existed = path.exists()
    prepare_dir(path, what)
    try:
        yield path
    except BaseException:
        if not existed:
            with contextlib.suppress(OSError):
                path.rmdir()  # only when empty
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path (a `str`, same suffix) beside `path` to write
    into; on success it is renamed onto `path`, on error removed."""
    path = Path(path)
    prepare_file(path)
    fd, tmp = tempfile.mkstemp(
        dir=path.parent, prefix=f".{path.stem}-", suffix=path.suffix
    )
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; files are 0644
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


def atomic_write_text(path, text: str) -> Path:
    """Write `text` to `path` atomically."""
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)
    return Path(path)


def atomic_write_json(path, obj) -> Path:
    """Write `obj` as strict JSON to `path` atomically."""
    return atomic_write_text(path, dumps(obj) + "\n")


class OutputLock:
    """`with OutputLock(out_dir):` holds an exclusive lock on `out_dir`; a
    second holder (another process) gets `ValueError` naming the folder and
    the process id of the first."""

    def __init__(self, directory):
        self.directory = Path(directory)
        self.path = self.directory / LOCK_NAME
        self._fh = None
        self._made = False

    def __enter__(self):
        self._made = not self.directory.exists()
        prepare_dir(self.directory)
        try:
            import fcntl
        except ImportError:  # not POSIX: no lock (documented)
            self._fh = open(self.path, "a+")
            return self
        while True:
            fh = open(self.path, "a+")
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                fh.seek(0)
                holder = fh.read().strip() or "another process"
                fh.close()
                self._drop_made_dir()
                raise ValueError(
                    f"{self.directory}: another bandopt run ({holder}) is writing "
                    "into this --out folder; wait for it or choose another --out."
                ) from None
            try:  # the holder before us may have removed the file: lock anew
                same = os.path.samestat(os.fstat(fh.fileno()), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if same:
                break
            fh.close()
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()}: {' '.join(sys.argv[1:])[:200]}\n")
        fh.flush()
        self._fh = fh
        return self

    def __exit__(self, exc_type, *exc):
        if self._fh is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.path)  # removed while still locked, then released
            self._fh.close()  # closing releases the flock
            self._fh = None
        if exc_type is not None:
            self._drop_made_dir()
        return False

    def _drop_made_dir(self) -> None:
        """Remove the folder this lock created when nothing was written."""
        if self._made:
            with contextlib.suppress(OSError):
                self.directory.rmdir()  # only when empty


def write_manifest(directory, **kwargs) -> Path:
    """`bandopt.provenance.manifest` written atomically to `directory`; a
    folder inside the repository's `results/` needs a clean code tree
    (`bandopt.provenance.check_clean_tree`)."""
    from ..provenance import check_clean_tree, manifest

    check_clean_tree(directory)
    return atomic_write_text(
        Path(directory) / "manifest.json",
        strict_dumps(manifest(**kwargs)) + "\n",
    )


def add_locked_out(parser) -> None:
    """The `--out DIR` option of commands that lock their output folder."""
    parser.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="output folder; a second run into the same folder is refused while "
        "the first is running",
    )
