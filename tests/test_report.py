"""The HTML report: structure, every number traced to its results file, drift
between results files stops the build, missing experiments are named.

The page is built from the committed `results/` (read only; a few seconds).
Numbers are checked with a JSON-pointer resolver written here, independent of
the one in `bandopt.report`.
"""

import base64
import csv
import json
import math
import re
import shutil
from html.parser import HTMLParser
from pathlib import Path

import pytest

from bandopt.cli import main
from bandopt.report import (
    MAX_BYTES,
    SECTIONS,
    ReportDriftError,
    build_report,
    consistency_messages,
)


RESULTS = Path(__file__).resolve().parents[1] / "results"


class _Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.sections, self.nums, self.imgs, self.tables = [], [], [], []
        self._rows = None
        self._in_body = False
        self.missing_boxes = 0

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "section":
            self.sections.append(a.get("id"))
        elif tag == "a" and a.get("class") == "num":
            self.nums.append(a)
        elif tag == "img":
            self.imgs.append(a)
        elif tag == "table":
            self._rows = 0
        elif tag == "tbody":
            self._in_body = True
        elif tag == "tr" and self._in_body:
            self._rows += 1
        elif tag == "div" and a.get("class") == "missing":
            self.missing_boxes += 1

    def handle_endtag(self, tag):
        if tag == "tbody":
            self._in_body = False
        elif tag == "table":
            self.tables.append(self._rows)


def _resolve(data, ptr):
    for tok in ptr.split("/")[1:]:
        tok = tok.replace("~1", "/").replace("~0", "~")
        data = data[int(tok)] if isinstance(data, list) else data[tok]
    return data


def _load(path: Path):
    if path.suffix == ".json":
        return json.loads(path.read_text())
    return list(csv.DictReader(path.read_text().splitlines()))


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    res = build_report(RESULTS, out, strict=False)
    page = _Page()
    page.feed(res.path.read_text())
    return res, page


def test_each_result_section_states_its_conditions(built):
    """Every section that shows numbers of one study opens with the scenes,
    noise, measurement effects and estimator they come from, read from that
    study's files (so two sections on different footings say so)."""
    res, _ = built
    text = res.path.read_text()
    for sid, want in (
        ("verdict", "held-out measured lamps over"),
        ("comparison", "no Moon"),
        ("band-count", "measurement effects: none"),
        ("search", "ridge surrogate"),
        ("classification", "the study's own band search"),
        ("radiometry", "lighting classes"),
        ("spatial", "sub-pixel phases per GSD"),
        ("inversion", "Moon told"),
    ):
        start = text.index(f'<section id="{sid}">')
        section = text[start : text.index("</section>", start)]
        at = section.find('<p class="conditions"><strong>Conditions.</strong>')
        assert at >= 0, sid
        assert want in section[at : section.index("</p>", at)], sid


def test_every_section_present_in_order(built):
    _, page = built
    assert page.sections == [sid for sid, _, _ in SECTIONS]


def test_page_is_readable_on_a_phone(built):
    """A viewport declaration (without it phones render a 980 px desktop page
    scaled down) and a narrow-screen layout: one-column contents, smaller
    table text; wide tables scroll inside their section."""
    res, _ = built
    text = res.path.read_text()
    head = text[: text.index("</head>")]
    viewport = '<meta name="viewport" content="width=device-width, initial-scale=1">'
    assert viewport in head
    assert "@media (max-width:700px)" in head
    assert "section{overflow-x:auto}" in head


def test_every_number_comes_from_its_file(built):
    res, page = built
    assert len(page.nums) > 300  # Table 5.1, comparison, band count, radiometry, ...
    cache = {}
    for a in page.nums:
        src = a["data-src"]
        if src not in cache:
            cache[src] = _load(RESULTS / src)
        value = _resolve(cache[src], a["data-ptr"])
        # the link goes to the same file (relative to the report)
        assert (res.path.parent / a["href"]).resolve() == (RESULTS / src).resolve()
        shown = a["data-value"]
        if value in (None, ""):
            assert shown == "None"
        elif math.isnan(float(value)):
            assert math.isnan(float(shown))
        else:
            assert float(shown) == pytest.approx(float(value), rel=1e-12), (src, a)


