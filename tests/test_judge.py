"""bandopt.studies.judge: the search's candidates from its committed files,
the loss and the one-SD choice on hand-made summaries, and the whole study
on a tiny configuration (two lamp partitions, two lamps per class)."""

import gzip
import json

import numpy as np
import pytest

from bandopt.folds import paired_lamp_ci
from bandopt.radiometry import RadiometryConfig
from bandopt.robustness import Perturbation
from bandopt.sensor.reference import load_band_set
from bandopt.studies import judge
from tests.test_robustness import LIGHT  # the shipped estimator without its slow extras


def test_candidates_are_the_searchs_designs_with_its_pan_band():
    cands = judge.candidates()
    compare = json.loads((judge.SEARCH / "compare.json").read_text())
    rec = load_band_set(judge.SEARCH / "recommended_bands.json")
    keys = [k for k, _ in cands]
    assert compare["pareto"]["recommended"] in keys
    with_design = [k for k, d in compare["designs"].items() if "stability" in d]
    assert set(with_design) <= set(keys)
    counts = [len(b.names) for _, b in cands]
    assert counts == sorted(counts)
    for key, bands in cands:
        assert bands.names[-1] == "PAN"
        assert float(bands.centre_nm[-1]) == pytest.approx(float(rec.centre_nm[-1]))
        if key in with_design:
            stab = compare["designs"][key]["stability"]
            np.testing.assert_allclose(
                bands.centre_nm[:-1], stab["centre_nm"], rtol=1e-9
            )
            np.testing.assert_allclose(bands.fwhm_nm[:-1], stab["fwhm_nm"], rtol=1e-9)
    rec_bands = dict(cands)[compare["pareto"]["recommended"]]
    np.testing.assert_allclose(rec_bands.centre_nm, rec.centre_nm)


def _summary(values: dict) -> dict:
    """A robustness summary with one row per band set and label: `values`
    maps (band set, label) to (level1, level2, LER, G, CCT) per partition."""
    rows = []
    labels = []
    for (b, lab), per in values.items():
        labels.append(lab) if lab not in labels else None
        per = np.asarray(per, float)
        row = {"band_set": b, "perturbation": lab, "kind": lab}
        for j, col in enumerate(
            ("level1_correct", "level2_correct", "LER", "G", "CCT")
        ):
            row[f"{col}_per_partition"] = per[:, j].tolist()
            row[col] = float(per[:, j].mean())
        rows.append(row)
    return {"rows": rows, "perturbations": labels}


SD = {"LER": 10.0, "G": 1.0, "CCT": 100.0}


def test_loss_is_the_mean_of_normalised_error_and_misclassification():
    s = _summary({("a", "clean"): [(0.8, 0.6, 10.0, 0.5, 300.0)] * 2,
                  ("a", "noise"): [(0.6, 0.4, 20.0, 1.0, 0.0)] * 2})  # fmt: skip
    loss = judge.losses(s, SD, ["a"])["a"]
    e = np.mean([(1 + 0.5 + 3) / 3, (2 + 1 + 0) / 3])
    c = np.mean([1 - 0.7, 1 - 0.5])
    assert loss["estimation"] == pytest.approx(e)
    assert loss["classification"] == pytest.approx(c)
    assert loss["J"] == pytest.approx((e + c) / 2)
    assert loss["J_sd"] == pytest.approx(0.0)
    with pytest.raises(ValueError, match="no row for band set 'b'"):
        judge.losses(s, SD, ["a", "b"])


