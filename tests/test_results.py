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


def test_update_readme_section_writes_a_page_and_its_index_entry(tmp_path):
    """A section is a page under `sections/` and one linked line in the index,
    replacing a marked entry or a hand-written section; `readme_text` puts the
    pages back in index order."""
    from bandopt.results import readme_section, readme_text

    (tmp_path / "README.md").write_text(
        "# Results\n\n## Radiometry (x)\n\nold numbers 5e-8\n\n## Spatial\n\nkeep\n"
    )
    page = update_readme_section("radiometry", "## Radiometry (x)\n\nnew 2.5e-09",
                                 heading="## Radiometry", results_dir=tmp_path)
    assert page == tmp_path / "sections" / "radiometry.md"
    text = (tmp_path / "README.md").read_text()
    assert "old numbers" not in text and "new 2.5e-09" not in text
    assert "- [Radiometry (x)](sections/radiometry.md)" in text
    assert "## Spatial\n\nkeep" in text
    assert text.index("<!-- radiometry:start -->") < text.index("## Spatial")
    assert readme_section("radiometry", tmp_path) == "## Radiometry (x)\n\nnew 2.5e-09"
    whole = readme_text(tmp_path)
    assert whole.index("new 2.5e-09") < whole.index("## Spatial")
    update_readme_section("radiometry", "third", results_dir=tmp_path)
    text = (tmp_path / "README.md").read_text()
    assert text.count("radiometry:start") == 1 and "(sections/radiometry.md)" in text
    assert readme_section("radiometry", tmp_path) == "third"
    update_readme_section("other", "## Other\n\nappended", results_dir=tmp_path)
    assert (tmp_path / "README.md").read_text().rstrip().endswith(
        "- [Other](sections/other.md)\n<!-- other:end -->")
    with pytest.raises(FileNotFoundError, match="no page of experiment 'none'"):
        readme_section("none", tmp_path)


def test_committed_index_links_every_page():
    """Every page under results/sections/ has its entry in the index, and every
    entry's page exists."""
    import re

    from bandopt.results import README, RESULTS_DIR, SECTIONS

    index = (RESULTS_DIR / README).read_text()
    linked = set(re.findall(r"\]\(sections/([\w-]+)\.md\)", index))
    pages = {p.stem for p in (RESULTS_DIR / SECTIONS).glob("*.md")}
    assert linked == pages and len(pages) > 10
    for name in pages:
        assert index.count(f"<!-- {name}:start -->") == 1


def test_a_recommendation_file_is_a_band_set_source(tmp_path):
    """`resolve_band_set` (every command's band loader) reads a recommendation
    file's "spectral" band set, equal to the band-set file it was written
    from; a recommendation without one is an error naming the file and key;
    `bands_record` keeps each band's name, centre and FWHM."""
    import numpy as np

    from bandopt.results import bands_record
    from bandopt.sensor import BandSet
    from bandopt.sensor.reference import resolve_band_set

    bands = BandSet.from_physical(
        [450.0, 640.0], [60.0, 480.0], 6.0, names=["B1", "PAN"], name="x"
    )
    update_recommendation(
        "spectral", {"set": "x", "band_set": bands.to_dict()}, results_dir=tmp_path
    )
    found = resolve_band_set(tmp_path / "recommendation.json")
    assert found.key == "spectral" and resolve_band_set("nightsat").key is None
    got = found.bands
    np.testing.assert_allclose(got.centre_nm, bands.centre_nm)
    np.testing.assert_allclose(got.fwhm_nm, bands.fwhm_nm)
    rec = bands_record(got)
    assert [b["name"] for b in rec] == ["B1", "PAN"]
    assert rec[0]["centre_nm"] == pytest.approx(450.0)
    assert rec[1]["fwhm_nm"] == pytest.approx(480.0)
    update_recommendation("spectral", {"set": "x"}, results_dir=tmp_path)
    with pytest.raises(ValueError, match=r"recommendation\.json: key 'spectral'"):
        resolve_band_set(tmp_path / "recommendation.json")
    ref = bands_record(resolve_band_set("nightsat").bands)
    assert ref and all(set(b) == {"name"} for b in ref)  # tabulated: names only