def test_table51_carries_every_band_and_sensor_property(built):
    res, page = built
    rec = json.loads((RESULTS / "recommendation.json").read_text())
    text = res.path.read_text()
    body = text[text.index('class="table51"') :]
    body = body[: body.index("</table>")]
    for band in rec["spectral"]["bands"]:
        assert f"<td>{band['name']}</td>" in body
    ptrs = {a["data-ptr"] for a in page.nums if a["data-src"] == "recommendation.json"}
    assert "/radiometry/bit_depth" in ptrs
    if "spatial" in rec:
        assert "/spatial/median_gsd_needed_m" in ptrs
    limits = [a for a in page.nums if a["data-src"] == "radiometry/limits.csv"]
    assert any(a["data-ptr"].endswith("/detection_limit_w_m2_sr_nm") for a in limits)
    assert any(a["data-ptr"].endswith("/snr_at_limit") for a in limits)


def test_figures_embedded_and_tables_filled(built):
    res, page = built
    assert res.bytes < MAX_BYTES
    assert len(page.imgs) >= 10
    for img in page.imgs:
        assert img["src"].startswith("data:image/png;base64,")
        raw = base64.b64decode(img["src"].split(",", 1)[1])
        assert raw[:8] == b"\x89PNG\r\n\x1a\n"
    assert page.tables and all(n > 0 for n in page.tables)
    assert "http://" not in res.path.read_text().replace("http://www.w3", "")


def test_experiment_not_run_is_named_missing(built):
    res, page = built
    if not (RESULTS / "estimate").is_dir():
        assert "estimate" in res.missing
        assert page.missing_boxes >= 1
        assert "MISSING" in res.path.read_text()


def test_committed_results_agree_with_each_other():
    """The real guard: on main, no two results files disagree. A failure names
    the stale file and the command that regenerates it."""
    assert consistency_messages(RESULTS) == []


# ----------------------------------------------------------------------------- drift
SMALL = (
    "recommendation.json",
    "README.md",
    "sections/radiometry.md",
    "sections/spatial.md",
    "sections/search.md",
    "sections/classification.md",
    "radiometry/limits.csv",
    "radiometry/summary.json",
    "spatial/summary.json",
    "search/compare.json",
    "search/recommended_bands.json",
    "search/stability.json",
    "search/tolerance.json",
    "judge/judge.json",
    "judge/recommended_bands.json",
    "robustness/summary.json",
    "spatial/overlap.json",
    "classify/summary.json",
)


