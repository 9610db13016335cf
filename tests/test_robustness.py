"""bandopt.robustness on a tiny configuration: records, pairing, summary maths,
resume, and the experiment's outputs."""

import gzip
import json

import numpy as np
import pytest

from bandopt import inversion as inv_mod, robustness as rb
from bandopt.calibration import expected_calibration_error
from bandopt.estimators import InversionConfig, fit_on_context
from bandopt.folds import class_balanced_weights, paired_lamp_ci
from bandopt.sensor.reference import resolve_band_set


LIGHT = InversionConfig(
    mixtures=0,
    peak_shifts_nm=(),
    planck=False,
    calibration="lamps",
    floor_grid=(1e-3,),
    interval_offsets=(0.0,),
)
"""The shipped estimator without its slow extras (blends, shifted LEDs,
Planck spectra, floor and offset grids): the test checks the study's
bookkeeping, not the estimator."""

STUDY = rb.RobustnessStudy(
    band_sets=rb.BAND_SETS[:1],
    perturbations=(
        rb.Perturbation("clean"),
        rb.Perturbation("mixture", 0.3),
        rb.Perturbation("left-out"),
    ),
    partitions=1,
    preset="tiny",
    atmospheres="none",
    lamps_per_class=2,
    config=LIGHT,
)
"""One partition, one scene per lamp, two lamps per class, one spectral row."""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    path = tmp_path_factory.mktemp("robustness") / "records.jsonl"
    records = rb.run_study(STUDY, path)
    return path, records, rb.summarise(records, STUDY)


def test_records_have_their_fields_and_are_paired(run):
    _, records, _ = run
    part = rb.partition(STUDY, 0)
    labels = [p.label for p in STUDY.perturbations]
    assert [r["perturbation"] for r in records[:: len(part.test)]] == labels
    lamps = {
        lab: [r["lamp"] for r in records if r["perturbation"] == lab] for lab in labels
    }
    ids = inv_mod.context_setup(part.ctx)[0].ids
    assert all(v == [ids[i] for i in part.test] for v in lamps.values())
    for r in records:
        assert {"partition", "band_set", "kind", "value", "lamp", "level1", "level2",
                "rows", "out_of_range", "truth", "truth_clean", "level1_correct",
                "level2_correct", "unexplained", "LER", "G", "LER_covered",
                "LER_width_median", "level1_confidence", "level1_top_right",
                "level1_answered_correct"} <= set(r)  # fmt: skip
        if r["unexplained"] == 0.0:  # every pixel answered
            assert r["level1_answered_correct"] == pytest.approx(r["level1_correct"])
        assert r["rows"] == len(r["level1_confidence"]) == len(r["level1_top_right"])
        assert r["out_of_range"] == 0
    clean = [r for r in records if r["kind"] == "clean"]
    assert all(r["truth"][:2] == r["truth_clean"][:2] for r in clean)
    train_ids = {ids[i] for i in part.train}
    for r in records:
        if r["kind"] == "mixture":
            assert r["other_lamp"] in train_ids
            other = part.ctx.table.classes[ids.index(r["other_lamp"])]
            assert other != r["level2"]
        if r["kind"] == "left-out":
            assert r["held_out_class"] == r["level2"]
            assert r["level2_correct"] == 0.0  # its class is not in the prior


def test_clean_rows_and_their_scenes_are_the_contexts(run):
    """The perturbed rows' path (spectra lit under the context's scenes) gives
    the context's own TOA for unperturbed spectra: the pairing is exact."""
    part = rb.partition(STUDY, 0)
    lamps = inv_mod.context_setup(part.ctx)[0]
    toa = rb.scene_spectra(part.ctx, lamps.spectra[part.test])
    np.testing.assert_allclose(toa, part.ctx.toa[part.test], rtol=1e-6)