def test_choice_takes_the_fewest_bands_within_one_sd_of_the_best():
    def loss(per):
        return {"J": float(np.mean(per)), "J_per_partition": list(per)}

    n = {"small": 3, "big": 6, "mid": 4}
    # big is best; small is worse by 0.01 +- 0.02 (within), mid worse by 0.1 +- 0.01
    losses = {
        "big": loss([0.20, 0.22, 0.21, 0.23]),
        "small": loss([0.23, 0.21, 0.24, 0.22]),
        "mid": loss([0.30, 0.32, 0.31, 0.35]),
    }
    ch = judge.choose(losses, n)
    assert ch["best"] == "big"
    assert ch["chosen"] == "small"
    assert "mid" not in ch["within_one_sd"]
    # a consistently worse small design (paired: +0.05 in every partition)
    losses["small"] = loss([0.25, 0.27, 0.26, 0.28])
    assert judge.choose(losses, n)["chosen"] == "big"


KEEP = ("n2+pan a=0", "n3+pan a=0.5")
"""The two candidates the tiny study judges."""


SMALL_RADIOMETRY = RadiometryConfig.quick(
    surfaces=("asphalt",), classes=("P6", "C0"), moons=(None,),
    fire_temperatures_k=(700.0,),
)  # fmt: skip
"""The instrument check's scene distribution in the tiny study: one surface,
the dimmest and a bright class, no Moon (seconds, not minutes)."""


