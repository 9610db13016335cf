import json

import pytest

from bandopt.results import update_readme_section, update_recommendation


def test_update_recommendation_merges_keys(tmp_path):
    update_recommendation("spectral", {"bands": [1]}, results_dir=tmp_path)
    update_recommendation("radiometry", {"bits": 12}, results_dir=tmp_path)
    update_recommendation("spectral", {"bands": [2]}, results_dir=tmp_path)
    data = json.loads((tmp_path / "recommendation.json").read_text())
    made = {k: v.pop("made_by") for k, v in data.items()}  # issue 15: provenance
    assert data == {"spectral": {"bands": [2]}, "radiometry": {"bits": 12}}
    assert set(made["radiometry"]) >= {"mode", "settings", "command_line"}


def test_every_part_records_mode_and_settings(tmp_path):
    update_recommendation(
        "radiometry", {"bits": 12, "mode": "quick"}, results_dir=tmp_path
    )
    update_recommendation(
        "spatial", {"gsd": 5}, results_dir=tmp_path, mode="full", settings={"a": 1}
    )
    data = json.loads((tmp_path / "recommendation.json").read_text())
    assert data["radiometry"]["made_by"]["mode"] == "quick"
    assert data["spatial"]["made_by"]["mode"] == "full"
    assert data["spatial"]["made_by"]["settings"] == {"a": 1}


def test_update_recommendation_rejects_non_object(tmp_path):
    (tmp_path / "recommendation.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match=r"recommendation\.json"):
        update_recommendation("x", 1, results_dir=tmp_path)


def test_update_readme_section_replaces_marked_or_headed_text(tmp_path):
    (tmp_path / "README.md").write_text(
        "# Results\n\n## Radiometry (x)\n\nold numbers 5e-8\n\n## Spatial\n\nkeep\n"
    )
    update_readme_section("radiometry", "## Radiometry (x)\n\nnew 2.5e-09",
                          heading="## Radiometry", results_dir=tmp_path)
    text = (tmp_path / "README.md").read_text()
    assert "old numbers" not in text and "new 2.5e-09" in text
    assert "## Spatial\n\nkeep" in text
    assert text.index("<!-- radiometry:start -->") < text.index("## Spatial")
    update_readme_section("radiometry", "third", results_dir=tmp_path)
    text = (tmp_path / "README.md").read_text()
    assert "new 2.5e-09" not in text and text.count("radiometry:start") == 1
    update_readme_section("other", "appended", results_dir=tmp_path)
    assert (tmp_path / "README.md").read_text().rstrip().endswith(
        "appended\n<!-- other:end -->")
