"""`bandopt/studies/ablations/bands.py`: evaluate's estimator with pan + 5 bands
and with contiguous band sets. The study's configuration, the band sets it
names, the per-class table, the decision rule fixed before the run and the
README text built from per-lamp records (the run itself is `make
estimate-bands`)."""

import json
from pathlib import Path

import numpy as np
import pytest

from bandopt import inversion as inv_mod
from bandopt.results import readme_section
from bandopt.studies import band_set, manifest_config
from bandopt.studies.ablations import bands as eb
from bandopt.studies.ablations.defaults import DEFAULT


def test_study_scores_evaluates_estimator_on_each_band_set_paired_with_ours():
    assert DEFAULT == inv_mod.DEFAULT_ESTIMATOR
    assert eb.STUDY.estimators == (DEFAULT,)
    assert list(eb.STUDY.band_sets) == [
        "recommended", "contiguous-13", "contiguous-26", "contiguous-52",
    ]  # fmt: skip
    assert all(v == ("unknown",) for v in eb.STUDY.band_sets.values())
    config = manifest_config(eb.STUDY, 4)
    assert config["modelled_lamps_used"] is True  # the Planck spectra, as evaluate's
    assert "Planck" in config["training_lamps"]


@pytest.mark.parametrize("n", eb.COUNTS)
def test_contiguous_band_sets_by_name(n):
    b = band_set(f"contiguous-{n}")
    assert len(b) == n
    np.testing.assert_allclose(b.fwhm_nm, 520.0 / n, rtol=1e-6)


def test_a_bad_contiguous_name_says_what_is_expected():
    with pytest.raises(ValueError, match="'contiguous-x': expected contiguous-N"):
        band_set("contiguous-x")


def _records(band, ler):
    """Two partitions of one band set: an amber LED and an HPS lamp."""
    return [
        {"band_set": band, "estimator": DEFAULT, "surface": "unknown",
         "partition": p, "fold": 0, "lamp": f"{c}{p}", "level2": c, "level1": "x",
         "out_of_range": 0, "LER": ler[c] + p, "G": 0.05 if band != "recommended"
         else 0.3, "CCT": 150.0, "CCT_mired": 10.0, "LER_covered": 1.0,
         "G_covered": 1.0, "CCT_covered": 1.0, "LER_width": 80.0,
         "level1_correct": 0.5 if c == "hps" else 1.0}
        for p in (0, 1)
        for c in ("led_amber", "hps")
    ]  # fmt: skip


def _summary(recs):
    rows = inv_mod.summarise(recs)
    paired = []
    for name in ("contiguous-13", "contiguous-52"):
        paired += inv_mod.paired_differences(rows, "recommended", name)
    defs = {
        "recommended": {"bands": 6, "fwhm_nm": [88.0] * 6},
        "contiguous-13": {"bands": 13, "fwhm_nm": [40.0] * 13},
        "contiguous-52": {"bands": 52, "fwhm_nm": [10.0] * 52},
    }
    extra = {"by_class": eb.by_class(recs), "bands": defs}
    return {"partitions": 2, "rows": rows, "paired": paired, "extra": extra}


def test_text_when_no_band_set_meets_the_goal():
    recs = _records("recommended", {"led_amber": 20.0, "hps": 7.0})
    recs += _records("contiguous-13", {"led_amber": 18.0, "hps": 6.0})
    recs += _records("contiguous-52", {"led_amber": 16.0, "hps": 7.0})
    summary = _summary(recs)
    table = summary["extra"]["by_class"]
    assert table["contiguous-52"]["led_amber"]["LER"] == pytest.approx(16.5)
    assert table["recommended"]["hps"]["level1_correct"] == pytest.approx(0.5)
    text = eb.readme_text(summary)
    assert "| recommended (pan + 5) | " + DEFAULT + " | 14.0 ± 0.7 |" in text
    assert "| contiguous-52 (52 x 10 nm) | -2.0 ± 0.0 | -0.250 ± 0.000 | +0 ± 0 |" in (
        text
    )
    assert "| led_amber (2) | 20.5 (1.00) | 18.5 (1.00) | 16.5 (1.00) |" in text
    assert "| hps (2) | 7.5 (0.50) | 6.5 (0.50) | 7.5 (0.50) |" in text
    assert "No band set meets the goal" in text
    assert "the error stays at 12.0-14.0 lm/W, 0.050-0.300 and 150-150 K" in text