def test_summary_maths(run):
    _, records, summary = run
    json.dumps(summary, allow_nan=False)  # strict JSON
    rows = {r["perturbation"]: r for r in summary["rows"]}
    for label, row in rows.items():
        recs = [r for r in records if r["perturbation"] == label]
        w = class_balanced_weights(np.asarray([r["level2"] for r in recs], object))
        for col in ("level1_correct", "LER", "unexplained"):
            v = np.asarray([r[col] for r in recs], float)
            assert row[col] == pytest.approx(np.sum(w * v))
        pix = np.concatenate([np.full(r["rows"], wi / r["rows"]) for r, wi in
                              zip(recs, w, strict=True)])  # fmt: skip
        conf = np.concatenate([r["level1_confidence"] for r in recs])
        right = np.concatenate([r["level1_top_right"] for r in recs]).astype(bool)
        assert row["ECE"] == pytest.approx(expected_calibration_error(conf, right, pix))
        flagged = np.concatenate([r["level1_flagged"] for r in recs]).astype(bool)
        for r in recs:  # the per-pixel flags are the lamp's unexplained rate
            assert np.mean(r["level1_flagged"]) == pytest.approx(r["unexplained"])
        if (~flagged).any():  # answered pixels only: the flagged carry no type
            assert row["ECE_answered"] == pytest.approx(
                expected_calibration_error(
                    conf[~flagged], right[~flagged], pix[~flagged]
                )
            )
        else:
            assert row["ECE_answered"] is None
        ans = [r for r in recs if r["level1_answered_correct"] is not None]
        wa = class_balanced_weights(np.asarray([r["level2"] for r in ans], object))
        v = np.asarray([r["level1_answered_correct"] for r in ans], float)
        assert row["level1_answered"] == pytest.approx(np.sum(wa * v) / wa.sum())
        lo = min(r["LER_width_median"] for r in recs)
        hi = max(r["LER_width_median"] for r in recs)
        assert lo <= row["LER_width_median"] <= hi
    for d in summary["paired"]:
        r, c = rows[d["perturbation"]], rows["clean"]
        for col in ("level1_correct", "LER", "ECE"):
            assert d[f"{col}_diff"] == pytest.approx(r[col] - c[col])
        # the interval over lamps: of the same class-balanced difference
        # (every lamp has level1_correct on both sides), lamps paired by id
        obs = rb.lamp_differences(
            [x for x in records if x["perturbation"] == d["perturbation"]],
            [x for x in records if x["perturbation"] == "clean"],
            "level1_correct",
        )
        assert sorted(obs["lamps"]) == sorted({x["lamp"] for x in records})
        est, lo, hi = paired_lamp_ci(**obs)
        assert est == pytest.approx(d["level1_correct_diff"])
        assert d["level1_correct_diff_ci95"] == pytest.approx([lo, hi])
        assert lo <= est <= hi
        assert "ECE_diff_ci95" not in d  # pooled over pixels: no lamp values
    assert "ci95" in summary["interval_note"]
    assert set(summary["reliability"]["recommended"]) == {"clean", "perturbed"}


def test_resume_keeps_finished_units(run, tmp_path):
    path, records, _ = run
    copy = tmp_path / "records.jsonl"
    copy.write_text(path.read_text() + '{"broken')
    kept, done = rb.load_records(copy, STUDY, resume=True)
    assert done == {(0, "recommended")} and len(kept) == len(records)
    assert rb.run_study(STUDY, copy, resume=True) == kept  # nothing recomputed
    fewer = rb.RobustnessStudy(
        band_sets=STUDY.band_sets, perturbations=STUDY.perturbations[:1]
    )
    kept, _ = rb.load_records(copy, fewer, resume=True)
    assert {r["perturbation"] for r in kept} == {"clean"}
    assert rb.load_records(copy, STUDY, resume=False) == ([], set())
    assert not copy.exists()
    packed = tmp_path / "records.jsonl.gz"  # the committed form
    with gzip.open(packed, "wt") as fh:
        fh.write(path.read_text())
    assert rb.load_records(packed, STUDY, resume=True) == (
        records,
        {(0, "recommended")},
    )
    assert rb.run_study(STUDY, packed, resume=True) == records


