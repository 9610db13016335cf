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
