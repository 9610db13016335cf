"""Every part of results/recommendation.json is written through the one shared
function, by the make target that claims it.

Static check (no experiment runs): a Makefile target whose `##` help says
`writes recommendation.json "KEY"` must run a module (`-m module`) from which
a call `update_recommendation("KEY", ...)` is reachable by following imports
inside the repository (and `bandopt.cli.main(["COMMAND", ...])` to the command's
module); every such call in the code is claimed by a target; and nothing but
`bandopt/results.py` writes the file itself.
"""

import ast
import functools
import re
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
PARTS = {"spectral", "classification", "radiometry", "spatial", "estimation"}


def _targets() -> dict[str, tuple[str, list[str]]]:
    """target -> (help line, recipe lines) of the Makefile."""
    out, cur = {}, None
    for line in (ROOT / "Makefile").read_text().splitlines():
        m = re.match(r"^([A-Za-z][\w-]*):", line)
        if m:
            cur = m.group(1)
            out[cur] = (line, [])
        elif line.startswith("\t") and cur is not None:
            out[cur][1].append(line.strip())
        elif line.strip() and not line.startswith("\t"):
            cur = None
    return out


def _claims() -> dict[str, str]:
    """part -> target claiming to write it."""
    claims = {}
    for target, (head, _) in _targets().items():
        for key in re.findall(r'writes recommendation\.json "(\w+)"', head):
            assert key not in claims, f"{key} claimed by {claims[key]} and {target}"
            claims[key] = target
    return claims


def _module_file(name: str) -> Path | None:
    base = ROOT / Path(*name.split("."))
    for cand in (base.with_suffix(".py"), base / "__init__.py"):
        if cand.is_file():
            return cand
    return None


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


@functools.cache
def _edges(path: Path) -> frozenset[Path]:
    """Repository modules imported by `path` (anywhere in it), plus CLI
    commands it dispatches to with `main(["command", ...])`."""
    tree = ast.parse(path.read_text())
    pkg = _module_name(path)
    if path.name != "__init__.py":
        pkg = pkg.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = pkg.split(".")
                up = up[: len(up) - node.level + 1]
                base = ".".join([*up, base] if base else up)
            names = [base] + [f"{base}.{a.name}" for a in node.names]
        elif (
            isinstance(node, ast.Call)
            and getattr(node.func, "id", getattr(node.func, "attr", None)) == "main"
            and node.args
            and isinstance(node.args[0], ast.List)
            and node.args[0].elts
            and isinstance(node.args[0].elts[0], ast.Constant)
        ):
            names = [f"bandopt.cli._cmd_{node.args[0].elts[0].value}"]
        for n in names:
            f = _module_file(n)
            if f is not None and f != path:
                out.add(f)
    return frozenset(out)


@functools.cache
def _writes(path: Path) -> frozenset[str]:
    """Keys of the `update_recommendation("KEY", ...)` calls in `path`."""
    keys = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if (
            isinstance(node, ast.Call)
            and getattr(node.func, "id", getattr(node.func, "attr", None))
            == "update_recommendation"
            and node.args
            and isinstance(node.args[0], ast.Constant)
        ):
            keys.add(node.args[0].value)
    return frozenset(keys)


def _reachable_writes(module: str) -> set[str]:
    start = _module_file(module)
    assert start is not None, f"make runs -m {module}, which is not in the repo"
    seen, todo, keys = set(), [start], set()
    while todo:
        f = todo.pop()
        if f in seen:
            continue
        seen.add(f)
        keys |= _writes(f)
        todo += list(_edges(f) - seen)
    return keys


def test_every_part_is_claimed_by_one_make_target():
    # the four parts the report reads; later experiments may claim more
    assert set(_claims()) >= PARTS


def test_each_claiming_target_reaches_the_shared_writer_for_its_part():
    targets = _targets()
    for key, target in _claims().items():
        modules = [
            m for line in targets[target][1] for m in re.findall(r"-m ([\w.]+)", line)
        ]
        assert modules, f"make {target} runs no python module"
        written = set().union(*(_reachable_writes(m) for m in modules))
        assert key in written, (
            f"make {target} claims to write recommendation.json {key!r}, but no "
            f'update_recommendation("{key}", ...) is reachable from {modules}'
        )


def test_every_shared_writer_call_is_claimed():
    claimed = set(_claims())
    for folder in ("bandopt", "experiments"):
        for f in (ROOT / folder).rglob("*.py"):
            for key in _writes(f):
                assert key in claimed, (
                    f"{f.relative_to(ROOT)} writes recommendation.json {key!r}, "
                    "which no make target claims"
                )


def test_nothing_else_writes_recommendation_json():
    bad = []
    for folder in ("bandopt", "experiments"):
        for f in (ROOT / folder).rglob("*.py"):
            if f == ROOT / "bandopt" / "results.py":
                continue
            for i, line in enumerate(f.read_text().splitlines(), 1):
                if "recommendation" in line and re.search(
                    r"write_text|json\.dump\(|open\([^)]*['\"]w", line
                ):
                    bad.append(f"{f.relative_to(ROOT)}:{i}: {line.strip()}")
    assert not bad, "write recommendation.json through update_recommendation:\n" + (
        "\n".join(bad)
    )


def test_the_check_can_fail(tmp_path):
    """A module that imports the writer but never calls it for the key is not
    counted, and the CLI dispatch is followed."""
    (tmp_path / "m.py").write_text(
        "from bandopt.results import update_recommendation\n"
        "update_recommendation('other', 1)\n"
    )
    assert _writes(tmp_path / "m.py") == {"other"}
    assert "radiometry" in _reachable_writes("experiments.radiometry")
    assert "spatial" not in _reachable_writes("experiments.radiometry")