def test_resume_reruns_a_band_set_whose_bands_changed(run, tmp_path):
    """The digests beside the records say which bands each unit ran with; a
    band set whose definition changed since (a new recommendation) is not
    finished, the others are kept."""
    path, records, _ = run
    side = rb.digests_path(path)
    assert side.name == "records.bands.json"
    recorded = json.loads(side.read_text())
    bands = resolve_band_set(STUDY.band_sets[0][1]).bands
    from bandopt.results import DATA_KEY, data_digest

    assert recorded == {"recommended": rb.band_digest(bands), DATA_KEY: data_digest()}
    copy = tmp_path / "records.jsonl"
    copy.write_text(path.read_text())
    rb.digests_path(copy).write_text(side.read_text())
    kept, done = rb.load_records(copy, STUDY, True, recorded)
    assert done == {(0, "recommended")} and len(kept) == len(records)
    other = resolve_band_set("nightsat").bands
    assert rb.band_digest(other) != recorded["recommended"]
    older = {**recorded, DATA_KEY: "older lamp data"}
    assert rb.load_records(copy, STUDY, True, older)[1] == set()  # all rerun
    copy.write_text(path.read_text())
    kept, done = rb.load_records(
        copy, STUDY, True, {"recommended": rb.band_digest(other)}
    )
    assert (kept, done) == ([], set())
    assert copy.read_text() == ""  # the changed unit's records are dropped


def test_masking_a_class_removes_it_from_the_answer():
    part = rb.partition(STUDY, 0)
    bands = resolve_band_set(rb.BAND_SETS[0][1]).bands
    inv = fit_on_context(
        part.ctx, bands, LIGHT, train_lamps=part.train.tolist(), inner=list(part.inner)
    )
    masked = rb.without_class(inv, "hps")
    rad = part.ctx.radiance(bands)
    res = masked.predict(rad[:50])
    assert "hps" not in res.level2_labels and "hps" not in res.level2
    # the class is gone from the misfit too (zero prior weight left it there):
    # HPS pixels are explained worse without HPS lamps, others no better
    lamps, _, _, _ = inv_mod.context_setup(part.ctx)
    l2 = np.asarray(lamps.level2, dtype=object)[part.ctx.table.lamp_of]
    hps = np.flatnonzero(l2 == "hps")[:64]
    before = inv.posterior(rad[hps])[1]
    after = masked.posterior(rad[hps])[1]
    assert np.all(after >= before - 1e-9) and np.mean(after > before * 1.01) > 0.5
    # so are the flag's inner folds: no HPS entry, no held-out HPS row
    for fold in masked.flag_folds:
        assert "hps" not in fold.model.prior.level2 and "hps" not in fold.classes


def test_study_options_are_checked():
    with pytest.raises(ValueError, match="clean"):
        rb.RobustnessStudy(perturbations=(rb.Perturbation("noise", 30.0),))
    with pytest.raises(ValueError, match="background-flat"):
        rb.Perturbation("background", 0.01)
    assert rb.Perturbation("Background_Flat", 0.01).label == "flat background 1 %"
    labels = [p.label for p in rb.STUDY_PERTURBATIONS]
    assert len(set(labels)) == len(labels) == 19
    assert rb.STUDY_PERTURBATIONS[-1].kind == "truncation"


def test_experiment_writes_its_outputs(run, tmp_path):
    from bandopt.robustness import write_outputs

    _, _, summary = run
    write_outputs(summary, STUDY, tmp_path)
    for name in ("summary.json", "robustness.png", "README.md", "manifest.json"):
        assert (tmp_path / name).is_file(), name
    text = (tmp_path / "README.md").read_text()
    assert "| recommended | 30 % other lamp |" in text
    assert "nan" not in text.lower().replace("n/a", "")


def test_committed_summary_pairs_our_bands_with_each_reference():
    """`versus` in the committed summary: our bands minus each reference on
    the same row, partition by partition, equal to the rows' own values; the
    report's verdict shows them beside each reference."""
    import json
    from pathlib import Path

    summary = json.loads(Path("results/robustness/summary.json").read_text())
    by = {(r["band_set"], r["perturbation"]): r for r in summary["rows"]}
    ours = summary["band_sets"][0]
    assert summary["versus"], "no paired comparison with the references"
    refs = set()
    for v in summary["versus"]:
        assert v["band_set"] == ours and v["reference"] != ours
        refs.add(v["reference"])
        a, b = by[(ours, v["perturbation"])], by[(v["reference"], v["perturbation"])]
        for col in ("level1_correct", "LER", "CCT", "ECE"):
            d = np.subtract(a[f"{col}_per_partition"], b[f"{col}_per_partition"])
            assert v[f"{col}_diff"] == pytest.approx(d.mean())
            assert v[f"{col}_diff_sd"] == pytest.approx(d.std(ddof=1))
    assert refs == set(summary["band_sets"][1:])
