"""bandopt.report.before_after on the committed results (git HEAD): every headline
is read from its file, a missing key fails naming file and key, a missing file
shows "not run", unchanged experiments are marked "NOT re-run", and the output
is strict JSON. No experiment runs; no made-up result files (a variant is a
committed file with one key removed or one field changed)."""

import json
import shutil
from pathlib import Path

import pytest

from bandopt.report import (
    _before_after_sides as sides,
    before_after as ba,
    consistency_messages,
)


RESULTS = Path(__file__).resolve().parents[1] / "results"

EXPECTED_KEYS = {
    # the fixed headlines every run of each experiment must provide
    "search": [
        "chosen_n",
        "best_n",
        "recommended",
        "norm_mae",
        "mae_LER",
        "mae_G",
        "mae_CCT",
        "f1",
        "reduction_sdgsat-1_LER",
        "reduction_nightsat_CCT",
        "band_names",
        "centre_nm",
        "fwhm_nm",
    ],
    "classify": [
        "chosen_n",
        "nested_l2",
        "rec_noisy_level1",
        "rec_noisy_level2",
        "ref_sdgsat-1_level2",
        "ref_nightsat_level1",
        "goal_margin",
        "goal_met",
    ],
    "radiometry": [
        "linear_bits",
        "companded_bits",
        "ner_bits",
        "clip_LER",
        "clip_f1",
        "sdgsat-1_limit",
        "nightsat_saturation",
        "viirs-dnb_bits",
    ],
    "spatial": [
        "median_gsd",
        "single_gsd",
        "scenes",
        "never",
        "overlap_gsd",
        "overlap_f1_mixed",
    ],
    "estimate": [
        "mae_recommended/inversion/unknown",
        "mae_sdgsat-1/ridge/unknown",
        "coverage_unseen_types_recommended",
    ],
    "noise_aware": ["P4_cv_loss", "P4_centre_nm", "P4_fwhm_nm"],
}


class Overlay:
    """A committed revision with some files replaced (bytes) or removed (None)."""

    def __init__(self, base, changes: dict):
        self.base, self.changes = base, changes
        self.commit, self.label, self.repo = (
            base.commit,
            f"{base.label} (edited)",
            base.repo,
        )

    def read(self, rel):
        return self.changes[rel] if rel in self.changes else self.base.read(rel)


@pytest.fixture(scope="module")
def head():
    return ba.GitSource("HEAD", RESULTS)


@pytest.fixture(scope="module")
def same(head):
    return ba.compare(head, head)


def _load(head, rel):
    return json.loads(head.read(rel))


def _without(head, rel, path):
    """The committed file `rel` with the key at `path` ("a/b/0/c") removed."""
    data = _load(head, rel)
    node, parts = data, path.split("/")
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node[p]
    del node[parts[-1]]
    return json.dumps(data).encode()


def test_head_against_itself_every_headline_present_and_no_change(same):
    assert set(same["experiments"]) == set(ba.EXPERIMENTS)
    for exp, e in same["experiments"].items():
        keys = [r["key"] for r in e["headlines"]]
        missing = [k for k in EXPECTED_KEYS[exp] if k not in keys]
        assert not missing, (exp, missing)
        assert e["before"]["run"] and e["after"]["run"]
        assert e["re_run"] is False
        assert set(e["files"].values()) == {"identical"}
        for r in e["headlines"]:
            assert r["before"] == r["after"], (exp, r)
            assert r["before"] not in (ba.NOT_RUN, ba.ABSENT), (exp, r)
            c = r["change"]
            if isinstance(c, list):  # None only where a value is undefined
                assert all(
                    x == 0 or (x is None and (v is None or isinstance(v, str)))
                    for x, v in zip(c, r["before"], strict=True)
                ), (exp, r)
            else:
                assert c in (0, "same"), (exp, r)