def test_the_tiny_study_writes_a_verdict_that_agrees_with_its_rows(
    tmp_path, monkeypatch
):
    every = judge.candidates
    monkeypatch.setattr(judge, "REFERENCES", ("nightsat",))
    monkeypatch.setattr(
        judge, "candidates",
        lambda search: [c for c in every(search) if c[0] in KEEP],
    )  # fmt: skip
    result = judge.run(
        tmp_path, partitions=2, preset="tiny", atmospheres="none",
        lamps_per_class=2, config=LIGHT,
        perturbations=(Perturbation("clean"), Perturbation("mixture", 0.1)),
        instrument=SMALL_RADIOMETRY,
    )  # fmt: skip
    assert set(result["losses"]) == {"n2+pan a=0", "n3+pan a=0.5", "nightsat"}
    assert result["choice"]["chosen"] in ("n2+pan a=0", "n3+pan a=0.5")
    assert result["n_bands"] == {"n2+pan a=0": 3, "n3+pan a=0.5": 4, "nightsat": 6}
    compare = json.loads((judge.SEARCH / "compare.json").read_text())
    assert result["snr_median"] == {  # beside the loss: the instrument's side
        **{k: compare["designs"][k]["snr_median"] for k in KEEP},
        "nightsat": compare["references"]["nightsat"]["snr_median"],
    }
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["versus"] == []  # peers: their pairs are in judge.json
    again = judge.losses(summary, result["truth_sd"], list(result["losses"]))
    for b, v in again.items():
        assert v["J"] == pytest.approx(result["losses"][b]["J"])
        assert len(v["J_per_partition"]) == 2
    d = result["chosen_minus_reference"]["nightsat"]["J"]["mean"]
    assert d == pytest.approx(
        result["losses"][result["choice"]["chosen"]]["J"]
        - result["losses"]["nightsat"]["J"]
    )
    # the paired interval over lamps is of that same difference: each
    # (lamp, partition)'s loss difference, per partition class-balanced,
    # then the mean over partitions, as the losses are
    with gzip.open(tmp_path / "records.jsonl.gz", "rt") as fh:
        records = [json.loads(x) for x in fh]
    per_lamp = judge.lamp_losses(records, result["truth_sd"])
    chosen = result["choice"]["chosen"]
    units = sorted({k[1:3] for k in per_lamp.losses if k[0] == chosen})
    diff = np.asarray([
        np.mean([np.subtract(v, per_lamp.losses[("nightsat", *k[1:])])
                 for k, v in per_lamp.losses.items()
                 if k[0] == chosen and k[1:3] == u], axis=0)
        for u in units
    ])  # fmt: skip
    obs = {
        "lamps": [u[0] for u in units],
        "classes": [per_lamp.classes[u[0]] for u in units],
        "groups": [u[1] for u in units],
    }
    for i, part in enumerate(judge.PARTS):
        v = result["chosen_minus_reference"]["nightsat"][part]
        est, lo, hi = paired_lamp_ci(diff[:, i], **obs)
        assert est == pytest.approx(v["mean"])
        assert v["ci95"] == pytest.approx([lo, hi]) and lo <= est <= hi
    assert "ci95" in result["searched_minus_chosen"]["J"]
    assert "Intervals: ci95" in (tmp_path / "README.md").read_text()
    assert "**Under the instrument**" in (tmp_path / "README.md").read_text()
    # the instrument check: every judged band set through the radiometry
    inst = result["instrument"]
    assert set(inst["band_sets"]) == set(result["losses"])
    assert inst["snr_target"] == 10.0
    for v in inst["band_sets"].values():
        assert v["snr_at_limit"] > 0
        target = inst["snr_target"] * (1 - 1e-9)  # the radiometry's own rule
        assert v["meets_snr_target"] == (v["snr_at_limit"] >= target)
    under = result["choice_under_instrument"]
    assert under["meeting_target"] == [
        b for b in KEEP if inst["band_sets"][b]["meets_snr_target"]
    ]
    # the trade the loss does not weigh: the narrowest band beside the SNR
    judged = {k: b for k, b in every(judge.SEARCH) if k in KEEP}
    judged["nightsat"] = load_band_set("nightsat")
    assert set(result["narrowest_fwhm_nm"]) == set(judged)
    for label, bands in judged.items():
        assert result["narrowest_fwhm_nm"][label] == pytest.approx(min(bands.fwhm_nm))
    for name in (
        "judge.json",
        "judge.png",
        "trade.png",
        "README.md",
        "manifest.json",
        "records.jsonl.gz",
    ):
        assert (tmp_path / name).is_file()
    assert result["choice"]["chosen"] in (tmp_path / "README.md").read_text()
    assert len(list((tmp_path / "candidates").glob("*.json"))) == 2
    # the choice becomes the "spectral" recommendation (beside the output,
    # since this is not the shipped folder) with the judged design's bands
    from bandopt.results import recommended_band_set

    rec = json.loads((tmp_path / "recommendation.json").read_text())["spectral"]
    assert rec["set"] == result["choice"]["chosen"] and rec["chosen_by"] == "judge"
    assert rec["search_pick"]["set"] == result["searched"]
    assert rec["judge"]["J"] == pytest.approx(result["losses"][rec["set"]]["J"])
    chosen = dict(every(judge.SEARCH))[rec["set"]]
    got = recommended_band_set("spectral", path=tmp_path / "recommendation.json")
    np.testing.assert_allclose(got.centre_nm, chosen.centre_nm)
    np.testing.assert_allclose(got.fwhm_nm, chosen.fwhm_nm)
    assert [b["name"] for b in rec["bands"]] == list(chosen.names)
    again = load_band_set(tmp_path / "recommended_bands.json")
    np.testing.assert_allclose(again.centre_nm, chosen.centre_nm)


