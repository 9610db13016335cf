"""The one reader of recommended band sets in results/recommendation.json."""

import numpy as np
import pytest

from bandopt.results import recommended_band_set, update_recommendation
from bandopt.sensor import BandSet


def test_round_trip_missing_and_malformed(tmp_path):
    assert recommended_band_set("spectral", results_dir=tmp_path) is None  # no file
    bands = BandSet.from_physical([450.0, 620.0], [40.0, 60.0], name="ours")
    update_recommendation("spectral", {"band_set": bands.to_dict(), "x": 1},
                          results_dir=tmp_path)  # fmt: skip
    got = recommended_band_set("spectral", results_dir=tmp_path)
    assert got.name == "ours" and got.names == bands.names
    np.testing.assert_allclose(np.asarray(got.centre_nm), [450.0, 620.0])
    np.testing.assert_allclose(np.asarray(got.fwhm_nm), [40.0, 60.0])
    assert recommended_band_set("classification", results_dir=tmp_path) is None
    update_recommendation("classification", {"bands": []}, results_dir=tmp_path)
    with pytest.raises(ValueError, match="'classification' has no 'band_set'"):
        recommended_band_set("classification", results_dir=tmp_path)
