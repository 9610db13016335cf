"""Import structure: the import graph reads from the file tops (issue 16).

- Outside `bandopt/cli`, an import inside a function says why on the line
  above it or on its own line (an optional dependency, an import cycle,
  start-up time); a run of consecutive imports shares the comment above its
  first line. In `bandopt/cli` function-local imports are the rule (start-up
  time), stated once in the `bandopt.cli` docstring.
- No module imports a private module or name (`_x`) of another top-level part
  of bandopt: `bandopt.classify` may not import `bandopt.search._problem` or
  `bandopt.provenance._git`. Modules `bandopt._x` are private to the package
  as a whole, so every part of it may import them.
- Layers: a lower module never imports a higher one, not even late inside a
  function (checked in a fresh interpreter, so nothing is imported already).
"""

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest


PACKAGE = Path(__file__).resolve().parents[1] / "bandopt"
MODULES = sorted(PACKAGE.rglob("*.py"))
CLI = PACKAGE / "cli"


def _module_name(path: Path) -> tuple[str, ...]:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return parts[:-1] if parts[-1] == "__init__" else parts


def _function_bodies(tree: ast.AST):
    """Every statement list inside a function (bodies, branches, handlers)."""
    for fn in ast.walk(tree):
        if not isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        for node in ast.walk(fn):
            for field in ("body", "orelse", "finalbody"):
                block = getattr(node, field, None)
                if isinstance(block, list) and block and isinstance(block[0], ast.stmt):
                    yield block


def unexplained_local_imports(source: str) -> list[int]:
    """Line numbers of function-local imports with no comment on their line,
    on the first line of their run of consecutive imports or above that run."""
    lines = source.splitlines()

    def commented(lineno: int) -> bool:  # `#` on an import line is a comment
        return "#" in lines[lineno - 1]

    bad = []
    for block in _function_bodies(ast.parse(source)):
        head = None  # first import of the current run
        for prev, stmt in zip([None, *block], block, strict=False):
            if not isinstance(stmt, ast.Import | ast.ImportFrom):
                head = None
                continue
            if head is None or prev.end_lineno + 1 != stmt.lineno:
                head = stmt  # a new run starts
            above = head.lineno >= 2 and lines[head.lineno - 2].lstrip().startswith("#")
            if not (commented(stmt.lineno) or commented(head.lineno) or above):
                bad.append(stmt.lineno)
    return sorted(set(bad))


def imports(source: str, module: tuple[str, ...], is_package: bool):
    """`(line, imported module, imported names)` of every import statement in
    `source` (at any depth), relative imports resolved against `module`."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            out += [(node.lineno, tuple(a.name.split(".")), ()) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module if is_package else module[:-1]
                base = base[: len(base) - (node.level - 1)]
                target = base + (tuple(node.module.split(".")) if node.module else ())
            else:
                target = tuple(node.module.split("."))
            out.append((node.lineno, target, tuple(a.name for a in node.names)))
    return out


def private_imports_across_parts(
    source: str, module: tuple[str, ...], is_package: bool
):
    """`(line, imported module, private parts)` for every import of a private
    module or name from another top-level part of bandopt than `module`'s."""
    part = module[1] if len(module) > 1 else None  # None: bandopt/__init__.py
    bad = []
    for line, target, names in imports(source, module, is_package):
        if target[0] != "bandopt" or len(target) < 2 or target[1] == part:
            continue
        private = [p for p in target[2:] if p.startswith("_")] + [
            n for n in names if n.startswith("_") and not n.startswith("__")
        ]
        if private:
            bad.append((line, ".".join(target), private))
    return bad


def imports_of(
    source: str, module: tuple[str, ...], is_package: bool, other: str
) -> list[int]:
    """Lines of `source` that import module `other` or a part of it, at any
    depth (`from .. import classify` counts as importing `bandopt.classify`)."""
    want = tuple(other.split("."))
    hits = []
    for line, target, names in imports(source, module, is_package):
        mods = [target] + [(*target, n) for n in names]
        if any(m[: len(want)] == want for m in mods):
            hits.append(line)
    return sorted(set(hits))


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("def f():\n    import colour\n", [2]),
        ("def f():\n    # optional dependency\n    import colour\n", []),
        ("def f():\n    import colour  # start-up time\n", []),
        ("def f():\n    import a  # cycle\n    import b\n", []),
        ("def f():\n    # cycle\n    import a\n    from b import c\n", []),
        ("def f():\n    # cycle\n    import a\n    x = 1\n    import b\n", [5]),
        ("def f():\n    try:\n        import a\n    except ImportError:\n"
         "        pass\n", [3]),
        ("import colour\n\n\ndef f():\n    return colour\n", []),
    ],
)
def test_the_local_import_check_can_fail(source, expected):
    assert unexplained_local_imports(source) == expected


