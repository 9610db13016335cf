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
"""

import ast
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


def private_imports_across_parts(
    source: str, module: tuple[str, ...], is_package: bool
):
    """`(line, imported module, private parts)` for every import of a private
    module or name from another top-level part of bandopt than `module`'s."""
    part = module[1] if len(module) > 1 else None  # None: bandopt/__init__.py
    bad = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            targets = [(tuple(a.name.split(".")), ()) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module if is_package else module[:-1]
                base = base[: len(base) - (node.level - 1)]
                target = base + (tuple(node.module.split(".")) if node.module else ())
            else:
                target = tuple(node.module.split("."))
            targets = [(target, tuple(a.name for a in node.names))]
        else:
            continue
        for target, names in targets:
            if target[0] != "bandopt" or len(target) < 2 or target[1] == part:
                continue
            private = [p for p in target[2:] if p.startswith("_")] + [
                n for n in names if n.startswith("_") and not n.startswith("__")
            ]
            if private:
                bad.append((node.lineno, ".".join(target), private))
    return bad


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
