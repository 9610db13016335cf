"""README sections generated from the result files agree with those files
(the report's drift check passes on them) and follow the files when they
change."""

import copy
import json
import shutil
from pathlib import Path

from bandopt.report import consistency_messages
from experiments import readme_sections


RESULTS = Path(__file__).resolve().parents[1] / "results"


def _copy(tmp_path, *rels):
    for rel in rels:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(RESULTS / rel, tmp_path / rel)


def test_generated_sections_pass_the_drift_check(tmp_path):
    _copy(tmp_path, "README.md", "classify/summary.json", "spatial/summary.json",
          "spatial/overlap.json", "recommendation.json")
    readme_sections.write("classification", tmp_path)
    readme_sections.write("spatial", tmp_path)
    text = (tmp_path / "README.md").read_text()
    assert text.count("<!-- classification:start -->") == 1
    assert text.count("<!-- spatial:start -->") == 1
    msgs = [m for m in consistency_messages(tmp_path) if "README" in m]
    assert msgs == []


def test_classification_text_follows_the_summary():
    summary = json.loads((RESULTS / "classify" / "summary.json").read_text())
    changed = copy.deepcopy(summary)
    row = next(r for r in changed["band_count"] if r["method"] == "nlopt")
    row["level2_macro_f1"] = 0.123
    assert "0.12 / " in readme_sections.classification_text(changed)
    assert "0.12 / " not in readme_sections.classification_text(summary)
