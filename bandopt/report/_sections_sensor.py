"""The report's first section: the recommended sensor (the thesis' Table 5.1),
its bands with intervals and tolerances, radiometry and GSD, read from
`results/recommendation.json` (and `radiometry/limits.csv`,
`search/tolerance.json`).

Apart from the other sections because it is the one that joins every
study's recommendation into a single table.
"""

from ._experiments import METRICS, UNITS, Ctx
from ._html import design_name, esc, table
from ._source import Sources, missing_box, pointer


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
    band = src.get(rel, p)
    if f"{stem}_{unit}" not in band:  # a judged design: the shipped estimator's scan
        field = "centre_nm" if stem == "centre_tolerance" else "fwhm_factor"
        return _shipped_tolerances(src, band["name"], field, digits)
    cell = _interval_or_none(src, rel, f"{p}/{stem}_{unit}", digits)
    if f"{stem}_calibrated_{unit}" in band:
        cal = _interval_or_none(src, rel, f"{p}/{stem}_calibrated_{unit}", digits)
        cell += f"; calibrated {cal}"
    return cell


SHIPPED_TOLERANCE = "robustness/tolerance/tolerance.json"
"""The tolerance scan with the shipped estimator (`make robustness
ARGS="--config tolerance"`)."""


def _shipped_interval(src: Sources, ptr: str, digits: int) -> str:
    """A tolerance interval of the shipped estimator's scan: its ends, "at
    least" where the grid's edge still passes, and where it fails."""
    T = SHIPPED_TOLERANCE
    iv = src.get(T, ptr)
    lo = src.num(T, ptr + "/interval/0", digits=digits)
    hi = src.num(T, ptr + "/interval/1", digits=digits)
    lo = ("&le; " if iv["open_low"] else "") + lo
    hi = ("&ge; " if iv["open_high"] else "") + hi
    fails = [
        src.num(T, f"{ptr}/fails_at/{k}", digits=digits)
        for k in (0, 1)
        if iv["fails_at"][k] is not None
    ]
    where = " (fails at " + " and ".join(fails) + ")" if fails else ""
    return f"[{lo}, {hi}]{where}"


def _shipped_tolerances(src: Sources, name: str, field: str, digits: int) -> str:
    """Band `name`'s `field` ("centre_nm", "fwhm_factor") interval from the
    shipped estimator's scan, or "not scanned"."""
    if not src.exists(SHIPPED_TOLERANCE):
        return "not scanned"
    per = src.get(SHIPPED_TOLERANCE, "/per_band")
    if field not in per.get(name, {}):
        return "not scanned"
    return _shipped_interval(src, pointer("per_band", name, field), digits)


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
        "<p>Recommended design: <strong>"
        + src.text(R, "/spectral/set", shown=design_name)
        + "</strong>, judged with the " + esc(spectral.get("estimator", "?"))
        + ". Intervals in brackets: " + esc(spectral.get("intervals", ""))
        + "; tolerances: " + esc(spectral.get("tolerances", "")) + ".</p>"
    )
    if spectral.get("chosen_by") == "judge":
        d = pointer("spectral", "search_pick", "minus_chosen", "J")
        parts.append(
            "<p>Chosen by the judge (<code>make judge</code>): among the "
            "search's candidates, the fewest bands whose loss under the "
            "shipped estimator, on clean and perturbed held-out lamps, is within "
            "one SD of the lowest (loss J " + src.num(R, "/spectral/judge/J")
            + " &plusmn; " + src.num(R, "/spectral/judge/J_sd", digits=2)
            + "). The search's own pick, "
            + src.text(R, "/spectral/search_pick/set", shown=design_name)
            + " (chosen on its surrogate, moonless and unperturbed), has a loss "
            "higher by " + src.num(R, d + "/mean")
            + (" " + src.interval(R, d + "/ci95", digits=2)
               + " (paired, 95 % interval over lamps).</p>"
               if "ci95" in spectral["search_pick"]["minus_chosen"]["J"]
               else " &plusmn; " + src.num(R, d + "/sd", digits=2)
               + " (paired by lamp partition).</p>")
        )  # fmt: skip
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
    leak = _leakage_and_aoi(src)
    if leak and spectral.get("chosen_by") == "judge":
        pick = spectral.get("search_pick", {}).get("set", "?")
        leak = leak.replace(
            "<p>Tolerated deviations",
            "<p>Of the search's own pick (" + design_name(pick)
            + "), not of this design: tolerated deviations",
            1,
        )
    parts.append(leak)
    if spectral.get("chosen_by") == "judge" and src.exists(SHIPPED_TOLERANCE):
        T = SHIPPED_TOLERANCE
        parts.append(
            "<p>Tolerances of this design (columns above, leakage and angle of "
            "incidence here) come from the shipped estimator's own scan ("
            + src.link(T) + "): " + esc(src.get(T, "/rule")) + "; "
            + src.num(T, "/partitions") + " lamp partitions. Out-of-band "
            "leakage, all bands: " + _shipped_interval(src, "/leakage", 3)
            + "; angle of incidence: " + _shipped_interval(src, "/aoi_deg", 3)
            + " deg. An end marked &ge; or &le; still passes at the scan's "
            "edge.</p>"
        )
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