def test_the_report_shows_the_judged_choice_and_whether_the_search_agrees(tmp_path):
    """The verdict section tables every judged band set with its loss and
    marks the choice; it says when the search's pick is not the choice, and
    without the judge's results it says what to run."""
    from bandopt.report import build_report

    per = {
        "n2": [(0.90, 0.80, 10.0, 0.2, 200.0), (0.88, 0.79, 11.0, 0.2, 210.0)],
        "n3": [(0.80, 0.70, 14.0, 0.3, 300.0), (0.82, 0.71, 13.0, 0.3, 320.0)],
        "ref": [(0.91, 0.81, 9.0, 0.3, 250.0), (0.90, 0.80, 9.5, 0.3, 260.0)],
    }
    s = _summary({(b, "clean"): v for b, v in per.items()})
    for r in s["rows"]:
        r.update(ECE=0.05, unexplained=0.0)
    n = {"n2": 3, "n3": 4, "ref": 6}
    out = tmp_path / "judge"
    out.mkdir()
    for searched, says in (
        ("n3", "not the search's pick"),
        ("n2", "is the judged choice"),
    ):
        res = judge.verdict(s, SD, list(per), n, searched, ("ref",))
        assert res["choice"]["chosen"] == "n2"
        (out / "judge.json").write_text(json.dumps(res))
        text = build_report(
            tmp_path, tmp_path / f"o{searched}", strict=False
        ).path.read_text()
        start = text.index('<section id="verdict">')
        section = text[start : text.index("</section>", start)]
        assert says in section
        assert "n2 <strong>(chosen" in section and "ref" in section
        # against the reference: ± SD over partitions without lamp records ...
        assert "The chosen design against each reference sensor" in section
        assert "written before the intervals over lamps" in section
    # ... its interval over lamps when judge.json has one
    res["chosen_minus_reference"]["ref"]["J"]["ci95"] = [-0.0123, 0.0456]
    res["interval_note"] = judge.INTERVAL_NOTE
    (out / "judge.json").write_text(json.dumps(res))
    text = build_report(tmp_path, tmp_path / "oci", strict=False).path.read_text()
    assert "-0.0123" in text and "0.0456" in text and "resampled within" in text
    (out / "judge.json").unlink()
    text = build_report(tmp_path, tmp_path / "o", strict=False).path.read_text()
    assert "make judge" in text


def test_choice_under_the_instrument_takes_the_judges_rule_on_those_that_meet_it():
    """Among candidates that reach the SNR target the judge's own rule picks;
    when none does, there is no pick, and the candidate needing the least
    exposure and what the judged choice needs are named."""
    from bandopt.studies._judge_instrument import choose_under_instrument

    def inst(meets, factors):
        return {"band_sets": {
            b: {"meets_snr_target": m, "exposure_factor": f}
            for b, m, f in zip("abc", meets, factors, strict=True)
        }}  # fmt: skip

    got = choose_under_instrument(
        inst((False, True, True), (9.0, 1.0, 1.0)), "abc", lambda m: m[-1], "a"
    )
    assert got == {"meeting_target": ["b", "c"], "chosen": "c", "same_as_judged": False}
    got = choose_under_instrument(
        inst((False, False, False), (9.0, 3.0, 40.0)), "abc", lambda m: m[0], "c"
    )
    assert got["chosen"] is None and got["meeting_target"] == []
    assert got["least_exposure"] == "b" and got["least_exposure_factor"] == 3.0
    assert got["judged_exposure_factor"] == 40.0


def test_committed_instrument_check_is_the_radiometrys():
    """The judge's instrument check of the recommended design and of the
    reference sensors is what `make radiometry` wrote for them (same scene
    distribution, photon model and rule): the SNR of the limiting band at its
    detection limit and the largest exposure factor."""
    import csv
    from pathlib import Path

    res = json.loads(Path("results/judge/judge.json").read_text())
    text = Path("results/radiometry/limits.csv").read_text()
    rows = list(csv.DictReader(text.splitlines()))
    rad = json.loads(Path("results/radiometry/summary.json").read_text())
    names = {"ours": res["choice"]["chosen"], "nightsat": "nightsat",
             "sdgsat-1": "sdgsat-1"}  # fmt: skip
    assert rad["band_set"] == "ours"
    for rad_name, label in names.items():
        mine = [r for r in rows if r["band_set"] == rad_name]
        assert mine, rad_name
        v = res["instrument"]["band_sets"][label]
        assert v["snr_at_limit"] == pytest.approx(
            min(float(r["snr_at_limit"]) for r in mine), rel=1e-4
        )  # the CSV's five significant digits
        assert v["exposure_factor"] == pytest.approx(
            max(float(r["exposure_factor_for_snr_target"]) for r in mine), rel=1e-4
        )
