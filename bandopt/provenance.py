"""Provenance manifests: what made a result, so any figure can be traced and re-made."""

import datetime as _dt
import hashlib
import os
import platform
import subprocess
import sys
from importlib import metadata
from pathlib import Path

from .strict_json import strict_dumps


PACKAGES = (
    "bandopt",
    "jax",
    "jaxlib",
    "equinox",
    "optimistix",
    "lineax",
    "nlopt",
    "colour-science",
    "scikit-learn",
    "numpy",
    "scipy",
    "earthlib",
    "ephem",
    "pvlib",
    "matplotlib",
    "rasterio",
)


CHECKOUT = Path(__file__).resolve().parent
"""Where git is asked: the checkout holding bandopt (tests point it elsewhere)."""

ALLOW_DIRTY_ENV = "BANDOPT_ALLOW_DIRTY"
"""Set to 1 to write a manifest into `results/` from a tree with uncommitted code."""


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(
            ["git", *args],
            capture_output=True,
            text=True,
            check=True,
            cwd=CHECKOUT,
        )
    except (OSError, subprocess.CalledProcessError):
        return None
    return out.stdout.strip() or None


def code_changes() -> list[str] | None:
    """Tracked files outside `results/` that differ from HEAD (at most 20),
    [] for a clean code tree, None outside git. `results/` is left out: an
    experiment writes its own outputs before its manifest, so counting them
    would mark every run dirty."""
    try:
        out = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            check=True,
            cwd=CHECKOUT,
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    return _changed_code_paths(out)


def _changed_code_paths(porcelain: str) -> list[str]:
    """Paths of `git status --porcelain` lines, without `results/` (a rename
    counts by its new path)."""
    paths = []
    for line in porcelain.splitlines():
        if len(line) < 4:
            continue
        path = line[3:].split(" -> ")[-1].strip('"')
        if not path.startswith("results/"):
            paths.append(path)
    return paths[:20]


def git_commit() -> str | None:
    """The commit (HEAD) of the git checkout holding bandopt; None outside git."""
    return _git("rev-parse", "HEAD")


def data_versions() -> dict:
    """Content hashes of the package data files (lamps, surfaces, atmospheres, Moon)."""
    root = Path(__file__).parent / "datasets" / "data"
    out = {}
    for sub in sorted(p for p in root.iterdir() if p.is_dir()):
        h = hashlib.sha256()
        for f in sorted(sub.rglob("*")):
            if f.is_file():
                h.update(f.relative_to(root).as_posix().encode())
                h.update(f.read_bytes())
        out[sub.name] = h.hexdigest()[:16]
    return out


def source_hash() -> str:
    """Content hash of bandopt's code: every file of the package except the
    data files that `data_versions` hashes and compiled bytecode, so any
    edit of the code changes it, with or without git."""
    root = Path(__file__).parent
    data = root / "datasets" / "data"
    h = hashlib.sha256()
    for f in sorted(root.rglob("*")):
        if (
            f.is_file()
            and f.suffix not in (".pyc", ".pyo")
            and data not in f.parents
            and "__pycache__" not in f.parts
        ):
            h.update(f.relative_to(root).as_posix().encode() + b"\0")
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


def lamp_library_info() -> dict:
    """Which lamp sets the library was built from (spectra per set; the LSPDD
    is switchable) and whether the spectra carry the near-infrared extension."""
    # start-up time: bandopt.results and the report import this module
    # without JAX
    from .datasets.lamps import library

    lib = library()  # every experiment uses the default: extension on
    extended = [r for r in lib.records if r.extended]
    sets: dict[str, int] = {}
    for r in lib.records:
        sets[r.source_set] = sets.get(r.source_set, 0) + 1
    return {
        "nir_extension": "on: spectra measured only to 780 nm are extended to 900 nm "
        "by bandopt.datasets.nir (switch: library(extend_nir=False))",
        "source_sets": sets,
        "lspdd": "lspdd" in lib.source_sets,
        "spectra": len(lib.records),
        "nir_measured_spectra": sum(r.nir_measured for r in lib.records),
        "extended_spectra": len(extended),
        "extended_unvalidated": sorted(
            r.id for r in extended if not r.extension_validated
        ),
        "extended": sorted(r.id for r in extended),
    }