@pytest.mark.parametrize(
    ("source", "module", "expected"),
    [
        ("from ..search._problem import Space\n", ("bandopt", "classify", "_x"),
         [(1, "bandopt.search._problem", ["_problem"])]),
        ("from .provenance import _git\n", ("bandopt", "results"),
         [(1, "bandopt.provenance", ["_git"])]),
        ("from bandopt.search import _task\n", ("bandopt", "classify", "_x"),
         [(1, "bandopt.search", ["_task"])]),
        ("import bandopt.search._task\n", ("bandopt", "classify", "_x"),
         [(1, "bandopt.search._task", ["_task"])]),
        ("from ._problem import _scale\n", ("bandopt", "search", "_x"), []),
        ("from . import _photometry_tables\n", ("bandopt", "photometry"), []),
        ("from ..search import Space\n", ("bandopt", "classify", "_x"), []),
    ],
)
def test_the_private_import_check_can_fail(source, module, expected):
    assert private_imports_across_parts(source, module, False) == expected


def test_function_local_imports_say_why():
    bad = []
    for path in MODULES:
        if path.is_relative_to(CLI):
            continue  # the rule is stated once in the bandopt.cli docstring
        rel = path.relative_to(PACKAGE.parent)
        bad += [f"{rel}:{n}" for n in unexplained_local_imports(path.read_text())]
    assert not bad, (
        "function-local imports without a reason (move them to the file top, or "
        "say why on the line above: optional dependency / cycle / start-up "
        "time): " + ", ".join(bad)
    )


def test_cli_states_its_local_import_rule_once():
    import bandopt.cli

    assert "function-local imports are the rule" in bandopt.cli.__doc__


def test_no_private_imports_across_parts():
    bad = []
    for path in MODULES:
        found = private_imports_across_parts(
            path.read_text(), _module_name(path), path.name == "__init__.py"
        )
        rel = path.relative_to(PACKAGE.parent)
        bad += [f"{rel}:{line} {target} {names}" for line, target, names in found]
    assert not bad, "private imports from another part of bandopt: " + "; ".join(bad)


LAYERS = [
    # (lower, higher): `lower` never imports `higher`, not even late
    ("bandopt.search", "bandopt.classify"),  # classify builds on search
    # the KNN evaluation dispatches to the inversion; both share _scores
    ("bandopt.classify._inversion", "bandopt.classify._evaluate"),
    ("bandopt.classify._scores", "bandopt.classify._evaluate"),
    ("bandopt.classify._scores", "bandopt.classify._inversion"),
    ("bandopt.scene", "bandopt.spatial"),  # spatial renders scenes
    # lamps extends its spectra with nir, nir calibrates on the measured spectra
    # of _lamp_sources: _lamp_sources <- nir <- lamps; _lamp_sources builds on
    # its readers and screens, which import none of the three
    ("bandopt.datasets.nir", "bandopt.datasets.lamps"),
    ("bandopt.datasets._lamp_sources", "bandopt.datasets.nir"),
    ("bandopt.datasets._lamp_sources", "bandopt.datasets.lamps"),
    ("bandopt.datasets._lamp_readers", "bandopt.datasets._lamp_sources"),
    ("bandopt.datasets._lamp_readers", "bandopt.datasets.nir"),
    ("bandopt.datasets._lamp_readers", "bandopt.datasets.lamps"),
    ("bandopt.datasets._lamp_screens", "bandopt.datasets._lamp_sources"),
    ("bandopt.datasets._lamp_screens", "bandopt.datasets.nir"),
    ("bandopt.datasets._lamp_screens", "bandopt.datasets.lamps"),
    # the library's report describes lamps and nir, neither imports it
    ("bandopt.datasets.lamps", "bandopt.datasets.lamp_report"),
    ("bandopt.datasets.nir", "bandopt.datasets.lamp_report"),
    # the inversion is an estimator the search, classification and evaluation use
    ("bandopt.inversion", "bandopt.search"),
    ("bandopt.inversion", "bandopt.classify"),
    ("bandopt.inversion", "bandopt.estimators"),
    ("bandopt.classify", "bandopt.estimators"),
    ("bandopt.search", "bandopt.estimators"),
]

INVERSION_FLOORS = (
    "_conditions",
    "_surfaces",
    "_lamps",
    "_variants",
    "_prior",
    "_scoring",
    "_prune",
    "_metrics",
    "_result",
    "_model",
    "_calibrate",
    "_fit",
    "_estimators",
    "_context",
    "_records",
    "_crossval",
    "_leave_class_out",
    "_summary",
)
"""The modules of `bandopt.inversion`, lowest first: each imports only modules
before it (its `__init__` re-exports them all)."""


def _files_of(module: str) -> list[Path]:
    path = PACKAGE.parent.joinpath(*module.split("."))
    return sorted(path.rglob("*.py")) if path.is_dir() else [path.with_suffix(".py")]


