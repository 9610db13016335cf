"""README sections generated from the result files agree with those files
(the report's drift check passes on them) and follow the files when they
change."""

import copy
import json
import shutil
from pathlib import Path

from bandopt.report import (
    classification_text,
    consistency_messages,
    noise_aware_text,
    write_readme_section,
)


RESULTS = Path(__file__).resolve().parents[1] / "results"


def _copy(tmp_path, *rels):
    for rel in rels:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(RESULTS / rel, tmp_path / rel)


def test_generated_sections_pass_the_drift_check(tmp_path):
    _copy(tmp_path, "README.md", "classify/summary.json", "spatial/summary.json",
          "spatial/overlap.json", "recommendation.json")
    write_readme_section("classification", tmp_path)
    write_readme_section("spatial", tmp_path)
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
    assert "0.12 / " in classification_text(changed)
    assert "0.12 / " not in classification_text(summary)


def test_noise_aware_text_follows_the_file(tmp_path):
    data = {
        "note": "3 free bands + fixed pan",
        "rows": [
            {"level": "noise-free", "cv_loss": 0.5, "bands": [[500.0, 100.0]]},
            {"level": "C0", "cv_loss": 0.2, "bands": [[440.0, 100.0]]},
            {"level": "P6", "cv_loss": 0.6, "bands": [[452.0, 130.0]]},
        ],
    }
    text = noise_aware_text(data)
    # C0 and P6 are 50 and 2 lx (bandopt.scene.LIGHTING_CLASSES)
    assert "C0 (50 lx) 440/100; P6 (2 lx) 452/130; noise-free 500/100" in text
    assert "at most 12 nm in centre and 30 nm in width" in text
    assert "0.20 -> 0.60" in text
    (tmp_path / "noise_aware").mkdir()
    (tmp_path / "noise_aware" / "noise_aware.json").write_text(json.dumps(data))
    (tmp_path / "README.md").write_text("# Results\n\n## Noise-aware bands\n\nold\n")
    write_readme_section("noise-aware", tmp_path)
    out = (tmp_path / "README.md").read_text()
    assert "old" not in out and out.count("<!-- noise-aware:start -->") == 1
    page = (tmp_path / "sections" / "noise-aware.md").read_text()
    assert "C0 (50 lx) 440/100" in page