LAMP_MODELS_NOT_USED = (
    "not used: every lamp spectrum that trained or scored is a measured one "
    "(spectra measured only to 780 nm carry the modelled NIR extension, see "
    "lamp_library); no spectrum of the physical lamp models (bandopt.lampmodels)"
)
"""What a manifest says of the lamp models unless its experiment says otherwise."""


def manifest(
    *,
    seed: int | None = None,
    config: dict | None = None,
    lamp_models: str = LAMP_MODELS_NOT_USED,
    **extra,
) -> dict:
    """A provenance record: git commit (and whether the code tree was dirty),
    package versions, seed, data versions, lamp library, whether modelled lamp
    spectra trained anything (`lamp_models`: an experiment that uses them
    says where and how; they never score), command line, machine, time."""
    versions = {}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    dirty = code_changes()
    return {
        "git_commit": git_commit(),
        "git_dirty": None if dirty is None else bool(dirty),
        "git_dirty_paths": dirty,
        "packages": versions,
        "python": sys.version.split()[0],
        "seed": seed,
        "data_versions": data_versions(),
        "lamp_library": lamp_library_info(),
        "lamp_models": lamp_models,
        "command_line": sys.argv,
        "machine": {"platform": platform.platform(), "processor": platform.machine()},
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "config": config or {},
        **extra,
    }


class DirtyTreeError(RuntimeError):
    """A result in the repository's `results/` would come from uncommitted code."""


def check_clean_tree(directory: str | Path) -> None:
    """Refuse (`DirtyTreeError`) a result folder `directory` inside the
    repository's `results/` while tracked code outside `results/` differs from
    HEAD (`code_changes`): a committed result must name the commit that made
    it. `BANDOPT_ALLOW_DIRTY=1` (or an experiment's `--allow-dirty`) lets it
    through; the manifest still records `git_dirty` and the paths. Folders
    elsewhere (a temporary folder, `tutorial-output/`) and runs outside git
    are always allowed."""
    top = _git("rev-parse", "--show-toplevel")
    if top is None or os.environ.get(ALLOW_DIRTY_ENV) == "1":
        return
    results = Path(top).resolve() / "results"
    if not Path(directory).resolve().is_relative_to(results):
        return
    dirty = code_changes()
    if dirty:
        raise DirtyTreeError(
            f"{directory}: refusing to write a result into {results} from a tree "
            f"with uncommitted code ({', '.join(dirty)}); commit or stash those "
            f"changes and re-run, or set {ALLOW_DIRTY_ENV}=1 (an experiment's "
            "--allow-dirty) to write it anyway, marked git_dirty in its manifest."
        )


def add_allow_dirty(parser) -> None:
    """The `--allow-dirty` option of an experiment's command line."""
    parser.add_argument(
        "--allow-dirty",
        action="store_true",
        help="write into results/ even from uncommitted code (the manifest "
        f"records git_dirty; same as {ALLOW_DIRTY_ENV}=1)",
    )


def refuse_dirty_at_start(parser, args, out: str | Path) -> None:
    """`check_clean_tree(out)` when an experiment starts, so a run that would
    be refused its manifest stops before computing (`parser.error`, exit 2)
    rather than after; `args.allow_dirty` (`add_allow_dirty`) sets
    `BANDOPT_ALLOW_DIRTY=1` for the rest of the run."""
    if getattr(args, "allow_dirty", False):
        os.environ[ALLOW_DIRTY_ENV] = "1"
    try:
        check_clean_tree(out)
    except DirtyTreeError as err:
        parser.error(str(err))


def write_manifest(directory: str | Path, **kwargs) -> Path:
    """Write `manifest.json` into `directory` (created if needed); return its
    path. A folder inside the repository's `results/` needs a clean code tree
    (`check_clean_tree`)."""
    directory = Path(directory)
    check_clean_tree(directory)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "manifest.json"
    path.write_text(strict_dumps(manifest(**kwargs), indent=2) + "\n")
    return path