@pytest.fixture()
def small(tmp_path):
    for rel in SMALL:
        if (RESULTS / rel).is_file():
            (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(RESULTS / rel, tmp_path / rel)
    assert consistency_messages(tmp_path) == consistency_messages(RESULTS)
    return tmp_path


def test_drift_in_a_csv_number_stops_the_build(small):
    path = small / "radiometry" / "limits.csv"
    rows = list(csv.DictReader(path.read_text().splitlines()))
    i = next(i for i, r in enumerate(rows) if r["band_set"] == "ours")
    rows[i]["detection_limit_w_m2_sr_nm"] = str(
        2 * float(rows[i]["detection_limit_w_m2_sr_nm"])
    )
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with pytest.raises(ReportDriftError, match=r"limits\.csv") as err:
        build_report(small, small / "out")
    assert any(rows[i]["band"] in m for m in err.value.messages)
    assert not (small / "out" / "index.html").exists()


def test_missing_gsd_and_readme_quote_stop_the_build(small):
    rec = json.loads((small / "recommendation.json").read_text())
    rec.pop("spatial", None)
    (small / "recommendation.json").write_text(json.dumps(rec))
    page = small / "sections" / "radiometry.md"
    readme = page.read_text()
    page.write_text(
        readme + "\n## Radiometry (x)\n\nDetection limits 5e-8 to 2e-7 W\n"
        if "Detection limits" not in readme
        else readme.replace("Detection limits ", "Detection limits 9", 1)
    )
    msgs = consistency_messages(small)
    assert any("no 'spatial' part" in m and "--recommend-only" in m for m in msgs)
    assert any("README.md quotes detection limits" in m for m in msgs)


def test_radiometry_of_another_band_set_is_stale(small):
    rec = json.loads((small / "recommendation.json").read_text())
    rec["spectral"]["bands"] = rec["spectral"]["bands"][1:]
    (small / "recommendation.json").write_text(json.dumps(rec))
    assert any("re-run `make radiometry`" in m for m in consistency_messages(small))


def test_cli_report_exit_codes(small, tmp_path, capsys):
    rec = json.loads((small / "recommendation.json").read_text())
    rec["spectral"]["set"] = "not-the-recommended-one"
    (small / "recommendation.json").write_text(json.dumps(rec))
    assert main(["report", "--results", str(small), "--out", str(tmp_path / "o")]) == 3
    err = capsys.readouterr().err
    assert "pareto/recommended" in err or "choice/chosen" in err


def test_empty_results_names_every_experiment_missing(tmp_path, capsys):
    (tmp_path / "res").mkdir()
    rc = main(
        [
            "report",
            "--results",
            str(tmp_path / "res"),
            "--out",
            str(tmp_path / "out"),
            "--json",
        ]
    )
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    from bandopt.report import EXPERIMENTS

    assert set(out["missing"]) == {e.key for e in EXPERIMENTS}
    page = _Page()
    page.feed((tmp_path / "out" / "index.html").read_text())
    assert page.sections == [sid for sid, _, _ in SECTIONS]
    assert page.missing_boxes >= len(EXPERIMENTS)


def test_interval_section_gives_coverage_and_width_from_the_robustness_suite(tmp_path):
    """The interval section tables coverage and median width of every band
    set's clean row and of our bands' perturbed rows, each number linked to
    its row of results/robustness/summary.json; without the suite it is
    MISSING."""
    res_dir = tmp_path / "res"
    (res_dir / "robustness").mkdir(parents=True)
    summary = json.loads((RESULTS / "robustness/summary.json").read_text())
    (res_dir / "robustness/summary.json").write_text(json.dumps(summary))
    res = build_report(res_dir, tmp_path / "out", strict=False)
    assert "robustness" not in res.missing
    text = res.path.read_text()
    start = text.index('<section id="inversion">')
    page = _Page()
    page.feed(text[start : text.index("</section>", start)])
    got = {a["data-ptr"]: a["data-value"] for a in page.nums
           if a["data-src"] == "robustness/summary.json"}  # fmt: skip
    for i, r in enumerate(summary["rows"]):
        shown = r["kind"] == "clean" or r["band_set"] == "recommended"
        for col in ("LER_covered", "CCT_covered", "G_width_median"):
            assert (f"/rows/{i}/{col}" in got) == shown, (i, col)
            if shown:
                assert float(got[f"/rows/{i}/{col}"]) == pytest.approx(r[col])
    assert "Intervals by the flag" not in text  # no manifest: not said
    for cal, words in (("flagged", "Intervals by the flag"),
                       ("classes", "held out in turn for every pixel")):  # fmt: skip
        manifest = json.loads((RESULTS / "robustness/manifest.json").read_text())
        manifest["config"]["config"]["calibration"] = cal
        (res_dir / "robustness/manifest.json").write_text(json.dumps(manifest))
        out = tmp_path / f"out-{cal}"
        assert words in build_report(res_dir, out, strict=False).path.read_text()
    (res_dir / "robustness/summary.json").unlink()
    assert "robustness" in build_report(res_dir, tmp_path / "o2", strict=False).missing


# ------------------------------------------------------------------- tolerances
_CAL = (
    ("centre_tolerance_calibrated_nm", "centre_shift_interval_calibrated_nm"),
    ("fwhm_tolerance_calibrated_factor", "fwhm_factor_interval_calibrated"),
)
_CAL_TOP = (
    "leakage_interval_calibrated",
    "meets_leakage_1pct_calibrated",
    "aoi_interval_calibrated_deg",
)


def _search_made(small):
    """The small results with the "spectral" recommendation as the search
    writes it (its own pick, with tolerances), before a judge chose: built
    from the search's files by the search's own row writer."""
    from bandopt.search._stability_study import _band_rows
    from bandopt.sensor.reference import load_band_set

    rec_path = small / "recommendation.json"
    rec = json.loads(rec_path.read_text())
    search = small / "search"
    stab = json.loads((search / "stability.json").read_text())
    tol = json.loads((search / "tolerance.json").read_text())
    bands = load_band_set(search / "recommended_bands.json")
    comp = json.loads((search / "compare.json").read_text())
    key = comp["pareto"]["recommended"]
    d = comp["designs"][key]
    rec["spectral"] = {
        "set": key,
        "bands": _band_rows(bands, stab, tol),
        "test_mae": {k: d[k] for k in ("partitions", "mae_mean", "mae_sd", "f1_mean")},
        "estimator": "the search's scorer",
    }
    rec_path.write_text(json.dumps(rec))
    shutil.rmtree(small / "judge", ignore_errors=True)
    for rel in ("robustness/summary.json", "spatial/overlap.json"):
        (small / rel).unlink(missing_ok=True)
    return rec


def test_a_judged_design_shows_its_choice_and_no_scan_of_its_own(small, tmp_path):
    """A recommendation the judge wrote: the page says it was chosen by the
    judge, links its loss and the search's pick's paired difference, marks
    its tolerances "not scanned" and ties the leakage scan to the search's
    pick."""
    rec = json.loads((small / "recommendation.json").read_text())
    if rec["spectral"].get("chosen_by") != "judge":
        pytest.skip("the committed recommendation is the search's")
    res = build_report(small, tmp_path / "out", strict=False)
    text = res.path.read_text()
    assert "Chosen by the judge" in text and "not scanned" in text
    page = _Page()
    page.feed(text)
    ptrs = {a["data-ptr"] for a in page.nums if a["data-src"] == "recommendation.json"}
    assert {"/spectral/judge/J", "/spectral/search_pick/minus_chosen/J/mean"} <= ptrs
    if (small / "search" / "tolerance.json").is_file():
        assert "Of the search's own pick" in text


def _tolerance_files(small, calibrated: bool):
    """The small results with (a made-up) or without the calibrated scan
    in both recommendation.json and search/tolerance.json."""
    rec_path = small / "recommendation.json"
    tol_path = small / "search" / "tolerance.json"
    if not tol_path.is_file():
        pytest.skip("no search/tolerance.json in results/")
    _search_made(small)
    rec, tol = json.loads(rec_path.read_text()), json.loads(tol_path.read_text())
    for b in rec["spectral"]["bands"]:
        t = tol["per_band"][b["name"]]
        for k, tk in _CAL:
            b.pop(k, None)
            t.pop(tk, None)
            if calibrated:
                b[k] = t[tk] = [-3.25, 4.75] if "centre" in k else [0.875, 1.125]
    for k in _CAL_TOP:
        tol.pop(k, None)
    if calibrated:
        tol.update(
            leakage_interval_calibrated=[0.0, 0.0375],
            meets_leakage_1pct_calibrated=True,
            aoi_interval_calibrated_deg=None,
        )  # null: nominal failed
    rec_path.write_text(json.dumps(rec))
    tol_path.write_text(json.dumps(tol))
    return rec


def test_tolerances_without_the_calibrated_scan_still_build(small, tmp_path):
    _tolerance_files(small, calibrated=False)  # the files of an older run
    assert not [m for m in consistency_messages(small) if "toleran" in m]
    res = build_report(small, tmp_path / "out", strict=False)
    text = res.path.read_text()
    assert "no calibrated scan in this run" in text
    page = _Page()
    page.feed(text)
    T = "search/tolerance.json"
    ptrs = {a["data-ptr"] for a in page.nums if a["data-src"] == T}
    assert {"/leakage_interval/0", "/aoi_interval_deg/1"} <= ptrs


def test_calibrated_tolerances_are_shown_and_checked(small, tmp_path):
    rec = _tolerance_files(small, calibrated=True)
    assert not [m for m in consistency_messages(small) if "toleran" in m]
    res = build_report(small, tmp_path / "out", strict=False)
    page = _Page()
    page.feed(res.path.read_text())
    got = {(a["data-src"], a["data-ptr"]): a["data-value"] for a in page.nums}
    assert (
        got[
            (
                "recommendation.json",
                "/spectral/bands/0/centre_tolerance_calibrated_nm/0",
            )
        ]
        == "-3.25"
    )
    assert (
        got[
            (
                "recommendation.json",
                "/spectral/bands/0/fwhm_tolerance_calibrated_factor/1",
            )
        ]
        == "1.125"
    )
    assert got[("search/tolerance.json", "/leakage_interval_calibrated/1")] == "0.0375"
    text = res.path.read_text()
    assert "no calibrated scan" not in text
    # a null interval (nominal itself failed) is shown as such, linked
    assert 'search/tolerance.json /aoi_interval_calibrated_deg">None</a>' in text
    # a calibrated tolerance that disagrees with tolerance.json is drift
    rec["spectral"]["bands"][0]["centre_tolerance_calibrated_nm"] = [-1.0, 1.0]
    (small / "recommendation.json").write_text(json.dumps(rec))
    msgs = consistency_messages(small)
    assert any("centre_tolerance_calibrated_nm" in m for m in msgs)


def test_search_solvers_and_converged_designs_are_shown(small, tmp_path):
    """The page names the solvers behind the recommendation and how many
    designs converged (per band count and for the recommended set), each
    number linked to its file; results without them say MISSING."""
    _search_made(small)  # without "search": older results
    res = build_report(small, tmp_path / "old", strict=False)
    assert "spectral/search" in res.path.read_text()  # older results: MISSING
    rec = json.loads((small / "recommendation.json").read_text())
    rec["spectral"]["search"] = {
        "global": "nlopt GN_CRS2_LM per resample",
        "local": "optimistix BFGS, rtol 1e-06",
        "designs_converged": 11,
        "designs": 12,
    }
    (small / "recommendation.json").write_text(json.dumps(rec))
    comp = json.loads((small / "search" / "compare.json").read_text())
    for d in comp["designs"].values():
        d["convergence"] = {
            "fits": {"successful": 90},
            "designs_converged": 9,
            "designs": 12,
        }
    (small / "search" / "compare.json").write_text(json.dumps(comp))
    res = build_report(small, tmp_path / "out", strict=False)
    text = res.path.read_text()
    assert "nlopt GN_CRS2_LM per resample" in text and "optimistix BFGS" in text
    page = _Page()
    page.feed(text)
    got = {(a["data-src"], a["data-ptr"]): a["data-value"] for a in page.nums}
    assert got[("recommendation.json", "/spectral/search/designs_converged")] == "11"
    assert (
        got[
            ("search/compare.json", "/designs/n5+pan a=0/convergence/designs_converged")
        ]
        == "9"
    )


def _verdict_rows(path: Path) -> dict[str, list[str]]:
    """First cell -> text cells of the verdict section's tables."""
    import re

    text = path.read_text()
    start = text.index('<section id="verdict">')
    section = text[start : text.index("</section>", start)]
    rows = {}
    for tr in re.findall(r"<tr>(.*?)</tr>", section):
        cells = [
            re.sub(r"<[^>]+>", "", c).strip() for c in re.findall(r"<td>(.*?)</td>", tr)
        ]
        if cells:
            rows[cells[0]] = cells
    return rows


def test_verdict_states_every_target_from_the_robustness_suite(tmp_path):
    """The first section gives each target its pass/fail from the shipped
    estimator's clean row (`results/robustness`) and each band's SNR verdict
    from the radiometry; moving a value across its target flips the verdict,
    and without the suite the section says what to run."""
    for rel in (
        "robustness/summary.json",
        "robustness/README.md",
        "radiometry/limits.csv",
        "radiometry/summary.json",
    ):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(RESULTS / rel, tmp_path / rel)
    summary = json.loads((RESULTS / "robustness/summary.json").read_text())
    ours = next(
        i
        for i, r in enumerate(summary["rows"])
        if r["band_set"] == "recommended" and r["perturbation"] == "clean"
    )
    res = build_report(tmp_path, tmp_path / "out", strict=False)
    assert SECTIONS[0][0] == "verdict"
    rows = _verdict_rows(res.path)
    g = rows["G index error (class-balanced MAE)"]
    assert g[1] == "≤ 0.25"
    # coverage is shown with its price, and every reference with ours minus
    # it and the 95 % interval over lamps (the suite's `versus`)
    cov = rows["90 % interval coverage, LER"]
    assert "median width" in cov[2] and "lm/W" in cov[2]
    assert all("median width" in c for c in cov[4:])
    ler = rows["LER error (class-balanced MAE)"]
    for cell in ler[4:]:
        assert re.search(r"ours − it: -?[\d.]+ \[-?[\d.]+, -?[\d.]+\]", cell), cell
    # "ahead" only where the paired interval is below 0
    ahead = next(v for k, v in rows.items() if k.startswith("our bands ahead"))
    said = dict(re.findall(r"(LER|G|CCT): (.*?)(?=; (?:LER|G|CCT):|$)", ahead[2]))
    words = {m: [] for m in ("LER", "G", "CCT")}
    for v in summary["versus"]:
        if v["perturbation"] != "clean":
            continue
        for m in words:
            lo, hi = v[f"{m}_diff_ci95"]
            if hi >= 0:  # not ahead: named with where it stands
                words[m].append(f"{'behind' if lo > 0 else 'level with'} "
                                f"{v['reference']}")  # fmt: skip
    for m, w in words.items():
        assert said[m] == ("; ".join(w) if w else "ahead of every reference")
    assert ahead[3] == ("pass" if not any(words.values()) else "fail")
    assert g[3] == ("pass" if summary["rows"][ours]["G"] <= 0.25 else "fail")
    limits = list(
        csv.DictReader((RESULTS / "radiometry/limits.csv").read_text().splitlines())
    )
    for r in limits:
        if r["band_set"] == "ours":
            want = "pass" if r["meets_snr_target"] == "True" else "fail"
            assert rows[r["band"]][2] == want

    summary["rows"][ours]["G"] = 0.26 if summary["rows"][ours]["G"] <= 0.25 else 0.2
    (tmp_path / "robustness/summary.json").write_text(json.dumps(summary))
    flipped = _verdict_rows(build_report(tmp_path, tmp_path / "o2", strict=False).path)
    assert flipped["G index error (class-balanced MAE)"][3] != g[3]

    (tmp_path / "robustness/summary.json").unlink()
    text = build_report(tmp_path, tmp_path / "o3", strict=False).path.read_text()
    start = text.index('<section id="verdict">')
    assert "make robustness" in text[start : text.index("</section>", start)]


def test_verdict_says_which_instrument_change_buys_the_snr(tmp_path):
    """The instrument changes the radiometry computes (`instrument_changes`
    from its limits) are stated under the SNR table, each knob with its value
    now and needed; a radiometry run without them is named, not skipped."""
    from bandopt.radiometry import instrument_changes
    from bandopt.sensor import SensorParams

    for rel in ("radiometry/limits.csv", "radiometry/summary.json"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(RESULTS / rel, tmp_path / rel)
    summary = json.loads((tmp_path / "radiometry/summary.json").read_text())
    ours = [
        r for r in summary["bands"] if r.get("band_set", "ours") == summary["band_set"]
    ]
    params = SensorParams(**summary["sensor_params"])
    ch = instrument_changes(
        params,
        [r["exposure_factor_for_snr_target"] for r in ours],
        [r["band"] for r in ours],
    )
    summary["instrument_changes"] = ch
    (tmp_path / "radiometry/summary.json").write_text(json.dumps(summary))
    text = build_report(tmp_path, tmp_path / "out", strict=False).path.read_text()
    start = text.index('<section id="verdict">')
    section = text[start : text.index("</section>", start)]
    if ch["met"]:
        assert "reaches the SNR target in every band" in section
    else:
        assert "What buys the SNR target" in section
        page = _Page()
        page.feed(section)
        got = {
            a["data-ptr"]
            for a in page.nums
            if a["data-src"] == "radiometry/summary.json"
        }
        for knob, c in ch["changes"].items():
            assert f"/instrument_changes/changes/{knob}/now" in got
            assert (
                c["needed"] is None
            ) or f"/instrument_changes/changes/{knob}/needed" in got
    del summary["instrument_changes"]
    (tmp_path / "radiometry/summary.json").write_text(json.dumps(summary))
    text = build_report(tmp_path, tmp_path / "o2", strict=False).path.read_text()
    assert "instrument changes in <code>results/radiometry/summary.json" in text


def test_every_results_folder_is_shown_or_listed_as_not_part_of_it(built):
    """A reader can tell a result the report leaves out from one that does
    not exist: each folder of results/ either gives the page a number, table
    or figure, or is named in the header's list of folders not shown."""
    res, _ = built
    text = res.path.read_text()
    shown = {Path(rel).parts[0] for rel in res.sources}
    note_at = text.index("Results not part of this report")
    note = text[note_at : text.index("</p>", note_at)]
    folders = [p.name for p in RESULTS.iterdir() if p.is_dir() and p.name != "report"]
    for name in folders:
        assert (name in shown) != (f"<code>{name}/</code>" in note), name
    assert f"({len([n for n in folders if n not in shown])} folders;" in note


def test_spatial_section_adds_the_full_moon_run_when_there_is_one(tmp_path):
    """The GSD table under a full Moon follows the moonless one, with its own
    conditions line (naming the Moon); without that run the section says how
    to make it."""
    for rel in ("spatial/summary.json",):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(RESULTS / rel, tmp_path / rel)

    def section():
        text = build_report(tmp_path, tmp_path / "out", strict=False).path.read_text()
        start = text.index('<section id="spatial">')
        return text[start : text.index("</section>", start)]

    assert "--moon full" in section()
    summary = json.loads((RESULTS / "spatial/summary.json").read_text())
    summary["config"]["moon"] = "full"
    (tmp_path / "spatial/full_moon").mkdir()
    (tmp_path / "spatial/full_moon/summary.json").write_text(json.dumps(summary))
    got = section()
    assert "The same scenes under a full Moon" in got
    assert "Moon full" in got and "--moon full" not in got


def test_verdict_states_the_gsd_from_the_spatial_study(tmp_path):
    """The verdict gives the GSD study's median coarsest GSD, its rule and the
    scenes where it fails, from key "spatial" of recommendation.json; without
    that key it says to run the study."""
    rec = json.loads((RESULTS / "recommendation.json").read_text())
    sp = rec["spatial"]

    def verdict():
        text = build_report(tmp_path, tmp_path / "out", strict=False).path.read_text()
        start = text.index('<section id="verdict">')
        return text[start : text.index("</section>", start)]

    (tmp_path / "recommendation.json").write_text(json.dumps(rec))
    got = verdict()
    assert "Ground sample distance: median" in got
    median = sp["median_gsd_needed_m"]
    assert median is None or f'data-value="{median}"' in got
    for scene in sp["scenes_never_detected"]:
        assert scene in got
    del rec["spatial"]
    (tmp_path / "recommendation.json").write_text(json.dumps(rec))
    assert "make spatial" in verdict()


def test_design_labels_read_as_plain_words_on_the_page(built):
    """A search design shows as "3 bands + pan (α = 0.5)", its label kept as
    the hover title; no bare internal label ("n3+pan a=0.5") is left in the
    page's visible text, and α is explained where designs are named."""
    import html
    import re

    from bandopt.report._html import design_name

    assert design_name("n3+pan a=0.5") == (
        '<span title="n3+pan a=0.5">3 bands + pan (α = 0.5)</span>'
    )
    assert "1 band + pan (α = 0)" in design_name("n1+pan a=0")
    assert design_name("nightsat") == "nightsat"
    res, _ = built
    text = res.path.read_text()
    visible = re.sub(r"<[^>]+>", " ", text)
    assert not re.findall(r"n\d\+pan a=[0-9.]+", visible)
    assert "α is the search's weight on lamp-type classification" in html.unescape(text)


def test_a_study_made_with_other_bands_than_the_recommendation_is_stale(tmp_path):
    """Robustness and spatial results record the bands they ran with; the
    consistency check names the study whose bands are not the spectral
    recommendation's, and one that records none."""
    bands = [
        {"name": "B1", "centre_nm": 450.0, "fwhm_nm": 60.0},
        {"name": "PAN", "centre_nm": 640.0, "fwhm_nm": 480.0},
    ]
    (tmp_path / "recommendation.json").write_text(
        json.dumps({"spectral": {"set": "n1+pan a=0", "bands": bands}})
    )
    (tmp_path / "robustness").mkdir()
    (tmp_path / "spatial").mkdir()
    summary = tmp_path / "robustness" / "summary.json"
    overlap = tmp_path / "spatial" / "overlap.json"
    summary.write_text(json.dumps({"bands": {"recommended": bands}}))
    overlap.write_text(json.dumps({"rows": []}))

    def stale():
        return [
            m for m in consistency_messages(tmp_path)
            if "ran with" in m or "does not record" in m
        ]  # fmt: skip

    (msg,) = stale()
    assert "spatial/overlap.json does not record" in msg
    overlap.write_text(json.dumps({"band_definitions": bands}))
    assert stale() == []
    moved = [dict(bands[0], centre_nm=451.0), bands[1]]
    summary.write_text(json.dumps({"bands": {"recommended": moved}}))
    (msg,) = stale()
    assert "robustness/summary.json ran with bands" in msg and "make robustness" in msg
    summary.write_text(json.dumps({"bands": {"recommended": bands}}))
    (tmp_path / "estimate_moon").mkdir()
    moon = tmp_path / "estimate_moon" / "summary.json"
    moon.write_text(json.dumps({"bands": {"recommended": moved}}))
    (msg,) = stale()
    assert "estimate_moon/summary.json ran with" in msg and "estimate-moon" in msg


def test_a_judged_design_shows_the_shipped_estimators_tolerances(small, tmp_path):
    """With the shipped estimator's tolerance scan, the judged design's
    tolerance cells and the leakage and angle-of-incidence line come from
    it, each end linked, open ends marked, failures named."""
    rec = json.loads((small / "recommendation.json").read_text())
    if rec["spectral"].get("chosen_by") != "judge":
        pytest.skip("the committed recommendation is the search's")
    name = rec["spectral"]["bands"][0]["name"]

    def scan(lo, hi, fails, open_high=False):
        return {"interval": [lo, hi], "fails_at": fails, "open_low": False,
                "open_high": open_high, "points": []}  # fmt: skip

    tol = {
        "rule": "every metric within 1.10x of nominal",
        "partitions": 4,
        "per_band": {name: {"centre_nm": scan(-5.0, 10.0, [-10.0, 20.0]),
                            "fwhm_factor": scan(0.7, 2.0, [0.5, None], True)}},
        "leakage": scan(0.0, 0.001, [None, 0.01]),
        "aoi_deg": scan(0.0, 30.0, [None, None], True),
    }  # fmt: skip
    path = small / "robustness" / "tolerance" / "tolerance.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(tol))
    text = build_report(small, tmp_path / "out", strict=False).path.read_text()
    page = _Page()
    page.feed(text)
    T = "robustness/tolerance/tolerance.json"
    got = {a["data-ptr"]: a["data-value"] for a in page.nums if a["data-src"] == T}
    assert got[f"/per_band/{name}/centre_nm/fails_at/1"] == "20.0"
    assert got[f"/per_band/{name}/fwhm_factor/interval/0"] == "0.7"
    assert got["/leakage/fails_at/1"] == "0.01"
    assert "&ge; " in text or "≥ " in text  # an open end
    assert "shipped estimator's own scan" in text


def test_classification_section_tabulates_its_own_bands_and_says_why(built):
    """The classification study's own band set is tabulated (centre and
    FWHM of each band, from its summary), named as not the recommended design
    with the reason, and the recommended design's F1 from the same study is
    beside it."""
    res, _ = built
    text = res.path.read_text()
    start = text.index('<section id="classification">')
    section = text[start : text.index("</section>", start)]
    summary = json.loads((RESULTS / "classify/summary.json").read_text())
    bands = summary["recommended"]["bands"]["band_set"]["bands"]
    assert "it is not the recommended design" in section
    for i, b in enumerate(bands):
        ptr = f"/recommended/bands/band_set/bands/{i}/fwhm_nm"
        assert f'data-ptr="{ptr}" data-value="{b["fwhm_nm"]!r}"' in section
    row = next(i for i, r in enumerate(summary["reference_sensors"])
               if r["sensor"] in ("recommended design", "spectral (issue 5)")
               and r["noise"])  # fmt: skip
    assert f'data-ptr="/reference_sensors/{row}/level2_macro_f1"' in section
