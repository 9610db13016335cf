import json

import pytest

from bandopt.results import update_recommendation


def test_update_recommendation_merges_keys(tmp_path):
    update_recommendation("spectral", {"bands": [1]}, results_dir=tmp_path)
    update_recommendation("radiometry", {"bits": 12}, results_dir=tmp_path)
    update_recommendation("spectral", {"bands": [2]}, results_dir=tmp_path)
    data = json.loads((tmp_path / "recommendation.json").read_text())
    assert data == {"spectral": {"bands": [2]}, "radiometry": {"bits": 12}}


def test_update_recommendation_rejects_non_object(tmp_path):
    (tmp_path / "recommendation.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match=r"recommendation\.json"):
        update_recommendation("x", 1, results_dir=tmp_path)
