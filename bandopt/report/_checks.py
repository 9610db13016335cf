"""Cross-file consistency: the same number in two results files must agree.

Each check reads two (or more) files of `results/` that quote the same
quantity and returns one message per disagreement, naming both files and the
field. `check_consistency` runs them all; the report refuses to build when any
message comes back (`ReportDriftError`). Checks whose files are absent are
skipped here: the report names the missing experiment instead.

Tolerances: JSON against JSON must agree to 1e-9 (relative; both are written
from the same float64); CSV files carry 6 significant digits (1e-5); numbers
quoted in `results/README.md` must agree at the precision they are printed
with (the file value rounded to the quoted number of significant digits).
"""

import math
import re
import statistics

from ..results import readme_text
from ._source import ReportInputError, ReportUnreadableError, Sources


JSON_RTOL = 1e-9
CSV_RTOL = 1e-5


class ReportDriftError(ValueError):
    """Two results files disagree about the same number."""

    def __init__(self, messages: list[str]):
        self.messages = list(messages)
        super().__init__(
            "results disagree between files (regenerate the stale file from its "
            "source; the report is not built):\n  - " + "\n  - ".join(self.messages)
        )


def _close(a, b, rtol: float) -> bool:
    if a is None or b is None:
        return a is None and b is None
    a, b = float(a), float(b)
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= rtol * max(abs(a), abs(b)) + 1e-300


def _same_as_quoted(quoted: str, value: float) -> bool:
    """`value` rounded to the significant digits of `quoted` equals it."""
    q = float(quoted)
    mant = re.sub(r"[eE].*$", "", quoted).replace("-", "").replace("+", "")
    digits = len(mant.replace(".", "").lstrip("0")) or 1
    if q == 0:
        return value == 0
    v = float(f"{value:.{digits - 1}e}")
    return _close(q, v, 1e-9)


def _rec(src: Sources):
    return src.load("recommendation.json") if src.exists("recommendation.json") else {}


def check_spectral(src: Sources) -> list[str]:
    """recommendation.json "spectral" against the search files it came from."""
    rec = _rec(src).get("spectral")
    out = []
    if rec is None:
        if src.exists("search/compare.json"):
            out.append(
                "results/search/compare.json exists but recommendation.json has no "
                "'spectral' part (re-run `make run`)."
            )
        return out
    if rec.get("chosen_by") == "judge":
        return out + _check_judged(src, rec)
    if src.exists("judge/judge.json"):
        judged = src.get("judge/judge.json", "/choice/chosen")
        if judged != rec.get("set"):
            out.append(
                f"judge/judge.json chose {judged!r} but recommendation.json "
                f"spectral/set is the search's {rec.get('set')!r} (re-run "
                "`make judge ARGS=--resume`)."
            )
    if src.exists("search/compare.json"):
        chosen = src.get("search/compare.json", "/pareto/recommended")
        if rec.get("set") != chosen:
            out.append(
                f"recommendation.json spectral/set = {rec.get('set')!r} but "
                f"search/compare.json pareto/recommended = {chosen!r}."
            )
        design = src.load("search/compare.json").get("designs", {}).get(chosen, {})
        for m, v in rec.get("test_mae", {}).get("mae_mean", {}).items():
            w = design.get("mae_mean", {}).get(m)
            if not _close(v, w, JSON_RTOL):
                out.append(
                    f"recommendation.json spectral/test_mae/mae_mean/{m} = {v} but "
                    f"search/compare.json designs/{chosen}/mae_mean/{m} = {w}."
                )
    bands = rec.get("bands", [])
    if src.exists("search/recommended_bands.json"):
        ref = {b["name"]: b for b in src.get("search/recommended_bands.json", "/bands")}
        if sorted(ref) != sorted(b["name"] for b in bands):
            out.append(
                "band names differ: recommendation.json spectral "
                f"{[b['name'] for b in bands]} vs search/recommended_bands.json "
                f"{sorted(ref)}."
            )
        for b in bands:
            r = ref.get(b["name"], {})
            for k in ("centre_nm", "fwhm_nm"):
                if b["name"] in ref and not _close(b.get(k), r.get(k), JSON_RTOL):
                    out.append(
                        f"{b['name']} {k}: recommendation.json spectral "
                        f"{b.get(k)} vs search/recommended_bands.json {r.get(k)}."
                    )
    if src.exists("search/stability.json"):
        st = src.load("search/stability.json")
        if st.get("set") == rec.get("set"):
            free = [b for b in bands if b["name"] != "PAN"]
            for i, b in enumerate(free):
                for k in ("centre_interval_nm", "fwhm_interval_nm"):
                    want = (st.get(k) or [None] * len(free))[i]
                    got = b.get(k)
                    if want is None or got is None or not all(
                        _close(x, y, JSON_RTOL) for x, y in zip(got, want, strict=True)
                    ):
                        out.append(
                            f"{b['name']} {k}: recommendation.json {got} vs "
                            f"search/stability.json {want}."
                        )
        else:
            out.append(
                f"search/stability.json is for set {st.get('set')!r}, the "
                f"recommendation is {rec.get('set')!r}."
            )
    if src.exists("search/tolerance.json"):
        per = src.get("search/tolerance.json", "/per_band")
        for b in bands:
            t = per.get(b["name"])
            if t is None:
                out.append(f"search/tolerance.json has no band {b['name']}.")
                continue
            for k, tk in (
                ("centre_tolerance_nm", "centre_shift_interval_nm"),
                ("fwhm_tolerance_factor", "fwhm_factor_interval"),
                ("centre_tolerance_calibrated_nm",
                 "centre_shift_interval_calibrated_nm"),
                ("fwhm_tolerance_calibrated_factor", "fwhm_factor_interval_calibrated"),
            ):
                if "calibrated" in k and k not in b and tk not in t:
                    continue  # both written before the calibrated scan existed
                if b.get(k) != t.get(tk):
                    out.append(
                        f"{b['name']} {k}: recommendation.json {b.get(k)} vs "
                        f"search/tolerance.json per_band/{b['name']}/{tk} {t.get(tk)}."
                    )
    return out