@pytest.mark.parametrize(
    ("source", "module", "expected"),
    [
        ("from ..classify import features\n", ("bandopt", "search", "_x"), [1]),
        ("def f():\n    from .. import classify\n", ("bandopt", "search", "_x"), [2]),
        ("import bandopt.classify._knn\n", ("bandopt", "search", "_x"), [1]),
        ("from ..classification import x\n", ("bandopt", "search", "_x"), []),
        ("from .. import knn\n", ("bandopt", "search", "_x"), []),
    ],
)
def test_the_layer_check_can_fail(source, module, expected):
    assert imports_of(source, module, False, "bandopt.classify") == expected


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("from . import nir\n", [1]),
        ("from .nir import technology_of\n", [1]),
        ("def f():\n    from .nir import extend_spectrum\n", [2]),
        ("import bandopt.datasets.nir\n", [1]),
        ("from . import lamps, loaders\n", []),
        ("from .nirx import y\n", []),
    ],
)
def test_the_layer_check_sees_sibling_modules(source, expected):
    module = ("bandopt", "datasets", "_lamp_sources")
    assert imports_of(source, module, False, "bandopt.datasets.nir") == expected


@pytest.mark.parametrize(("lower", "higher"), LAYERS)
def test_lower_layers_do_not_import_higher_ones(lower, higher):
    """No import statement in `lower`'s files (at any depth) names `higher`,
    and importing `lower` in a fresh interpreter does not load `higher`."""
    files = _files_of(lower)
    assert files and all(f.is_file() for f in files), lower
    bad = []
    for path in files:
        found = imports_of(
            path.read_text(), _module_name(path), path.name == "__init__.py", higher
        )
        bad += [f"{path.relative_to(PACKAGE.parent)}:{n}" for n in found]
    assert not bad, f"{lower} imports {higher}: " + ", ".join(bad)

    # the package holding `lower` is imported first: its __init__ may import
    # every part (bandopt.classify does), and only what importing `lower`
    # itself adds counts
    parent = lower.rsplit(".", 1)[0]
    prefix = higher + "."
    code = (
        f"import sys, {parent}\n"
        "before = set(sys.modules)\n"
        f"import {lower}\n"
        f"print(sorted(m for m in set(sys.modules) - before "
        f"if (m + '.').startswith({prefix!r})))"
    )
    path = [str(PACKAGE.parent), *filter(None, [os.environ.get("PYTHONPATH")])]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(path)}
    p = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True
    )
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "[]", f"importing {lower} loads {p.stdout.strip()}"


def upward_imports(
    source: str, module: tuple[str, ...], floors: tuple[str, ...]
) -> list[tuple[int, str]]:
    """`(line, sibling)` for every import in `source` (at any depth) of a
    module of `module`'s package that is not below it in `floors`."""
    package, own = module[:-1], module[-1]
    below = set(floors[: floors.index(own)])
    bad = []
    for line, target, names in imports(source, module, False):
        if target[: len(package)] != package:
            continue
        rest = target[len(package) :]
        siblings = [rest[0]] if rest else [n for n in names if n in floors]
        bad += [(line, s) for s in siblings if s not in below]
    return bad


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("from ._fit import fit_inversion\n", [(1, "_fit")]),
        ("def f():\n    from ._crossval import cross_validate\n", [(2, "_crossval")]),
        ("from . import _model, _lamps\n", [(1, "_model")]),
        ("import bandopt.inversion._summary\n", [(1, "_summary")]),
        ("from ._lamps import LampSet\nfrom ..estimate import METRICS\n", []),
    ],
)
def test_the_floor_check_can_fail(source, expected):
    module = ("bandopt", "inversion", "_metrics")
    assert upward_imports(source, module, INVERSION_FLOORS) == expected


def test_inversion_modules_import_only_lower_floors():
    folder = PACKAGE / "inversion"
    found = sorted(p.stem for p in folder.glob("*.py") if p.name != "__init__.py")
    assert found == sorted(INVERSION_FLOORS), "place every module in INVERSION_FLOORS"
    bad = []
    for name in INVERSION_FLOORS:
        path = folder / f"{name}.py"
        found = upward_imports(path.read_text(), _module_name(path), INVERSION_FLOORS)
        bad += [f"{path.relative_to(PACKAGE.parent)}:{n} imports {s}" for n, s in found]
    assert not bad, "an inversion module imports one above it: " + ", ".join(bad)


EXPERIMENTS = sorted((PACKAGE.parent / "experiments").glob("*.py"))


def test_experiments_use_only_public_names():
    """`experiments/` holds scripts on the library's public face: no private
    module or name of bandopt (`bandopt._config`, `bandopt.search._task`,
    `from bandopt.x import _y`), none of another experiment's private names."""
    bad = []
    for path in EXPERIMENTS:
        module = ("experiments", path.stem)
        for line, target, names in imports(path.read_text(), module, False):
            if target[0] not in ("bandopt", "experiments"):
                continue
            private = [p for p in target[1:] if p.startswith("_")] + [
                n for n in names if n.startswith("_") and not n.startswith("__")
            ]
            if private:
                bad.append(f"{path.name}:{line} {'.'.join(target)} {private}")
    assert not bad, "private imports in experiments/: " + "; ".join(bad)
