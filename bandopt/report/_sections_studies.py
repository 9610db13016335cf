"""The report's sections of the studies after the band search: lamp-type
classification, radiometry, spatial sampling, overlapping lamp types and
the inversion estimator's interval coverage, each read only from its
folder of `results/` (a MISSING box when the study has not run).
"""

from . import _conditions
from ._experiments import METRICS, UNITS, Ctx, needs
from ._html import esc, table
from ._source import missing_box, pointer


@needs("classify")
def classification(ctx: Ctx) -> str:
    src = ctx.src
    K = "classify/summary.json"
    out = [
        _conditions.classification(src),
        "<p>The classification experiment searches its own band set (nested "
        "lamp-grouped CV) on the type alone, to show what a design made only "
        "for classification reaches; it is not the recommended design, which "
        "the judge chose on estimation and classification together. The "
        "confusion matrices are for that set (n = "
        + src.num(K, "/chosen_n_bands") + "), nested level-2 macro F1 "
        + src.num(K, "/recommended/bands/level2_macro_f1_nested", digits=2)
        + ". " + _recommended_design_f1(src, K) + "</p>",
        _classification_bands(src, K),
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


RECOMMENDED_ROWS = ("recommended design", "spectral (issue 5)")
"""Names of the recommended design's row among the classification study's
reference sensors (the second: files written before it was renamed)."""


def _recommended_design_f1(src, K: str) -> str:
    """The recommended design's macro F1 in the classification study (its
    photon-noise row among the reference sensors), or what to run."""
    for i, r in enumerate(src.load(K)["reference_sensors"]):
        if r["sensor"] in RECOMMENDED_ROWS and r.get("noise"):
            return (
                "The recommended design, scored the same way: level-2 macro F1 "
                + src.num(K, f"/reference_sensors/{i}/level2_macro_f1", digits=2)
                + ", level-1 "
                + src.num(K, f"/reference_sensors/{i}/level1_macro_f1", digits=2)
                + " (photon noise)."
            )
    return "The recommended design was not scored here (<code>make classify</code>)."


def _classification_bands(src, K: str) -> str:
    """The classification study's own band set, tabulated."""
    bands = src.get(K, "/recommended/bands/band_set/bands")
    rows = [
        [esc(b["name"]),
         src.num(K, f"/recommended/bands/band_set/bands/{i}/centre_nm", digits=4),
         src.num(K, f"/recommended/bands/band_set/bands/{i}/fwhm_nm", digits=3)]
        for i, b in enumerate(bands)
    ]  # fmt: skip
    return table(
        ["band", "centre [nm]", "FWHM [nm]"], rows,
        caption="The classification study's own band set (searched on the type "
        "alone; not the recommended design)",
    )  # fmt: skip


@needs("radiometry")
def radiometry(ctx: Ctx) -> str:
    src = ctx.src
    S = "radiometry/summary.json"
    L = "radiometry/limits.csv"
    out = [_conditions.radiometry(src),
           f"<p>Limit rule: {src.text(S, '/rule_text')}</p>"]
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


MOON_SPATIAL = "spatial/full_moon/summary.json"
"""The GSD study under a full Moon (`python -m experiments.spatial --moon full
--out results/spatial/full_moon`)."""


def _gsd_table(src, S: str, caption: str) -> str:
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
    return table(["scene"] + [f"F1 at {g} m" for g in gsds] + ["coarsest GSD [m]"],
                 rows, caption=caption)


@needs("spatial")
def spatial(ctx: Ctx) -> str:
    src = ctx.src
    S = "spatial/summary.json"
    summ = src.load(S)
    out = [
        _conditions.spatial(src),
        f"<p>Thesis: {src.text(S, '/thesis')}. Assumptions: "
        + esc("; ".join(summ.get("assumptions", []))) + ".</p>",
        _gsd_table(src, S, "Single-lamp detection F1 vs GSD"),
        (f"<p>Why F1 is not monotonic in GSD: {src.text(S, '/why')}</p>"
         if "why" in summ else ""),
        (_conditions.spatial(src, MOON_SPATIAL)
         + _gsd_table(src, MOON_SPATIAL, "The same scenes under a full Moon "
                      "(moonlit ground adds light and noise; the detector keeps "
                      "its false-alarm rate)")
         if src.exists(MOON_SPATIAL) else
         missing_box("the GSD study under a full Moon "
                     "(<code>results/spatial/full_moon/summary.json</code>)",
                     "python -m experiments.spatial --moon full --out "
                     "results/spatial/full_moon")),
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


@needs("overlap")
def overlap(ctx: Ctx) -> str:
    src = ctx.src
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
    classes = sorted({c for r in src.get(O, "/rows")
                      for c in r.get("n_per_class", {})})  # fmt: skip
    per_class = []
    for i, r in enumerate(src.get(O, "/rows")):
        if "n_per_class" not in r:
            continue
        cells = [src.num(O, f"/rows/{i}/gsd_m")]
        for c in classes:
            if c in r["n_per_class"]:
                cells.append(src.num(O, f"/rows/{i}/f1_per_class/{c}", digits=2)
                             + " (n = " + src.num(O, f"/rows/{i}/n_per_class/{c}")
                             + ")")  # fmt: skip
            else:
                cells.append("no pixel")
        per_class.append(cells)
    by_class = (
        table(["GSD [m]"] + [f"F1 {esc(c)} (lit pixels)" for c in classes], per_class,
              caption="Per class: F1 and the lit pixels whose dominant type it is "
              "(a class with few pixels left cannot carry a macro F1)")
        if per_class else
        missing_box("per-class counts in <code>results/spatial/overlap.json</code>",
                    "re-run <code>make spatial</code>")
    )  # fmt: skip
    return (
        f"<p>Bands: {src.text(O, '/bands')}.</p>"
        + table(["GSD [m]", "lit pixels", "mixed fraction", "F1 pure pixels",
                 "F1 mixed pixels", "macro F1"], rows,
                caption="Lamp type where two types overlap (mixed-led-hps layout)")
        + by_class
        + src.image("spatial/overlap.png", "Lamp-type F1 with overlapping types")
    )


INTERVALS = "robustness/summary.json"
"""The shipped estimator's intervals on held-out lamps (`make robustness`)."""


def _interval_cells(src, i: int, row: dict) -> list[str]:
    cells = []
    for m in METRICS:
        cov = src.num(INTERVALS, f"/rows/{i}/{m}_covered", digits=2)
        if row.get(f"{m}_covered_sd") is not None:
            cov += " ± " + src.num(INTERVALS, f"/rows/{i}/{m}_covered_sd", digits=1)
        cells.append(cov)
    for m in METRICS:
        cells.append(src.num(INTERVALS, f"/rows/{i}/{m}_width_median", digits=3))
    return cells


CALIBRATION_WORDS = {
    "flagged": "Intervals by the flag (<code>--intervals by-flag</code>, the "
    "default): calibrated on held-out lamps of the library's types for pixels "
    "the prior explains, on library classes held out in turn for pixels "
    "flagged unexplained.",
    "classes": "Intervals calibrated on library classes held out in turn for "
    "every pixel (<code>--intervals any-type</code>).",
    "lamps": "Intervals calibrated on held-out lamps of the library's types "
    "for every pixel (<code>--intervals known-types</code>).",
}
"""What the robustness run's interval calibration (its manifest's
`config.config.calibration`) means, for the intervals section."""


def _calibration_words(src) -> str:
    """The calibration the robustness run's estimator used, in words (none
    without its manifest)."""
    rel = "robustness/manifest.json"
    if not src.path(rel).is_file():
        return ""
    cfg = src.load(rel).get("config", {}).get("config", {})
    return CALIBRATION_WORDS.get(cfg.get("calibration"), "")


@needs("robustness")
def inversion(ctx: Ctx) -> str:
    """Coverage and median width of the 90 % intervals of `bandopt
    evaluate`'s estimator on held-out measured lamps: every band set's
    clean row, then our bands under each measurement effect."""
    src = ctx.src
    rows = src.load(INTERVALS)["rows"]
    header = ["band set", "row", *(f"coverage {m}" for m in METRICS),
              *(f"median width {m}" + (f" [{UNITS[m]}]" if UNITS[m] else "")
                for m in METRICS)]
    clean = [[esc(r["band_set"]), esc(r["perturbation"]), *_interval_cells(src, i, r)]
             for i, r in enumerate(rows) if r["kind"] == "clean"]
    ours = [[esc(r["band_set"]), esc(r["perturbation"]), *_interval_cells(src, i, r)]
            for i, r in enumerate(rows)
            if r["band_set"] == "recommended" and r["kind"] != "clean"]
    return (
        _conditions.robustness(src)
        + "<p>The 90 % intervals <code>bandopt evaluate</code> gives (surface "
        "unknown, Moon told), on held-out measured lamps over "
        + src.num(INTERVALS, "/partitions", digits=1)
        + " lamp partitions: coverage is the class-balanced share of pixels whose "
        "truth lies inside (target 0.85-0.95; mean ± SD over partitions), width "
        "the class-balanced median of each lamp's median interval width. "
        + _calibration_words(src)
        + " The perturbed rows and their pairing with the clean ones are in "
        + src.link("robustness/README.md", "results/robustness")
        + ".</p>"
        + table(header, clean, caption="Every band set, clean spectra")
        + table(header, ours, caption="Our bands under each measurement effect")
    )