def _check_judged(src: Sources, rec: dict) -> list[str]:
    """A "spectral" recommendation the judge wrote: its set is the judge's
    choice, its bands are that design of the search (`compare.json`) and the
    judge's `recommended_bands.json`, its loss is the judge's."""
    out = []
    key = rec.get("set")
    if not src.exists("judge/judge.json"):
        return ["recommendation.json spectral was chosen by the judge but "
                "results/judge/judge.json is missing (run `make judge`)."]
    judge = src.load("judge/judge.json")
    if judge["choice"]["chosen"] != key:
        out.append(
            f"recommendation.json spectral/set = {key!r} but judge/judge.json "
            f"choice/chosen = {judge['choice']['chosen']!r}."
        )
        return out
    j = judge["losses"][key]["J"]
    if not _close(rec.get("judge", {}).get("J"), j, JSON_RTOL):
        out.append(
            f"recommendation.json spectral/judge/J = {rec.get('judge', {}).get('J')} "
            f"but judge/judge.json losses/{key}/J = {j}."
        )
    bands = rec.get("bands", [])
    if src.exists("judge/recommended_bands.json"):
        ref = src.get("judge/recommended_bands.json", "/bands")
        if [b["name"] for b in ref] != [b["name"] for b in bands]:
            out.append("band names differ: recommendation.json spectral vs "
                       "judge/recommended_bands.json.")
        for b, r in zip(bands, ref, strict=False):
            for k in ("centre_nm", "fwhm_nm"):
                if not _close(b.get(k), r.get(k), JSON_RTOL):
                    out.append(
                        f"{b['name']} {k}: recommendation.json spectral "
                        f"{b.get(k)} vs judge/recommended_bands.json {r.get(k)}."
                    )
    if src.exists("search/compare.json"):
        design = src.load("search/compare.json").get("designs", {}).get(key)
        if design is None:
            out.append(f"search/compare.json has no design {key!r} (the judge's "
                       "choice): re-run `make judge`.")
        elif design.get("stability"):
            free = [b for b in bands if b["name"] != "PAN"]
            for k in ("centre_nm", "fwhm_nm"):
                want = design["stability"][k]
                got = [b.get(k) for b in free]
                if len(got) != len(want) or not all(
                    _close(x, y, JSON_RTOL) for x, y in zip(got, want, strict=True)
                ):
                    out.append(
                        f"recommendation.json spectral {k} {got} vs "
                        f"search/compare.json designs/{key}/stability/{k} {want}."
                    )
    return out


