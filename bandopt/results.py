"""Shared result files: `results/recommendation.json`, merged by every experiment.

Each experiment owns one top-level key (`"spectral"`, `"classification"`,
`"radiometry"`, `"spatial"`) and replaces only that key, so experiments can run
in any order and a re-run overwrites only its own part.
"""

import json
import os
import tempfile
from pathlib import Path


RESULTS_DIR = Path(os.environ.get("BANDOPT_RESULTS", "results"))
RECOMMENDATION = "recommendation.json"


def update_recommendation(
    key: str, value, *, results_dir: str | Path | None = None
) -> Path:
    """Replace `key` in `results/recommendation.json` (created if missing),
    writing atomically so a crash never leaves a half-written file."""
    root = Path(results_dir) if results_dir is not None else RESULTS_DIR
    root.mkdir(parents=True, exist_ok=True)
    path = root / RECOMMENDATION
    data = json.loads(path.read_text()) if path.is_file() else {}
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a JSON object at the top level.")
    data[key] = value
    fd, tmp = tempfile.mkstemp(dir=root, prefix=".recommendation-", suffix=".json")
    with os.fdopen(fd, "w") as fh:
        json.dump(data, fh, indent=2, default=str)
        fh.write("\n")
    os.replace(tmp, path)
    return path


README = "README.md"


def update_readme_section(
    name: str, text: str, *, heading: str | None = None,
    results_dir: str | Path | None = None,
) -> Path:
    """Replace experiment `name`'s section of `results/README.md`: the text
    between `<!-- name:start -->` and `<!-- name:end -->`. Without markers, a
    hand-written section starting with the line `heading` (up to the next level-2
    heading or marker) is replaced; else the section is appended. Sections are
    written from the experiment's own result files, never typed by hand."""
    root = Path(results_dir) if results_dir is not None else RESULTS_DIR
    path = root / README
    old = path.read_text() if path.is_file() else "# Results\n"
    start, end = f"<!-- {name}:start -->", f"<!-- {name}:end -->"
    block = f"{start}\n{text.strip()}\n{end}"
    if start in old and end in old:
        new = old[: old.index(start)] + block + old[old.index(end) + len(end):]
    elif heading is not None and f"\n{heading}" in old:
        i = old.index(f"\n{heading}") + 1
        rest = old[i + len(heading):]
        stops = [j for j in (rest.find("\n## "), rest.find("\n<!--")) if j >= 0]
        j = i + len(heading) + (min(stops) + 1 if stops else len(rest))
        new = old[:i] + block + "\n\n" + old[j:].lstrip("\n")
    else:
        new = old.rstrip("\n") + "\n\n" + block + "\n"
    path.write_text(new)
    return path
