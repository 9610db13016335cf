"""The report's sections, each built only from files of `results/`.

A section whose experiment has not been run says so in a MISSING box (and the
experiment is listed at the top of the report); nothing is skipped silently.
"""

import dataclasses
import html

from ._html import esc, figure_png, table
from ._source import Sources, fmt_number, missing_box, pointer


@dataclasses.dataclass(frozen=True)
class Experiment:
    """One experiment whose output the report reads."""

    key: str
    title: str
    marker: str  # a file (or folder, ending in "/") whose presence means "run"
    command: str


EXPERIMENTS = (
    Experiment("search", "Spectral band search (stability study)",
               "search/compare.json", "make run"),
    Experiment("classify", "Lamp-type classification", "classify/summary.json",
               "make classify"),
    Experiment("radiometry", "Radiometric sampling", "radiometry/summary.json",
               "make radiometry"),
    Experiment("spatial", "Spatial sampling (GSD)", "spatial/summary.json",
               "make spatial"),
    Experiment("overlap", "Overlapping lamp types", "spatial/overlap.json",
               "make spatial"),
    Experiment("estimate", "Inversion estimator: interval coverage", "estimate/",
               "the inversion experiment of issue 12 (writes results/estimate/)"),
    Experiment("library", "Lamp library and NIR-extension validation",
               "library/nir_validation.json", "python -m experiments.lamp_library"),
    Experiment("noise_aware", "Noise-aware bands", "noise_aware/noise_aware.json",
               "make noise-aware"),
    Experiment("bench", "Benchmarks", "bench/search.json", "make bench"),
)
BY_KEY = {e.key: e for e in EXPERIMENTS}
METRICS = ("LER", "G", "CCT")
UNITS = {"LER": "lm/W", "G": "", "CCT": "K"}


class Ctx:
    """Sources plus the list of experiments found missing while building."""

    def __init__(self, src: Sources):
        self.src = src
        self.missing: list[str] = []
        self.stale: dict[str, list[str]] = {}

    def ran(self, key: str) -> bool:
        e = BY_KEY[key]
        if e.marker.endswith("/"):
            folder = self.src.path(e.marker)
            return folder.is_dir() and any(folder.glob("*.json"))
        return self.src.exists(e.marker)

    def need(self, key: str) -> str | None:
        """None when experiment `key` ran, else its MISSING box (recorded)."""
        if self.ran(key):
            return None
        e = BY_KEY[key]
        if key not in self.missing:
            self.missing.append(key)
        return missing_box(
            f"{esc(e.title)} (no <code>results/{esc(e.marker)}</code>)",
            f"not run yet; produce it with <code>{esc(e.command)}</code>",
        )


# -----------------------------------------------------------------------------
def experiments_status(ctx: Ctx) -> str:
    src = ctx.src
    rows = []
    for e in EXPERIMENTS:
        ran = ctx.ran(e.key)
        if not ran and e.key not in ctx.missing:
            ctx.missing.append(e.key)
        folder = e.marker.split("/")[0] + "/"
        man = folder + "manifest.json"
        when = src.text(man, "/created_utc") if src.exists(man) else "no manifest"
        commit = (
            src.text(man, "/git_commit") if src.exists(man) else ""
        )
        rows.append([
            esc(e.title),
            '<span class="ok">run</span>' if ran else "<strong>MISSING</strong>",
            src.link(e.marker) if ran and not e.marker.endswith("/")
            else f"<code>results/{esc(e.marker)}</code>",
            f"<code>{esc(e.command)}</code>",
            when,
            commit,
        ])
    return table(
        ["experiment", "status", "result", "command", "run at (UTC)", "git commit"],
        rows,
    )


def _interval_or_none(src: Sources, rel: str, ptr: str, digits: int) -> str:
    """`src.interval`, or a linked "none" when the file holds null (no
    deviation tolerated, not even the nominal)."""
    if src.get(rel, ptr) is None:
        return src.text(rel, ptr)
    return src.interval(rel, ptr, digits=digits)


