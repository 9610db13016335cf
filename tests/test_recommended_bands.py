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


def _write(path, entry):
    import json

    path.write_text(json.dumps({"spectral": entry}))
    return path


def test_band_set_wins_over_the_bands_summary(tmp_path):
    """An experiment writes both `band_set` (the design, here shape k 8) and a
    `bands` summary (centres and widths for people): the reader takes the
    design, in the experiments and in `bandopt radiometry --bands FILE`."""
    from bandopt.radiometry import load_band_set

    bands = BandSet.from_physical([450.0, 620.0], [40.0, 60.0], shape_k=8.0,
                                  name="ours")  # fmt: skip
    summary = [{"name": n, "centre_nm": c, "fwhm_nm": w, "centre_interval_nm": [0, 1]}
               for n, c, w in zip(bands.names, [450.0, 620.0], [40.0, 60.0],
                                  strict=True)]  # fmt: skip
    rec = _write(tmp_path / "recommendation.json",
                 {"bands": summary, "band_set": bands.to_dict()})  # fmt: skip
    for got in (
        recommended_band_set("spectral", results_dir=tmp_path),
        recommended_band_set("spectral", path=rec),
        load_band_set(str(rec))[0],
    ):
        np.testing.assert_allclose(np.asarray(got.shape_k), [8.0, 8.0])
        np.testing.assert_allclose(np.asarray(got.centre_nm), [450.0, 620.0])


def test_hand_written_bands_list_and_its_errors(tmp_path):
    rec = _write(tmp_path / "r.json", {"name": "mine", "bands": [
        {"name": "a", "centre_nm": 500.0, "fwhm_nm": 40.0, "tolerance": [1, 2]},
        {"name": "b", "edges_nm": [600.0, 650.0]}]})  # fmt: skip
    got = recommended_band_set("spectral", path=rec)
    assert got.name == "mine" and got.names == ("a", "b")
    np.testing.assert_allclose(np.asarray(got.shape_k), [6.0, 6.0])  # the default
    _write(rec, {"bands": ["not a band"]})
    with pytest.raises(ValueError, match=r"r.json: key 'spectral': 'bands' must be"):
        recommended_band_set("spectral", path=rec)
    _write(rec, {"band_set": "ours", "bands": [{"name": "a"}]})  # a label, no set
    with pytest.raises(ValueError, match="'spectral' has no 'band_set' object"):
        recommended_band_set("spectral", path=rec)
    rec.write_text('{"spectral": ')
    with pytest.raises(ValueError, match=r"r.json: not valid JSON"):
        recommended_band_set("spectral", path=rec)


def test_no_second_recommendation_parser():
    """The radiometry package reads recommendation files only through
    `bandopt.results.recommended_band_set`."""
    import bandopt.radiometry as radiometry

    assert not hasattr(radiometry, "spectral_band_set")
