"""`bandopt.studies.estimate` with `--modelled-per-class`: the committed
README section is regenerated exactly from the committed records, and a run
with modelled lamps says how many were used in its records, summary, README
text and manifest."""

import json
from pathlib import Path

import pytest

from bandopt import inversion as inv_mod
from bandopt.results import readme_section
from bandopt.studies import estimate as est


RESULTS = Path(__file__).resolve().parents[1] / "results"


def _committed():
    d = RESULTS / "estimate"
    recs = [json.loads(x) for x in (d / "records.jsonl").read_text().splitlines()]
    unseen = json.loads((d / "unseen_types.json").read_text())
    return recs, unseen


def _paired(summary):
    out = []
    for name in est.DEFAULT_BAND_SETS[1:]:
        out += inv_mod.paired_differences(summary, "recommended", name)
    return out


def test_committed_records_regenerate_the_committed_section():
    """Whatever N the committed run used (make estimate: 5), its records
    regenerate its summary and README section exactly, and the text says
    whether modelled lamps were used."""
    recs, unseen = _committed()
    n_model = est.modelled_per_class_of(recs)
    summary = inv_mod.summarise(recs)
    committed = json.loads((RESULTS / "estimate" / "summary.json").read_text())
    assert json.loads(json.dumps(summary)) == committed
    variants = inv_mod.estimator_differences(summary)
    committed_variants = json.loads(
        (RESULTS / "estimate" / "estimator_paired.json").read_text()
    )
    assert json.loads(json.dumps(variants)) == committed_variants
    text = est.readme_text(summary, _paired(summary), unseen, variants)
    section = readme_section("estimate", RESULTS)
    assert text.strip() == section
    if n_model == 0:
        assert "no modelled lamp spectra" in text and est.MODELS not in text
    else:
        assert f"{n_model} modelled lamps per class" in text and est.MODELS in text
        # the measured-only rows are there too, and say so
        assert "every other row trains on measured lamps only" in text


def _records(n_model):
    rows = []
    for p in (0, 1):
        for estimator, n in (("inversion", 0), (est.MODELS, n_model)):
            for lamp, (c, e) in enumerate([("hps", 1.0), ("mercury", 3.0)]):
                rows.append(
                    {
                        "band_set": "recommended",
                        "estimator": estimator,
                        "surface": "unknown",
                        "partition": p,
                        "lamp": f"l{lamp}",
                        "level2": c,
                        "out_of_range": 0,
                        "LER": e + p,
                        "LER_covered": 1.0,
                        "G_covered": 1.0,
                        "CCT_covered": 1.0,
                        "level1_correct": 0.5,
                        "unexplained": 0.0,
                        "modelled_per_class": n,
                    }
                )
    return rows


def test_a_run_with_modelled_lamps_says_so_everywhere():
    recs = _records(7)
    assert est.modelled_per_class_of(recs) == 7
    summary = inv_mod.summarise(recs)
    by = {r["estimator"]: r for r in summary}
    assert by["inversion"]["modelled_per_class"] == 0
    assert by[est.MODELS]["modelled_per_class"] == 7
    overall = {
        k: 0.5
        for k in (
            "LER_covered",
            "G_covered",
            "CCT_covered",
            "level1_correct",
            "level1_correct_where_family_in_prior",
            "unexplained",
        )
    }
    overall["out_of_range"] = 0
    unseen = {
        "recommended": {"overall": overall, "modelled_per_class": 0},
        "recommended+models": {"overall": overall, "modelled_per_class": 7},
    }
    text = est.readme_text(summary, [], unseen)
    assert "also train on 7 modelled lamps per class" in text
    assert f"`{est.MODELS}` (in the prior), `ridge+models`" in text
    assert "calibrated on each fit's measured training lamps only" in text
    assert "Scoring uses measured lamps only" in text
    assert f"| recommended | {est.MODELS} | unknown |" in text
    assert (
        f"Unseen lamp types (recommended, {est.MODELS}, 7 modelled lamps per class"
        in text
    )
    assert "Unseen lamp types (recommended, inversion, surface unknown" in text
    cfg = est.modelled_lamps_config(7)
    assert cfg["modelled_per_class"] == 7
    assert "7 modelled lamps per class" in cfg["training_lamps"]
    cov = est.interval_coverage(summary, unseen)
    assert f"recommended/unknown/{est.MODELS}" in cov["held_out_lamps"]
    rec = est.recommendation(summary, cov)["class_balanced_mae"]
    assert rec[f"recommended/{est.MODELS}/unknown"]["modelled_per_class"] == 7
    # the default run's recommendation rows have no such key
    plain = inv_mod.summarise([r for r in recs if r["estimator"] == "inversion"])
    for r in plain:
        del r["modelled_per_class"]
    assert all(
        "modelled_per_class" not in v
        for v in est.recommendation(plain, {})["class_balanced_mae"].values()
    )


def test_resume_refuses_records_of_another_modelled_setting(tmp_path):
    (tmp_path / "records.jsonl").write_text(
        "\n".join(json.dumps(r) for r in _records(7)) + "\n"
    )
    with pytest.raises(SystemExit, match="--modelled-per-class 7, not 3"):
        est.run(
            ["--out", str(tmp_path), "--resume", "--modelled-per-class", "3",
             "--band-sets", "recommended"]
        )
    with pytest.raises(SystemExit):
        est.run(["--out", str(tmp_path), "--modelled-per-class", "-1"])