def _tolerance_cell(src: Sources, rel: str, p: str, stem: str, unit: str, *,
                    digits: int) -> str:
    """A band's tolerance `<stem>_<unit>` with the estimator fitted to the
    nominal bands, then `<stem>_calibrated_<unit>` (estimator coefficients
    refitted on the as-built responses) when the recommendation has it (runs before the
    calibrated scan do not)."""
    cell = _interval_or_none(src, rel, f"{p}/{stem}_{unit}", digits)
    band = src.get(rel, p)
    if f"{stem}_calibrated_{unit}" in band:
        cal = _interval_or_none(src, rel, f"{p}/{stem}_calibrated_{unit}", digits)
        cell += f"; calibrated {cal}"
    return cell


def _leakage_and_aoi(src: Sources) -> str:
    """Leakage and angle-of-incidence tolerances of search/tolerance.json,
    uncalibrated and (when the file has them: runs before the calibrated scan
    do not) calibrated; empty without the file."""
    T = "search/tolerance.json"
    if not src.exists(T):
        return ""
    tol = src.load(T)

    def met(key):
        return " (1 % met: " + src.text(T, "/" + key) + ")"

    leak = "out-of-band leakage " + _interval_or_none(src, T, "/leakage_interval", 3)
    leak += met("meets_leakage_1pct")
    aoi = "angle of incidence " + _interval_or_none(src, T, "/aoi_interval_deg", 3)
    aoi += " deg"
    if "leakage_interval_calibrated" in tol:
        leak += "; calibrated " + _interval_or_none(
            src, T, "/leakage_interval_calibrated", 3
        ) + met("meets_leakage_1pct_calibrated")
        aoi += "; calibrated " + _interval_or_none(
            src, T, "/aoi_interval_calibrated_deg", 3
        ) + " deg"
    else:
        leak += " (no calibrated scan in this run)"
    return (
        "<p>Tolerated deviations of all bands at once (errors within 10 %; "
        "calibrated: estimator coefficients refitted on the as-built "
        "responses, hyper-parameters of the nominal fit): "
        + leak + "; " + aoi + ".</p>"
    )


