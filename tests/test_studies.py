"""Studies as configurations (`bandopt.studies`): the registry, `make study`,
and one study run end to end through the machinery on a tiny scenario set:
records, summary, figure and manifest written, and a resumed run recomputes
nothing and writes the same summary. Every registered study's committed
README section is what its configuration generates from its committed
summary."""

import dataclasses
import json
from pathlib import Path

import pytest

from bandopt.results import RESULTS_DIR, readme_section
from bandopt.studies import STUDIES, Study, run


ROOT = Path(__file__).resolve().parents[1]


def test_registry_names_every_ablation_once_by_any_spelling():
    assert len(STUDIES) >= 7
    for name, study in STUDIES.items():
        assert isinstance(study, Study) and study.name == name
        assert STUDIES[name.upper().replace("-", "_")] is study
        assert study.out == f"results/{name.replace('-', '_')}"
        assert set(study.estimators) >= {v for pair in study.pairs for v in pair}
        assert study.band_sets and study.title and study.description
    with pytest.raises(ValueError, match="Unknown study 'no-such'"):
        STUDIES.resolve("no-such")


@pytest.mark.parametrize("name", list(STUDIES))
def test_committed_section_is_generated_by_the_configuration(name):
    """Results are recomputed, not replayed: the committed README section of
    each study is its configuration's text of its committed summary."""
    study = STUDIES[name]
    summary = json.loads((ROOT / study.out / "summary.json").read_text())
    section = readme_section(f"{name}", RESULTS_DIR)
    assert section.strip() == study.readme(summary).strip()


def test_make_study_lists_and_refuses_an_unknown_name(capsys):
    from experiments import study

    assert study.main([]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in STUDIES)
    assert study.main(["no-such-study"]) == 2
    assert "Unknown study 'no-such-study'" in capsys.readouterr().err
    recipe = (ROOT / "Makefile").read_text().split("\nstudy:")[1].split("\n\n")[0]
    assert "experiments.study $(NAME) $(ARGS)" in recipe


def test_a_tiny_study_runs_through_the_machinery_and_resumes(tmp_path):
    study = dataclasses.replace(
        STUDIES["estimate-mix"],
        preset="tiny",
        atmospheres="none",
        band_sets={"sdgsat-1": ("unknown",)},
        oracle=False,
    )
    argv = ["--partitions", "2", "--out", str(tmp_path), "--no-unseen"]
    assert run(study, argv) == 0
    names = {p.name for p in tmp_path.iterdir()}
    assert {"records.jsonl", "summary.json", "errors.png", "manifest.json"} <= names
    records = [
        json.loads(x) for x in (tmp_path / "records.jsonl").read_text().splitlines()
    ]
    assert {(r["partition"], r["band_set"]) for r in records} == {
        (0, "sdgsat-1"),
        (1, "sdgsat-1"),
    }
    assert {r["estimator"] for r in records} == set(study.estimators)
    summary = json.loads((tmp_path / "summary.json").read_text())
    rows = {r["estimator"]: r for r in summary["rows"]}
    assert set(rows) == set(study.estimators)
    for r in rows.values():  # class-balanced MAE with its spread over partitions
        assert r["LER"] > 0 and r["LER_sd"] is not None
    (paired,) = [p for p in summary["paired"] if p.get("vs") == study.pairs[0][1]]
    assert paired["estimator"] == study.pairs[0][0]
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["config"]["study"] == "estimate-mix"
    before = (tmp_path / "summary.json").read_bytes()
    lines = (tmp_path / "records.jsonl").read_text()
    assert run(study, [*argv, "--resume"]) == 0  # nothing left to compute
    assert (tmp_path / "records.jsonl").read_text() == lines
    assert (tmp_path / "summary.json").read_bytes() == before


def test_a_study_takes_its_variants_from_the_estimator_registry():
    """Every study's variants are configurations of the registered inversion
    (`estimators.variant`, the options `inversion.options_of` names); a
    misspelt variant stops the study's configuration, naming it."""
    from bandopt import inversion as inv_mod
    from bandopt.estimators import InversionConfig, variant

    for study in STUDIES.values():
        for label in (*study.estimators, *study.unseen):
            config = variant(label)
            assert isinstance(config, InversionConfig)
            opts = inv_mod.options_of(label)
            for f in dataclasses.fields(opts):
                assert getattr(config, f.name) == getattr(opts, f.name), label
    study = next(iter(STUDIES.values()))
    with pytest.raises(ValueError, match="inversion-moon-mixx"):
        dataclasses.replace(study, estimators=("inversion-moon-mixx",))


def test_resume_drops_only_the_band_sets_whose_bands_changed(tmp_path):
    """The digests beside a study's records: a band set recorded with other
    bands than now (a new recommendation) loses its records and reruns; the
    others stay finished; the new digests are recorded."""
    from bandopt.studies._units import load_records

    path = tmp_path / "records.jsonl"
    recs = [{"partition": p, "band_set": b, "x": 1}
            for p in (0, 1) for b in ("recommended", "nightsat")]  # fmt: skip
    path.write_text("".join(json.dumps(r) + "\n" for r in recs))
    side = tmp_path / "records.bands.json"
    side.write_text(json.dumps({"recommended": "old", "nightsat": "n"}))
    kept, done = load_records(
        path, keep=True, say=lambda m: None,
        digests={"recommended": "new", "nightsat": "n"},
    )  # fmt: skip
    assert done == {(0, "nightsat"), (1, "nightsat")}
    assert [r["band_set"] for r in kept] == ["nightsat", "nightsat"]
    assert len(path.read_text().splitlines()) == 2
    assert json.loads(side.read_text()) == {"recommended": "new", "nightsat": "n"}
    _, done = load_records(path, keep=True, say=lambda m: None,
                           digests={"recommended": "new", "nightsat": "n"})  # fmt: skip
    assert done == {(0, "nightsat"), (1, "nightsat")}
    assert load_records(path, keep=False, say=lambda m: None) == ([], set())
    assert not side.exists()


def test_resume_after_a_change_of_the_lamp_data_reruns_every_unit(tmp_path):
    """With the lamp data's fingerprint (`results.DATA_KEY`) beside the
    records, a resume after it changed reruns every band set, not only
    those whose bands changed; a file without it (written before it was
    recorded) is read as before and gets it."""
    from bandopt.results import DATA_KEY, data_digest
    from bandopt.studies._units import load_records

    path = tmp_path / "records.jsonl"
    recs = [{"partition": p, "band_set": b, "x": 1}
            for p in (0, 1) for b in ("recommended", "nightsat")]  # fmt: skip
    side = tmp_path / "records.bands.json"
    now = {"recommended": "r", "nightsat": "n", DATA_KEY: data_digest()}
    for recorded, want in (
        ({"recommended": "r", "nightsat": "n"}, 4),  # before: kept, recorded
        ({"recommended": "r", "nightsat": "n", DATA_KEY: now[DATA_KEY]}, 4),
        ({"recommended": "r", "nightsat": "n", DATA_KEY: "older data"}, 0),
    ):
        path.write_text("".join(json.dumps(r) + "\n" for r in recs))
        side.write_text(json.dumps(recorded))
        _, done = load_records(path, keep=True, say=lambda m: None, digests=now)
        assert len(done) == want, recorded
        assert json.loads(side.read_text()) == now
    assert data_digest() == now[DATA_KEY]  # deterministic
    assert len(now[DATA_KEY]) == 16