def check_radiometry(src: Sources) -> list[str]:
    """recommendation.json "radiometry" against limits.csv and summary.json,
    and the band set it was computed for against the spectral recommendation."""
    rec_all = _rec(src)
    rec = rec_all.get("radiometry")
    out = []
    if rec is None:
        if src.exists("radiometry/summary.json"):
            out.append(
                "results/radiometry/summary.json exists but recommendation.json has "
                "no 'radiometry' part (re-run `make radiometry`)."
            )
        return out
    label = rec.get("band_set", "ours")
    if src.exists("radiometry/limits.csv"):
        rows = {
            r["band"]: r for r in src.load("radiometry/limits.csv")
            if r.get("band_set") == label
        }
        for key, col in (
            ("detection_limit_w_m2_sr_nm", "detection_limit_w_m2_sr_nm"),
            ("saturation_w_m2_sr_nm", "saturation_w_m2_sr_nm"),
            ("snr_at_limit", "snr_at_limit"),
        ):
            for band, v in rec.get(key, {}).items():
                row = rows.get(band)
                if row is None:
                    out.append(
                        f"radiometry band {band}: in recommendation.json, not in "
                        f"radiometry/limits.csv (band_set {label})."
                    )
                    continue
                if not _close(v, float(row[col]), CSV_RTOL):
                    out.append(
                        f"radiometry {band} {key}: recommendation.json {v:.6g} vs "
                        f"radiometry/limits.csv {row[col]}."
                    )
        extra = sorted(set(rows) - set(rec.get("detection_limit_w_m2_sr_nm", {})))
        if extra:
            out.append(
                f"radiometry/limits.csv bands {extra} ({label}) are not in "
                "recommendation.json radiometry."
            )
    if src.exists("radiometry/summary.json"):
        bits = (src.get("radiometry/summary.json", "/bit_depth") or {}).get(
            "recommended_linear_bits"
        )
        if rec.get("bit_depth") != bits:
            out.append(
                f"radiometry bit depth: recommendation.json {rec.get('bit_depth')} vs "
                f"radiometry/summary.json bit_depth/recommended_linear_bits {bits}."
            )
    spectral = rec_all.get("spectral")
    if spectral is not None and label == "ours":
        names = [b["name"] for b in spectral.get("bands", [])]
        got = list(rec.get("detection_limit_w_m2_sr_nm", {}))
        if sorted(names) != sorted(got):
            out.append(
                f"radiometry was computed for bands {got}, the spectral "
                f"recommendation has {names}: results/radiometry is stale "
                "(re-run `make radiometry`)."
            )
        for b in rec.get("bands", []) or []:
            s = next((x for x in spectral["bands"] if x["name"] == b["name"]), None)
            if s is not None and not (
                _close(b["centre_nm"], s["centre_nm"], JSON_RTOL)
                and _close(b["fwhm_nm"], s["fwhm_nm"], JSON_RTOL)
            ):
                out.append(
                    f"radiometry band {b['name']} was {b['centre_nm']:.1f}/"
                    f"{b['fwhm_nm']:.1f} nm, the spectral recommendation has "
                    f"{s['centre_nm']:.1f}/{s['fwhm_nm']:.1f} nm: re-run "
                    "`make radiometry`."
                )
    return out


def spatial_median(summary: dict) -> float | None:
    """Median of the coarsest working GSD over the row and arrangement
    scenes of `results/spatial/summary.json` (the rule of
    `experiments.spatial`)."""
    arr = summary.get("config", {}).get("arrangements", [])
    per = {k: v.get("coarsest_gsd_m") for k, v in summary["gsd_needed_m"].items()}
    found = [
        v for k, v in per.items()
        if (k in arr or k.startswith("row-")) and v is not None
    ]
    return statistics.median(found) if found else None


def check_spatial(src: Sources) -> list[str]:
    """recommendation.json "spatial" (the GSD) against spatial/summary.json."""
    out = []
    if not src.exists("spatial/summary.json"):
        return out
    rec = _rec(src).get("spatial")
    if rec is None:
        return [
            "results/spatial/summary.json exists but recommendation.json has no "
            "'spatial' part (no GSD): regenerate it with "
            "`python -m experiments.spatial --recommend-only`."
        ]
    summary = src.load("spatial/summary.json")
    want = spatial_median(summary)
    if not _close(rec.get("median_gsd_needed_m"), want, JSON_RTOL):
        out.append(
            f"GSD: recommendation.json spatial/median_gsd_needed_m "
            f"{rec.get('median_gsd_needed_m')} vs {want} from "
            "spatial/summary.json gsd_needed_m."
        )
    for k, v in summary["gsd_needed_m"].items():
        got = rec.get("gsd_needed_m_per_scene", {}).get(k, "absent")
        if got != v.get("coarsest_gsd_m"):
            out.append(
                f"GSD of scene {k}: recommendation.json {got} vs "
                f"spatial/summary.json {v.get('coarsest_gsd_m')}."
            )
    return out