def recommended_sensor(ctx: Ctx) -> str:
    """The Table 5.1 of the thesis: bands with intervals, radiometry, GSD."""
    src = ctx.src
    if not src.exists("recommendation.json"):
        return missing_box("<code>results/recommendation.json</code>",
                           "no experiment has written a recommendation yet")
    rec = src.load("recommendation.json")
    parts = []
    box = ctx.need("search")
    if "spectral" not in rec:
        return (box or "") + missing_box(
            "the spectral recommendation (key 'spectral')", "run <code>make run</code>"
        )
    R = "recommendation.json"
    spectral = rec["spectral"]
    parts.append(
        "<p>Recommended design: <strong>" + src.text(R, "/spectral/set")
        + "</strong>, judged with the " + esc(spectral.get("estimator", "?"))
        + ". Intervals in brackets: " + esc(spectral.get("intervals", ""))
        + "; tolerances: " + esc(spectral.get("tolerances", "")) + ".</p>"
    )
    search = spectral.get("search")
    if search is None:
        parts.append(missing_box(
            "the search solvers and their convergence (key 'spectral/search')",
            "run <code>make run</code>"))
    else:
        parts.append(
            "<p>Search: " + esc(search["global"]) + "; " + esc(search["local"])
            + ". Designs of the recommended set whose local fit converged: "
            + src.num(R, "/spectral/search/designs_converged") + " of "
            + src.num(R, "/spectral/search/designs") + ".</p>"
        )
    rad = rec.get("radiometry")
    lim_rows = {}
    if rad is not None and src.exists("radiometry/limits.csv"):
        for i, r in enumerate(src.load("radiometry/limits.csv")):
            if r["band_set"] == rad.get("band_set", "ours"):
                lim_rows[r["band"]] = i
    rows = []
    for i, b in enumerate(spectral["bands"]):
        p = pointer("spectral", "bands", i)
        name = b["name"]
        cells = [
            esc(name),
            src.num(R, p + "/centre_nm", digits=4),
            src.interval(R, p + "/centre_interval_nm", digits=4),
            _tolerance_cell(src, R, p, "centre_tolerance", "nm", digits=2),
            src.num(R, p + "/fwhm_nm", digits=3),
            src.interval(R, p + "/fwhm_interval_nm", digits=3),
            _tolerance_cell(src, R, p, "fwhm_tolerance", "factor", digits=3),
        ]
        if name in lim_rows:
            rp = f"/{lim_rows[name]}"
            L = "radiometry/limits.csv"
            cells += [
                src.num(L, rp + "/detection_limit_w_m2_sr_nm"),
                src.num(L, rp + "/saturation_w_m2_sr_nm"),
                src.num(L, rp + "/snr_at_limit", digits=2),
                esc(src.get(L, rp + "/limited_by")),
            ]
        else:
            cells += ["<strong>MISSING</strong>"] * 4
        rows.append(cells)
    parts.append(table(
        ["band", "centre [nm]", "centre interval [nm]", "centre tolerance [nm]",
         "FWHM [nm]", "FWHM interval [nm]", "FWHM tolerance [factor]",
         "detection limit [W m-2 sr-1 nm-1]", "saturation [W m-2 sr-1 nm-1]",
         "SNR at limit", "limit set by"],
        rows, caption="Recommended sensor (cf. thesis Table 5.1)", cls="table51",
    ))
    parts.append(_leakage_and_aoi(src))
    sensor = []
    if rad is None:
        parts.append(ctx.need("radiometry") or missing_box(
            "the radiometry part of recommendation.json", "run make radiometry"))
    else:
        sensor.append(["bit depth, linear [bit]", src.num(R, "/radiometry/bit_depth")])
        if "bit_depth_companded" in rad:
            sensor.append([
                "bit depth, companded (" + esc(rad.get("companding", "")) + ") [bit]",
                src.num(R, "/radiometry/bit_depth_companded"),
            ])
        else:
            sensor.append(["bit depth, companded [bit]",
                           "<strong>MISSING</strong> (not in recommendation.json "
                           "radiometry: re-run <code>make radiometry</code>)"])
        sensor.append(["linear bits for a step below the noise at the limit [bit]",
                       src.num(R, "/radiometry/bits_linear_step_le_ner_at_limit")])
    spatial = rec.get("spatial")
    if spatial is None:
        sensor.append(["GSD [m]", "<strong>MISSING</strong> (no spatial part)"])
    else:
        sensor.append([
            "GSD needed, median over row and arrangement scenes [m]",
            src.num(R, "/spatial/median_gsd_needed_m"),
        ])
        sensor.append(["scenes never detected at any GSD",
                       esc(", ".join(spatial.get("scenes_never_detected", []))
                           or "none")])
    parts.append(table(["sensor property", "value"], sensor,
                       caption="Radiometric and spatial resolution"))
    if rad is not None:
        parts.append(
            f'<p class="note">Bit depth rule: {esc(rad.get("bit_depth_rule", ""))}. '
            f'Limit rule: see {src.link("radiometry/summary.json")}.</p>'
        )
    if spatial is not None:
        parts.append(f'<p class="note">GSD rule: {esc(spatial.get("rule", ""))}; '
                     f'thesis: {esc(spatial.get("thesis", ""))}.</p>')
    tm = spectral.get("test_mae")
    if tm:
        parts.append(
            "<p>Outer-test errors of the recommended design (mean over "
            + src.num(R, "/spectral/test_mae/partitions") + " lamp partitions): "
            + ", ".join(
                f"{m} {src.num(R, pointer('spectral', 'test_mae', 'mae_mean', m))}"
                " &plusmn; "
                + src.num(R, pointer("spectral", "test_mae", "mae_sd", m), digits=2)
                + f" {UNITS[m]}"
                for m in METRICS
            )
            + "; level-2 macro F1 " + src.num(R, "/spectral/test_mae/f1_mean", digits=2)
            + ".</p>"
        )
    return "".join(parts)