def test_text_when_a_contiguous_set_meets_the_goal_names_the_smallest():
    recs = _records("recommended", {"led_amber": 20.0, "hps": 7.0})
    recs += _records("contiguous-13", {"led_amber": 4.0, "hps": 3.0})
    recs += _records("contiguous-52", {"led_amber": 2.0, "hps": 1.0})
    text = eb.readme_text(_summary(recs))
    assert "The goal is met with contiguous-13" in text
    assert "No band set" not in text


def test_goal_needs_all_three_metrics():
    row = {"LER": 4.0, "G": 0.09, "CCT": 199.0}
    assert eb.meets_goal(row)
    assert not eb.meets_goal({**row, "CCT": 201.0})
    assert not eb.meets_goal({**row, "G": None})


def test_committed_section_is_generated_from_the_committed_summary():
    results = Path(__file__).resolve().parents[1] / "results"
    path = results / "estimate_bands" / "summary.json"
    summary = json.loads(path.read_text())
    section = readme_section("estimate-bands", results)
    assert section.strip() == eb.readme_text(summary).strip()
    assert summary["scored_lamps"] == "measured lamps only"
    assert summary["modelled_lamps_used"] is True
    assert {r["band_set"] for r in summary["rows"]} == set(eb.BAND_SETS)
    for row in summary["rows"]:
        assert row["out_of_range"] == 0 and row["partitions"] == 4


def test_nearest_lamp_gap_names_each_lamp_by_its_nearest_other_lamp():
    grid = np.arange(380.0, 901.0)

    def line(centre):
        return np.exp(-0.5 * ((grid - centre) / 25.0) ** 2) + 1e-3

    from bandopt.estimate import lamp_truth

    spectra = np.stack([line(555.0), 3.0 * line(555.0), line(620.0)])
    (ler_a, ler_b) = lamp_truth(spectra[[0, 2]], grid)[0][:, 0]
    gap = eb.nearest_lamp_gap(spectra, grid, ["a", "a2", "b"])
    # the first two have one shape: each is the other's nearest (no error);
    # the third's nearest is one of them
    assert gap["lamps"] == 3
    by_class = gap["nearest"]["LER_by_class"]
    assert by_class["a"] == pytest.approx(0.0, abs=1e-9)
    assert by_class["a2"] == pytest.approx(0.0, abs=1e-9)
    assert by_class["b"] == pytest.approx(abs(ler_a - ler_b), rel=1e-9)
    assert gap["nearest"]["LER"] == pytest.approx(abs(ler_a - ler_b) / 3, rel=1e-9)
    # "the 3 nearest" of 3 lamps are the other two, never the lamp itself
    three = gap["mean_of_3"]["LER_by_class"]
    assert three["b"] == pytest.approx(abs(ler_a - ler_b), rel=1e-9)
    assert three["a"] == pytest.approx(abs(ler_a - ler_b) / 2, rel=1e-9)


def test_figure_is_written(tmp_path):
    recs = _records("recommended", {"led_amber": 20.0, "hps": 7.0})
    recs += _records("contiguous-52", {"led_amber": 16.0, "hps": 7.0})
    summary = _summary(recs)
    summary["extra"]["nearest_lamp"] = {"nearest": {"LER": 12.0, "G": 0.3, "CCT": 280}}
    eb.figure(summary, tmp_path / "errors.png")
    assert (tmp_path / "errors.png").stat().st_size > 10_000


def test_direct_text_says_which_metrics_meet_the_goal():
    rows = [
        {"band_set": "contiguous-26", "surface": "class", "LER": 2.2, "G": 0.155,
         "CCT": 65.0, "out_of_range": 0},
        {"band_set": "contiguous-26", "surface": "unknown", "LER": 17.0, "G": 0.39,
         "CCT": 479.0, "out_of_range": 0},
    ]  # fmt: skip
    by_class = {"contiguous-26/class": {"led_amber": {"G": 1.1}, "hps": {"G": 0.1}}}
    lines = eb.direct_lines({"rows": rows, "by_class": by_class}, lambda b: b)
    text = "\n".join(lines)
    assert "| contiguous-26 | unknown | 17.0 | 0.390 | 479 | 0 |" in text
    assert text.index("| unknown |") < text.index("| class |")  # less knowledge first
    assert "meets the goal for LER (2.2 lm/W) and CCT (65 K)" in text
    assert "not for G (0.155; most in led_amber, 1.10" in text
    rows[0]["G"] = 0.09
    text = "\n".join(eb.direct_lines({"rows": rows, "by_class": by_class}, str))
    assert "The goal is met by the direct estimate with contiguous-26" in text