OUR_BANDS_USED = (
    ("robustness/summary.json", "bands", "recommended", "make robustness"),
    ("spatial/summary.json", "bands", None, "make spatial"),
    ("spatial/overlap.json", "band_definitions", None, "make spatial"),
    ("spatial/full_moon/summary.json", "bands", None,
     "python -m experiments.spatial --moon full --out results/spatial/full_moon"),
    ("robustness/tolerance/summary.json", "bands", "recommended",
     'make robustness ARGS="--config tolerance"'),
    ("estimate_moon/summary.json", "bands", "recommended", "make estimate-moon"),
    ("estimate_defaults/summary.json", "bands", "recommended",
     "make study NAME=estimate-defaults ARGS=--resume"),
)
"""Results made with our bands, where each records them (file, field, key
within it or None) and what re-makes it."""


def check_study_bands(src: Sources) -> list[str]:
    """Each study in `OUR_BANDS_USED` ran with the spectral recommendation's
    bands (names, centres and FWHMs), else it is stale."""
    spectral = _rec(src).get("spectral")
    if spectral is None:
        return []
    want = spectral.get("bands", [])
    out = []
    for path, field, key, make in OUR_BANDS_USED:
        if not src.exists(path):
            continue
        got = src.load(path).get(field)
        if isinstance(got, dict):
            got = got.get(key)
        if not isinstance(got, list):
            out.append(
                f"results/{path} does not record the bands it ran with ({field}"
                + (f"/{key}" if key else "") + f"): re-run `{make}`."
            )
            continue
        same = [b.get("name") for b in got] == [b.get("name") for b in want] and all(
            _close(g.get(k), w.get(k), JSON_RTOL)
            for g, w in zip(got, want, strict=True)
            for k in ("centre_nm", "fwhm_nm")
        )
        if not same:
            out.append(
                f"results/{path} ran with bands "
                f"{[(b.get('name'), b.get('centre_nm')) for b in got]}, not the "
                f"spectral recommendation {spectral.get('set')!r}: re-run `{make}`."
            )
    return out


def check_classification(src: Sources) -> list[str]:
    """recommendation.json "classification" against classify/summary.json."""
    rec = _rec(src).get("classification")
    if not src.exists("classify/summary.json"):
        return []
    if rec is None:
        return [
            "results/classify/summary.json exists but recommendation.json has no "
            "'classification' part (re-run `make classify`)."
        ]
    want = src.get("classify/summary.json", "/recommended/bands")
    out = []
    for k in ("centre_nm", "fwhm_nm"):
        a, b = rec.get(k, []), want.get(k, [])
        if len(a) != len(b) or not all(
            _close(x, y, JSON_RTOL) for x, y in zip(a, b, strict=True)
        ):
            out.append(f"classification {k}: recommendation.json {a} vs "
                       f"classify/summary.json recommended/bands/{k} {b}.")
    for k in ("level2_macro_f1_nested", "level2_macro_f1_recommended_set"):
        if not _close(rec.get(k), want.get(k), JSON_RTOL):
            out.append(f"classification {k}: recommendation.json {rec.get(k)} vs "
                       f"classify/summary.json {want.get(k)}.")
    return out


def _readme_section(text: str, title_start: str) -> str:
    """The README text from the heading starting with `title_start` to the
    next `## ` heading."""
    m = re.search(
        rf"^## {re.escape(title_start)}.*?(?=^## |\Z)", text, re.M | re.S
    )
    return m.group(0) if m else ""


_NUM = r"([0-9]+(?:\.[0-9]+)?(?:e[-+]?[0-9]+)?)"