def comparison(ctx: Ctx) -> str:
    src = ctx.src
    box = ctx.need("search")
    if box:
        return box
    C = "search/compare.json"
    comp = src.load(C)
    ours = comp["pareto"]["recommended"]
    rows = []

    def mae_cells(kind, name):
        cells = []
        for m in METRICS:
            base = pointer(kind, name)
            cells.append(
                src.num(C, base + f"/mae_mean/{m}")
                + " &plusmn; " + src.num(C, base + f"/mae_sd/{m}", digits=2)
            )
        return cells

    rows.append([
        f"<strong>{esc(ours)}</strong> (ours)",
        src.num(C, pointer("designs", ours, "n_bands")) + " + pan",
        *mae_cells("designs", ours),
        src.num(C, pointer("designs", ours, "f1_mean"), digits=2),
        "", "", "",
    ])
    for name in comp["references"]:
        red = []
        for m in METRICS:
            p = pointer("reductions", name, "recommended", m)
            red.append(
                src.num(C, p + "/reduction", digits=2, scale=100.0, suffix=" %")
                + " " + src.interval(C, p + "/ci95", digits=2, scale=100.0)
            )
        rows.append([
            esc(name), src.num(C, pointer("references", name, "n_bands")),
            *mae_cells("references", name),
            src.num(C, pointer("references", name, "f1_mean"), digits=2),
            *red,
        ])
    out = [
        "<p>Every reference sensor is scored with the same estimator on the same "
        f"lamp partitions ({src.text(C, '/estimator/note')}). Errors: mean &plusmn; "
        "SD over partitions of the class-balanced outer-test MAE. Reductions: "
        f"{src.text(C, '/reductions/note')} (recommended design vs the sensor, 95 % "
        "CI in brackets).</p>",
        table(
            ["sensor", "bands", "LER MAE [lm/W]", "G MAE", "CCT MAE [K]",
             "level-2 macro F1", "LER reduction", "G reduction", "CCT reduction"],
            rows, caption="Comparison with every reference sensor",
        ),
    ]
    if ctx.ran("classify"):
        K = "classify/summary.json"
        refs = src.load(K)["reference_sensors"]
        crow = [
            [esc(r["sensor"]), src.num(K, f"/reference_sensors/{i}/n_bands"),
             src.num(K, f"/reference_sensors/{i}/level2_macro_f1", digits=2),
             src.num(K, f"/reference_sensors/{i}/level1_macro_f1", digits=2)]
            for i, r in enumerate(refs) if r.get("noise")
        ]
        out.append(table(
            ["sensor", "bands", "level-2 macro F1", "level-1 macro F1"], crow,
            caption="Classification of the reference sensors (classification "
            "experiment, photon noise)",
        ))
        out.append(src.image("classify/reference_sensors.png",
                             "Reference sensors: classification F1"))
    else:
        out.append(ctx.need("classify"))
    return "".join(out)


def _converged_cell(src: Sources, rel: str, ptr: str) -> str:
    """`k / R` designs (best fit per resample) whose local fit converged, or
    MISSING for results written before fits recorded their outcome."""
    conv = src.get(rel, ptr).get("convergence")
    if conv is None:
        return "<strong>MISSING</strong> (re-run <code>make run</code>)"
    return (src.num(rel, ptr + "/convergence/designs_converged") + " / "
            + src.num(rel, ptr + "/convergence/designs"))