def test_headlines_are_the_files_numbers(head, same):
    """Spot checks against the committed files, read independently."""
    rows = {
        exp: {r["key"]: r["after"] for r in e["headlines"]}
        for exp, e in same["experiments"].items()
    }
    cmp = _load(head, "search/compare.json")
    rec = cmp["pareto"]["recommended"]
    assert rows["search"]["chosen_n"] == cmp["band_count"]["chosen_n"]
    assert rows["search"]["recommended"] == rec
    assert rows["search"]["mae_CCT"] == cmp["designs"][rec]["mae_mean"]["CCT"]
    assert (
        rows["search"]["reduction_nightsat_CCT"]
        == (cmp["reductions"]["nightsat"]["recommended"]["CCT"]["reduction"])
    )
    bands = _load(head, "search/recommended_bands.json")["bands"]
    assert rows["search"]["centre_nm"] == [b["centre_nm"] for b in bands]
    cls = _load(head, "classify/summary.json")
    assert (
        rows["classify"]["nested_l2"]
        == (cls["recommended"]["bands"]["level2_macro_f1_nested"])
    )
    rad = _load(head, "radiometry/summary.json")
    assert (
        rows["radiometry"]["linear_bits"]
        == (rad["bit_depth"]["recommended_linear_bits"])
    )
    est = _load(head, "estimate/summary.json")
    r = next(
        x
        for x in est
        if (x["band_set"], x["estimator"], x["surface"])
        == ("recommended", "inversion", "unknown")
    )
    assert rows["estimate"]["mae_recommended/inversion/unknown"] == (
        [r["LER"], r["G"], r["CCT"]]
    )
    man = _load(head, "estimate/manifest.json")
    assert same["experiments"]["estimate"]["after"]["git_commit"] == (man["git_commit"])
    assert (
        same["experiments"]["estimate"]["after"]["created_utc"] == (man["created_utc"])
    )


@pytest.mark.parametrize(
    ("exp", "name", "path"),
    [
        ("search", "compare.json", "band_count/chosen_n"),
        ("search", "recommended_bands.json", "bands/0/fwhm_nm"),
        ("classify", "summary.json", "recommended/noisy/level2/macro_f1"),
        ("radiometry", "summary.json", "bit_depth/recommended_linear_bits"),
        ("spatial", "summary.json", "gsd_needed_m/single"),
        ("estimate", "coverage.json", "unseen_types"),
        ("noise_aware", "noise_aware.json", "rows/0/cv_loss"),
    ],
)
def test_a_missing_key_fails_naming_file_and_key(head, exp, name, path):
    rel = f"{exp}/{name}"
    edited = Overlay(head, {rel: _without(head, rel, path)})
    with pytest.raises(ValueError, match=rf"results/{rel}: missing key") as err:
        ba.compare(head, edited, [exp])
    assert repr(path.split("/")[-1]) in str(err.value)


def test_missing_experiment_or_file_on_one_side_is_not_run(head):
    gone = {f"noise_aware/{n}": None for n in ("noise_aware.json", "manifest.json")}
    gone["spatial/overlap.json"] = None
    rec = ba.compare(head, Overlay(head, gone), ["noise_aware", "spatial", "search"])
    na = rec["experiments"]["noise_aware"]
    assert na["before"]["run"] and not na["after"]["run"]
    assert na["re_run"] is None
    assert all(
        r["after"] == ba.NOT_RUN and r["change"] is None for r in na["headlines"]
    )
    assert all(r["before"] != ba.NOT_RUN for r in na["headlines"])
    sp = {r["key"]: r for r in rec["experiments"]["spatial"]["headlines"]}
    assert sp["overlap_f1_mixed"]["after"] == ba.NOT_RUN
    assert sp["median_gsd"]["after"] == sp["median_gsd"]["before"]
    assert rec["experiments"]["spatial"]["re_run"] is True  # a file differs
    text = ba.readme_text(rec)
    assert "### noise_aware (`results/noise_aware/`) - **not run after**" in text
    assert "After: not run" in text
    assert f"| P4: CV loss [1] | {_p4(head)} | not run | n/a |" in text
    # and the other way round
    back = ba.compare(Overlay(head, gone), head, ["noise_aware"])
    assert "**not run before**" in ba.readme_text(back)


def _p4(head):
    rows = _load(head, "noise_aware/noise_aware.json")["rows"]
    return f"{next(r for r in rows if r['level'] == 'P4')['cv_loss']:.4g}"


def test_not_re_run_is_marked_and_a_re_run_is_not(head, same):
    text = ba.readme_text(same)
    for exp in ba.EXPERIMENTS:
        assert f"### {exp} (`results/{exp}/`) - **NOT re-run**" in text
    assert "**NOT re-run (after = before): " + ", ".join(ba.EXPERIMENTS) in text
    man = _load(head, "search/manifest.json")
    man["created_utc"] = "2026-11-25T13:00:00+00:00"  # the file a re-run rewrites
    rec = ba.compare(
        head, Overlay(head, {"search/manifest.json": json.dumps(man).encode()})
    )
    assert rec["experiments"]["search"]["re_run"] is True
    assert rec["experiments"]["classify"]["re_run"] is False
    text = ba.readme_text(rec)
    assert "### search (`results/search/`)\n" in text
    assert "### classify (`results/classify/`) - **NOT re-run**" in text
    assert "2026-11-25T13:00:00+00:00" in text