def check_readme(src: Sources) -> list[str]:
    """Numbers quoted in results/README.md against the files they quote."""
    path = src.path("README.md")
    if not path.is_file():
        return []
    text = readme_text(path.parent)
    out = []
    rad = _readme_section(text, "Radiometry")
    if rad and src.exists("radiometry/limits.csv"):
        rows = [r for r in src.load("radiometry/limits.csv") if r["band_set"] == "ours"]
        for label, col, pat in (
            ("detection limits", "detection_limit_w_m2_sr_nm",
             rf"[Dd]etection limits {_NUM} to {_NUM}"),
            ("saturation", "saturation_w_m2_sr_nm", rf"saturation {_NUM} to {_NUM}"),
        ):
            m = re.search(pat, rad)
            if m is None or not rows:
                continue
            vals = [float(r[col]) for r in rows]
            lo, hi = min(vals), max(vals)
            same = _same_as_quoted(m.group(1), lo) and _same_as_quoted(m.group(2), hi)
            if not same:
                out.append(
                    f"results/README.md quotes {label} {m.group(1)} to {m.group(2)}; "
                    f"results/radiometry/limits.csv (ours) holds {lo:.2g} to {hi:.2g}."
                )
        m = re.search(r"linear bit depth\s+needed:\s+(\d+) bits", rad)
        if m and src.exists("radiometry/summary.json"):
            bits = (src.get("radiometry/summary.json", "/bit_depth") or {}).get(
                "recommended_linear_bits"
            )
            if int(m.group(1)) != bits:
                out.append(
                    f"results/README.md quotes a linear bit depth of {m.group(1)}; "
                    f"results/radiometry/summary.json has {bits}."
                )
    spa = _readme_section(text, "Spatial")
    m = re.search(rf"median GSD needed to detect single lamps {_NUM} m", spa)
    if m and src.exists("spatial/summary.json"):
        want = spatial_median(src.load("spatial/summary.json"))
        if want is None or not _same_as_quoted(m.group(1), want):
            out.append(
                f"results/README.md quotes a median GSD of {m.group(1)} m; "
                f"results/spatial/summary.json gives {want} m."
            )
    srch = _readme_section(text, "Spectral band search")
    if srch and src.exists("search/compare.json"):
        m = re.search(r"Recommended: \*\*(.+?)\*\*", srch)
        chosen = src.get("search/compare.json", "/pareto/recommended")
        if m and m.group(1) != chosen:
            out.append(
                f"results/README.md recommends {m.group(1)!r}; "
                f"results/search/compare.json pareto/recommended is {chosen!r}."
            )
        if src.exists("search/stability.json"):
            st = src.load("search/stability.json")
            for m in re.finditer(
                rf"B(\d): {_NUM} nm \[{_NUM}, {_NUM}\], FWHM {_NUM} nm", srch
            ):
                i = int(m.group(1)) - 1
                if i >= len(st["centre_nm"]):
                    out.append(f"results/README.md quotes B{i + 1}, "
                               "search/stability.json has fewer bands.")
                    continue
                pairs = (
                    (m.group(2), st["centre_nm"][i]),
                    (m.group(3), st["centre_interval_nm"][i][0]),
                    (m.group(4), st["centre_interval_nm"][i][1]),
                    (m.group(5), st["fwhm_nm"][i]),
                )
                if not all(abs(float(q) - v) <= 0.5 + 1e-9 for q, v in pairs):
                    out.append(
                        f"results/README.md band B{i + 1} "
                        f"({m.group(0)}) differs from search/stability.json."
                    )
    cls = _readme_section(text, "Classification")
    m = re.search(rf"{_NUM}((?: / {_NUM})+) for (\d)-(\d) bands", cls)
    if m and src.exists("classify/summary.json"):
        quoted = [m.group(1), *re.findall(_NUM, m.group(2))]
        n0 = int(m.group(len(m.groups()) - 1))
        by_n = {
            r["n_bands"]: r["level2_macro_f1"]
            for r in src.get("classify/summary.json", "/band_count")
            if r.get("method") == "nlopt"
        }
        for k, q in enumerate(quoted):
            v = by_n.get(n0 + k)
            if v is None or not _same_as_quoted(q, v):
                out.append(
                    f"results/README.md quotes level-2 F1 {q} for {n0 + k} bands; "
                    f"results/classify/summary.json has {v}."
                )
    return out


CHECKS = (
    check_spectral,
    check_radiometry,
    check_spatial,
    check_study_bands,
    check_classification,
    check_readme,
)


def check_consistency(src: Sources) -> list[str]:
    """Every disagreement between results files (empty when consistent)."""
    out = []
    for check in CHECKS:
        try:
            out += check(src)
        except ReportUnreadableError:
            raise  # a file that cannot be read: named, not a disagreement
        except (KeyError, TypeError, ReportInputError) as err:
            out.append(f"{check.__name__}: a results file lacks a field ({err!r}).")
    return out