def band_count(ctx: Ctx) -> str:
    src = ctx.src
    box = ctx.need("search")
    if box:
        return box
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    C = "search/compare.json"
    comp = src.load(C)
    bc = comp["band_count"]
    ns = sorted(int(n) for n in bc["mean"])
    rows = []
    for n in ns:
        d = f"n{n}+pan a=0"
        rows.append([
            str(n) + " + pan",
            src.num(C, pointer("band_count", "mean", str(n)))
            + " &plusmn; " + src.num(C, pointer("band_count", "sd", str(n)), digits=2),
            *[
                src.num(C, pointer("designs", d, "mae_mean", m))
                + " &plusmn; "
                + src.num(C, pointer("designs", d, "mae_sd", m), digits=2)
                for m in METRICS
            ],
            src.num(C, pointer("designs", d, "f1_mean"), digits=2),
            _converged_cell(src, C, pointer("designs", d)),
        ])
    fig, axes = plt.subplots(1, 4, figsize=(14, 3.2))
    series = [("normalised MAE", None)] + [(f"{m} MAE", m) for m in METRICS]
    for ax, (label, m) in zip(axes, series, strict=True):
        if m is None:
            y = [bc["mean"][str(n)] for n in ns]
            e = [bc["sd"][str(n)] for n in ns]
        else:
            y = [comp["designs"][f"n{n}+pan a=0"]["mae_mean"][m] for n in ns]
            e = [comp["designs"][f"n{n}+pan a=0"]["mae_sd"][m] for n in ns]
        ax.errorbar(ns, y, yerr=e, marker="o", capsize=3, label="ours (+ pan)")
        refs = comp["references"].values()
        ax.plot([r["n_bands"] for r in refs],
                [r["norm_mae_mean"] if m is None else r["mae_mean"][m] for r in refs],
                "x", color="grey", label="reference sensors")
        ax.axvline(bc["chosen_n"], color="k", ls=":", lw=1)
        ax.set_xlabel("free bands n")
        ax.set_title(label + (f" [{UNITS[m]}]" if m and UNITS[m] else ""))
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    img = figure_png(
        fig, "Outer-test error vs band count (mean +/- SD over lamp partitions, "
        "alpha = 0; grey x: reference sensors at their band count; dotted: the "
        "chosen n). Drawn from results/search/compare.json.")
    plt.close(fig)
    return (
        f"<p>Rule: {src.text(C, '/band_count/rule')}. Chosen n = "
        f"{src.num(C, '/band_count/chosen_n')} (best n = "
        f"{src.num(C, '/band_count/best_n')}).</p>"
        + table(["bands", "normalised MAE", "LER MAE [lm/W]", "G MAE", "CCT MAE [K]",
                 "level-2 F1", "designs converged"], rows,
                caption="Error vs band count (designs converged: resamples whose "
                "best local fit met optimistix's tolerances)")
        + img
    )


def search_figures(ctx: Ctx) -> str:
    src = ctx.src
    box = ctx.need("search")
    if box:
        return box
    P = "search/pareto.json"
    rows = []
    if src.exists(P):
        for name in src.load(P)["candidates"]:
            p = pointer("candidates", name)
            rows.append([
                esc(name), src.num(P, p + "/alpha", digits=2),
                src.num(P, p + "/norm_mae_mean"),
                src.num(P, p + "/f1_mean", digits=2),
                src.num(P, p + "/snr_median", digits=2),
            ])
    return (
        src.image("search/stability.png",
                  "Stability of the recommended bands over lamp resamples")
        + src.image("search/pareto.png",
                    "Pareto front: estimation error vs classification vs SNR")
        + (f"<p>Rule: {src.text(P, '/rule')}.</p>" if src.exists(P) else "")
        + table(["candidate", "alpha", "normalised MAE", "level-2 F1",
                 "median SNR at the limit"], rows, caption="Pareto candidates")
    )


def classification(ctx: Ctx) -> str:
    src = ctx.src
    box = ctx.need("classify")
    if box:
        return box
    K = "classify/summary.json"
    out = [
        "<p>The classification experiment searches its own band set (nested "
        "lamp-grouped CV); the confusion matrices are for that set (n = "
        + src.num(K, "/chosen_n_bands") + "), nested level-2 macro F1 "
        + src.num(K, "/recommended/bands/level2_macro_f1_nested", digits=2) + ".</p>"
    ]
    for level in (2, 1):
        rel = f"classify/confusion_level{level}.csv"
        if not src.exists(rel):
            out.append(missing_box(f"<code>results/{rel}</code>", "make classify"))
            continue
        data = src.load(rel)
        cols = list(data[0])
        out.append(table(
            [esc(c) for c in cols],
            [[esc(r[cols[0]])] + [src.num(rel, f"/{i}/{c}") for c in cols[1:]]
             for i, r in enumerate(data)],
            caption=f"Confusion matrix, level {level} (rows: true class; counts of "
            "scenes)",
        ))
    out.append(src.image("classify/confusion_level2.png", "Level-2 confusion matrix"))
    out.append(src.image("classify/f1_vs_band_count.png",
                         "Classification F1 vs band count"))
    return "".join(out)