def test_the_before_revision_of_issue_11_reads(head):
    """The lead's use: --before 0e7885f (main before the re-runs) against now.
    Every experiment has its files there, and none records the scene physics
    (all predate the recorded neighbourhood)."""
    try:
        before = ba.GitSource("0e7885f", RESULTS)
    except ValueError:
        pytest.skip("commit 0e7885f is not in this clone")
    rec = ba.compare(before, head)
    for exp, e in rec["experiments"].items():
        assert e["before"]["run"] and e["after"]["run"], exp
        assert e["before"]["physics"]["summary"].startswith(ba.NOT_RECORDED_PRE11), exp
        # ABSENT allowed: a quantity only the re-run has (e.g. one more band)
        assert all(r["before"] != ba.NOT_RUN for r in e["headlines"]), exp


def test_change_rules():
    assert ba.change(2, 3) == {"change": 1, "relative": 0.5}
    assert ba.change(0.0, 1.0) == {"change": 1.0, "relative": None}
    assert ba.change([1.0, 2.0], [1.5, 2.0])["change"] == [0.5, 0.0]
    assert ba.change([1.0], [1.0, 2.0])["change"] == "changed (1 -> 2 values)"
    assert ba.change("a", "b")["change"] == "changed"
    assert ba.change(True, True)["change"] == "same"
    assert ba.change(ba.NOT_RUN, 1.0) == {"change": None, "relative": None}
    assert ba.change(1.0, ba.ABSENT) == {"change": None, "relative": None}


def test_written_json_is_strict_and_readme_section_replaced(head, same, tmp_path):
    for rel in (
        "README.md",
        "classify/summary.json",
        "spatial/summary.json",
        "spatial/overlap.json",
        "recommendation.json",
        "radiometry/limits.csv",
        "radiometry/summary.json",
        "search/compare.json",
        "search/stability.json",
    ):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(RESULTS / rel, tmp_path / rel)
    drift = [m for m in consistency_messages(tmp_path) if "README" in m]
    ba.write(same, tmp_path)
    ba.write(same, tmp_path)  # a second run replaces, not appends

    def no_constants(name):
        raise AssertionError(f"non-strict JSON constant {name}")

    data = json.loads(
        (tmp_path / "before_after.json").read_text(), parse_constant=no_constants
    )
    assert data["before"]["commit"] == head.commit
    assert (tmp_path / "before_after_manifest" / "manifest.json").is_file()
    text = (tmp_path / "README.md").read_text()
    assert text.count("<!-- before-after:start -->") == 1
    assert text.count("<!-- before-after:end -->") == 1
    old = (RESULTS / "README.md").read_text()
    assert text.startswith(old.split("<!-- before-after:start -->")[0].rstrip("\n"))
    # the report's drift check sees nothing new in the generated section
    assert [m for m in consistency_messages(tmp_path) if "README" in m] == drift


def test_cli_prints_the_section_without_writing(capsys):
    assert (
        ba.run(
            [
                "--before",
                "HEAD",
                "--after",
                "HEAD",
                "--results",
                str(RESULTS),
                "--experiments",
                "spatial",
                "--no-write",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert out.startswith("## Before / after issue 11")
    assert "### spatial (`results/spatial/`) - **NOT re-run**" in out


def test_unknown_revision_is_a_clear_error():
    with pytest.raises(ValueError, match="'no-such-rev': not a git revision"):
        ba.GitSource("no-such-rev", RESULTS)


def test_a_lost_manifest_commit_is_dated_against_the_physics_commit(head):
    """A manifest whose commit is not in the repository: made before the
    commit that added the neighbourhood option is pre-issue-11; made after it,
    the physics is unknown (never guessed)."""
    first = sides._first_physics_commit(head.repo)
    if first is None:
        pytest.skip("this clone has no commit with scene physics options")
    lost = "0" * 40
    early = sides._physics({}, lost, head.repo, "2000-01-01T00:00:00+00:00")
    assert early["summary"].startswith(ba.NOT_RECORDED_PRE11 + ", by date")
    assert first[0][:7] in early["summary"]
    late = sides._physics({}, lost, head.repo, "2999-01-01T00:00:00+00:00")
    assert late["summary"] == "not recorded (manifest commit not in this repository)"
    undated = sides._physics({}, lost, head.repo, None)
    assert undated["summary"] == late["summary"]
