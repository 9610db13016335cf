"""Strict JSON everywhere: every JSON file bandopt writes goes through
`bandopt.strict_json.strict_dumps` (undefined values as null, never the
non-standard NaN/Infinity tokens), and no committed result file holds them."""

import ast
import json
import math
from pathlib import Path

import numpy as np
import pytest

from bandopt.strict_json import json_safe, strict_dumps


ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"


def _refuse(token: str):
    raise ValueError(f"bare {token}")


def strict_loads(text: str):
    """`json.loads` that fails on NaN, Infinity and -Infinity."""
    return json.loads(text, parse_constant=_refuse)


def test_undefined_values_are_written_as_null():
    row = {
        "gsd_m": np.float64(20.0),
        "f1_pure": float("nan"),
        "bounds": (np.float32("inf"), -math.inf, 1),
        "per_band": np.array([0.5, np.nan]),
        "where": Path("results/spatial"),
    }
    text = strict_dumps(row, indent=None)
    assert strict_loads(text) == {
        "gsd_m": 20.0,
        "f1_pure": None,
        "bounds": [None, None, 1],
        "per_band": [0.5, None],
        "where": "results/spatial",
    }
    assert math.isnan(row["f1_pure"])  # the caller's object is not changed
    assert json_safe([np.int64(3)]) == [3]
    assert "\n" in strict_dumps({"a": 1})
    assert "\n" not in strict_dumps({"a": 1}, indent=None)
    with pytest.raises(ValueError, match="bare NaN"):
        strict_loads(json.dumps({"a": float("nan")}))  # the hook below catches them


def _result_files() -> list[Path]:
    return sorted(
        p for p in RESULTS.rglob("*") if p.suffix in (".json", ".jsonl") and p.is_file()
    )


def test_committed_results_hold_no_bare_nan_or_infinity():
    """Every results/**/*.json and *.jsonl parses as strict JSON; a failure
    names each file and the first offending token."""
    files = _result_files()
    assert len(files) > 50  # the folder is there (a test that scans nothing passes)
    bad = []
    for path in files:
        text = path.read_text()
        docs = text.splitlines() if path.suffix == ".jsonl" else [text]
        for n, doc in enumerate(docs, start=1):
            if not doc.strip():
                continue
            try:
                strict_loads(doc)
            except ValueError as err:
                where = f":{n}" if path.suffix == ".jsonl" else ""
                bad.append(f"{path.relative_to(ROOT)}{where}: {err}")
                break
    assert not bad, "non-standard JSON (write it with strict_dumps):\n" + "\n".join(bad)


WRITERS = {"write", "write_text", "writelines", "writestr", "write_bytes"}


def _json_calls(node: ast.AST) -> list[ast.Call]:
    return [
        c
        for c in ast.walk(node)
        if isinstance(c, ast.Call)
        and isinstance(c.func, ast.Attribute)
        and isinstance(c.func.value, ast.Name)
        and c.func.value.id == "json"
        and c.func.attr in ("dump", "dumps")
    ]


def test_no_json_file_is_written_around_the_strict_writer():
    """`json.dump` (always a file) and `json.dumps` fed into a write call are
    refused in bandopt/ and experiments/: they would write NaN. In-memory
    uses (hash keys, messages, deep copies) stay allowed."""
    found = []
    for folder in ("bandopt", "experiments"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            tree = ast.parse(path.read_text())
            calls = [c for c in _json_calls(tree) if c.func.attr == "dump"]
            for node in ast.walk(tree):
                if (
                    isinstance(node, ast.Call)
                    and isinstance(node.func, ast.Attribute)
                    and node.func.attr in WRITERS
                ):
                    calls += _json_calls(node)
            found += [f"{path.relative_to(ROOT)}:{c.lineno}" for c in calls]
    found = sorted(set(found))
    assert not found, "JSON written without strict_dumps:\n" + "\n".join(found)


def test_the_scan_sees_a_json_write():
    """The scan above is not blind: it flags the pattern it forbids."""
    src = 'p.write_text(json.dumps(x) + "\\n")\njson.dump(x, fh)\nkey = json.dumps(x)\n'
    tree = ast.parse(src)
    writes = [n for n in ast.walk(tree) if isinstance(n, ast.Call)
              and isinstance(n.func, ast.Attribute) and n.func.attr in WRITERS]
    flagged = {c.lineno for w in writes for c in _json_calls(w)}
    flagged |= {c.lineno for c in _json_calls(tree) if c.func.attr == "dump"}
    assert flagged == {1, 2}


def test_spatial_section_reads_an_undefined_f1_as_missing():
    """The README's spatial section skips the null F1 of a GSD with no
    one-type pixels (what the strict writer makes of NaN)."""
    from bandopt.report._readme import spatial_text

    summary = json.loads((RESULTS / "spatial" / "summary.json").read_text())
    overlap = json.loads((RESULTS / "spatial" / "overlap.json").read_text())
    overlap["rows"][-1]["f1_pure"] = None
    rows = overlap["rows"][:-1]
    text = spatial_text(summary, overlap)
    pure = [r["f1_pure"] for r in rows if r["f1_pure"] is not None]
    lo, hi = f"{min(pure):.2f}", f"{max(pure):.2f}"
    assert f"F1 {lo if lo == hi else f'{lo}-{hi}'} (GSD" in text