def radiometry(ctx: Ctx) -> str:
    src = ctx.src
    box = ctx.need("radiometry")
    if box:
        return box
    S = "radiometry/summary.json"
    L = "radiometry/limits.csv"
    out = [f"<p>Limit rule: {src.text(S, '/rule_text')}</p>"]
    rows = []
    for i, r in enumerate(src.load(L)):
        rows.append([
            esc(r["band_set"]), esc(r["band"]),
            src.num(L, f"/{i}/detection_limit_w_m2_sr_nm"),
            src.num(L, f"/{i}/saturation_w_m2_sr_nm"),
            src.num(L, f"/{i}/snr_at_limit", digits=2),
            esc(r["limited_by"]),
        ])
    out.append(table(
        ["band set", "band", "detection limit [W m-2 sr-1 nm-1]",
         "saturation [W m-2 sr-1 nm-1]", "SNR at limit", "limit set by"],
        rows, caption="Detection limits and saturation, every band set",
    ))
    B = "radiometry/bit_depth.csv"
    if src.exists(B):
        brow = [
            [esc(r["label"]), src.num(B, f"/{i}/LER_mae"), src.num(B, f"/{i}/G_mae"),
             src.num(B, f"/{i}/CCT_mae"), src.num(B, f"/{i}/macro_f1", digits=2)]
            for i, r in enumerate(src.load(B))
        ]
        out.append(table(["quantisation", "LER MAE [lm/W]", "G MAE", "CCT MAE [K]",
                          "level-2 macro F1"], brow, caption="Bit depth"))
    out.append(src.image(
        "radiometry/histograms/ours.png",
        "Radiance histograms of the recommended bands, with detection limit, "
        "saturation, dim-scene requirement and night-sky background drawn in",
    ))
    for name in ("viirs-dnb", "sdgsat-1", "nightsat"):
        rel = f"radiometry/histograms/{name}.png"
        if src.exists(rel):
            out.append(src.image(rel, f"Radiance histograms, {name}", width="80%"))
    return "".join(out)


def spatial(ctx: Ctx) -> str:
    src = ctx.src
    box = ctx.need("spatial")
    if box:
        return box
    S = "spatial/summary.json"
    summ = src.load(S)
    gsds = [str(int(g)) if float(g).is_integer() else str(g)
            for g in summ["config"]["gsds_m"]]
    rows = []
    for name, v in summ["gsd_needed_m"].items():
        p = pointer("gsd_needed_m", name)
        rows.append(
            [esc(name)]
            + [src.num(S, p + pointer("f1_by_gsd", g), digits=2)
               if g in v["f1_by_gsd"] else "n/a" for g in gsds]
            + [src.num(S, p + "/coarsest_gsd_m") if v["coarsest_gsd_m"] is not None
               else "none"]
        )
    out = [
        f"<p>Thesis: {src.text(S, '/thesis')}. Assumptions: "
        + esc("; ".join(summ.get("assumptions", []))) + ".</p>",
        table(["scene"] + [f"F1 at {g} m" for g in gsds] + ["coarsest GSD [m]"],
              rows, caption="Single-lamp detection F1 vs GSD"),
        src.image("spatial/f1_by_gsd.png", "Detection F1 vs GSD"),
    ]
    for scene in ("single-sided", "staggered"):
        for g in ("2m", "10m"):
            rel = f"spatial/images/{scene}_gsd{g}.png"
            if src.exists(rel):
                out.append(src.image(rel, f"Rendered scene {scene} at GSD {g}",
                                     width="70%"))
    out.append(src.image("spatial/cross_section_across.png",
                         "Cross-section across the road with the DoG response",
                         width="80%"))
    return "".join(out)


def overlap(ctx: Ctx) -> str:
    src = ctx.src
    box = ctx.need("overlap")
    if box:
        return box
    O = "spatial/overlap.json"
    rows = []
    for i, _ in enumerate(src.get(O, "/rows")):
        p = f"/rows/{i}"
        rows.append([
            src.num(O, p + "/gsd_m"), src.num(O, p + "/n_lit"),
            src.num(O, p + "/mixed_fraction", digits=2),
            src.num(O, p + "/f1_pure", digits=2), src.num(O, p + "/f1_mixed", digits=2),
            src.num(O, p + "/macro_f1", digits=2),
        ])
    return (
        f"<p>Bands: {src.text(O, '/bands')}.</p>"
        + table(["GSD [m]", "lit pixels", "mixed fraction", "F1 pure pixels",
                 "F1 mixed pixels", "macro F1"], rows,
                caption="Lamp type where two types overlap (mixed-led-hps layout)")
        + src.image("spatial/overlap.png", "Lamp-type F1 with overlapping types")
    )


def _find_coverage(obj, path=()):
    """(pointer tokens, value) of every number under a key with 'coverage'."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            if "coverage" in str(k).lower() and (
                v is None or (isinstance(v, int | float) and not isinstance(v, bool))
            ):
                yield (*path, k), v  # None: not estimable, shown as n/a
            else:
                yield from _find_coverage(v, (*path, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _find_coverage(v, (*path, i))


def inversion(ctx: Ctx) -> str:
    src = ctx.src
    box = ctx.need("estimate")
    if box:
        return box
    folder = src.path("estimate")
    rows = []
    for f in sorted(folder.glob("*.json")):
        rel = f"estimate/{f.name}"
        if f.name == "manifest.json":
            continue
        for toks, _ in _find_coverage(src.load(rel)):
            rows.append([src.link(rel), esc("/".join(map(str, toks))),
                         src.num(rel, pointer(*toks), digits=3)])
    out = []
    if rows:
        out.append(table(["file", "field", "coverage"], rows,
                         caption="Interval coverage (fraction of true values "
                         "inside the stated intervals)"))
    else:
        out.append(missing_box("an interval-coverage number in results/estimate/*.json",
                               "the inversion results carry no field named "
                               "'coverage'"))
        ctx.missing.append("estimate (coverage)")
    figs = sorted(folder.glob("*.png"))
    for f in figs:
        out.append(src.image(f"estimate/{f.name}", f.stem.replace("_", " ")))
    return "".join(out)


def provenance(ctx: Ctx) -> str:
    src = ctx.src
    rows, pk_rows, data_rows = [], {}, {}
    folders = sorted({e.marker.split("/")[0] for e in EXPERIMENTS})
    lib_info = None
    for folder in folders:
        man = f"{folder}/manifest.json"
        if not src.exists(man):
            rows.append([esc(folder), "<strong>no manifest</strong>", "", "", ""])
            continue
        m = src.load(man)
        rows.append([
            esc(folder), src.text(man, "/git_commit"),
            esc(m.get("git_dirty")), src.text(man, "/created_utc"),
            esc(m.get("python", "")),
        ])
        for k, v in (m.get("packages") or {}).items():
            pk_rows.setdefault(k, {})[folder] = v
        for k, v in (m.get("data_versions") or {}).items():
            data_rows.setdefault(k, {})[folder] = v
        if m.get("lamp_library") and (
            lib_info is None or m.get("created_utc", "") > lib_info[1].get(
                "created_utc", "")
        ):
            lib_info = (man, m)
    newest = max(
        (src.load(f"{f}/manifest.json") for f in folders
         if src.exists(f"{f}/manifest.json")),
        key=lambda m: m.get("created_utc", ""), default=None,
    )
    stale = {}
    if newest is not None:
        for f in folders:
            if not src.exists(f"{f}/manifest.json"):
                continue
            dv = src.load(f"{f}/manifest.json").get("data_versions") or {}
            diff = sorted(k for k, v in (newest.get("data_versions") or {}).items()
                          if dv.get(k) != v)
            if diff:
                stale[f] = diff
    ctx.stale = stale
    for r in rows:
        folder = r[0]
        r.append(esc(", ".join(stale.get(folder, []))) or "")
    out = [
        table(["results folder", "git commit", "dirty tree", "created (UTC)", "python",
               "data sets differing from the newest result"],
              rows, caption="Which code and data made each result (a result made "
              "with other data than the newest one is older than that data: "
              "re-run it to compare like with like)"),
        table(["package"] + [esc(f) for f in folders],
              [[esc(k)] + [esc(v.get(f, "")) for f in folders]
               for k, v in sorted(pk_rows.items())],
              caption="Package versions per results folder"),
        table(["data set (content hash)"] + [esc(f) for f in folders],
              [[esc(k)] + [esc(v.get(f, "")) for f in folders]
               for k, v in sorted(data_rows.items())],
              caption="Data versions per results folder (a blank: the data set "
              "did not exist when that result was made)"),
    ]
    out.append("<h3>Modelled rather than measured inputs</h3>")
    if lib_info is None:
        out.append(missing_box("a manifest with lamp-library provenance",
                               "re-run any experiment"))
    else:
        man, m = lib_info
        lib = m["lamp_library"]
        out.append(
            f"<p>Near-infrared extension ({src.link(man)}): "
            f"{src.text(man, '/lamp_library/nir_extension')}. "
            f"{src.num(man, '/lamp_library/extended_spectra')} of "
            f"{src.num(man, '/lamp_library/spectra')} library spectra are measured "
            "only to about 780 nm and extended to 900 nm by a model; "
            f"{len(lib.get('extended_unvalidated', []))} of them belong to a "
            "technology whose extension could not be validated (no second "
            "measured lamp):</p><p><code>"
            + esc(", ".join(lib.get("extended_unvalidated", []))) + "</code></p>"
        )
        if lib.get("extended"):
            out.append("<p>Every extended lamp: <code>"
                       + esc(", ".join(lib["extended"])) + "</code></p>")
        else:
            out.append(
                '<p class="note">This manifest predates the per-lamp list of '
                "extended spectra (<code>lamp_library/extended</code>); results "
                "re-run since then record it.</p>"
            )
    if ctx.ran("library"):
        N = "library/nir_validation.json"
        rows = []
        for cls, v in src.get(N, "/per_class").items():
            p = pointer("per_class", cls)
            err = v.get("bands", {}).get("780-900", {})
            key = next((k for k in err if "median" in k), None)
            rows.append([
                esc(cls), src.num(N, p + "/lamps_validated"),
                esc(v.get("extension_validated")),
                src.num(N, p + pointer("bands", "780-900", key), digits=2)
                if key else esc(v.get("note", "n/a")),
            ])
        out.append(table(
            ["class", "lamps validated (leave-one-out)", "extension validated",
             "median |relative error| of the 780-900 nm power"],
            rows, caption="NIR extension, leave-one-out validation",
        ))
        out.append(src.image("library/nir_validation.png", "NIR extension validation",
                             width="80%"))
    else:
        out.append(ctx.need("library"))
    return "".join(out)


def consistency(ctx: Ctx, messages: list[str], checks: tuple) -> str:
    items = "".join(f"<li><code>{esc(c.__name__)}</code>: {esc(c.__doc__ or '')}"
                    "</li>" for c in checks)
    verdict = (
        '<p class="ok">All agree (0 disagreements).</p>' if not messages
        else missing_box(
            f"{len(messages)} disagreements (built without the check, for tests "
            "only)", "<ul>" + "".join(f"<li>{esc(m)}</li>" for m in messages)
            + "</ul>")
    )
    return (
        "<p>Every number quoted in two results files was compared before this "
        "report was built; a disagreement stops the build. Checks run:</p>"
        f"<ul>{items}</ul>{verdict}"
    )


def missing_summary(ctx: Ctx) -> str:
    out = ""
    if not ctx.missing:
        out += '<p class="ok">Every experiment the report reads has been run.</p>'
    else:
        out += missing_box(
            "experiments not run: " + ", ".join(
                esc(BY_KEY[k].title if k in BY_KEY else k) for k in ctx.missing),
            "each section below says what produces it",
        )
    if ctx.stale:
        out += (
            '<p class="note"><strong>Made with older data:</strong> '
            + "; ".join(f"{esc(f)} ({esc(', '.join(d))})"
                        for f, d in sorted(ctx.stale.items()))
            + ' differ from the data of the newest result (see '
            '<a href="#provenance">Provenance</a>).</p>'
        )
    return out


def fmt(v) -> str:
    return html.escape(fmt_number(v))
