"""The band-search sections of the report: the comparison with every
reference sensor, the error vs band count (with its figure) and the
stability and Pareto figures, all read from `results/search/`.
"""

from . import _conditions
from ._experiments import METRICS, UNITS, Ctx, needs
from ._html import ALPHA_NOTE, design_name, esc, figure_png, table
from ._source import Sources, pointer


@needs("search")
def comparison(ctx: Ctx) -> str:
    src = ctx.src
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
        f"<strong>{design_name(ours)}</strong> (ours)",
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
        _conditions.search_context(src, C, estimator=src.text(C, "/estimator/note")),
        "<p>Every reference sensor is scored with the same estimator on the same "
        f"lamp partitions ({src.text(C, '/estimator/note')}). Errors: mean &plusmn; "
        "SD over partitions of the class-balanced outer-test MAE. Reductions: "
        f"{src.text(C, '/reductions/note')} (recommended design vs the sensor, 95 % "
        f"CI in brackets). {esc(ALPHA_NOTE)}.</p>",
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


@needs("search")
def band_count(ctx: Ctx) -> str:
    src = ctx.src
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
        _conditions.search_context(src, C, estimator=src.text(C, "/estimator/note"))
        + f"<p>Rule: {src.text(C, '/band_count/rule')}. Chosen n = "
        f"{src.num(C, '/band_count/chosen_n')} (best n = "
        f"{src.num(C, '/band_count/best_n')}).</p>"
        + table(["bands", "normalised MAE", "LER MAE [lm/W]", "G MAE", "CCT MAE [K]",
                 "level-2 F1", "designs converged"], rows,
                caption="Error vs band count (designs converged: resamples whose "
                "best local fit met optimistix's tolerances)")
        + img
    )


def _judged_note(src) -> str:
    """When the judge chose the recommendation: the Pareto pick below is the
    search's, not the recommended design, and where the choice is."""
    if not src.exists("recommendation.json"):
        return ""
    spectral = src.load("recommendation.json").get("spectral", {})
    if spectral.get("chosen_by") != "judge":
        return ""
    return (
        "<p>The pick below is the search's, on its surrogate and footing. The "
        "recommended design is the one the shipped estimator judged best among "
        "the search's candidates, "
        + src.text("recommendation.json", "/spectral/set", shown=design_name)
        + " (the verdict's table and the sensor section).</p>"
    )


@needs("search")
def search_figures(ctx: Ctx) -> str:
    src = ctx.src
    P = "search/pareto.json"
    rows = []
    if src.exists(P):
        for name in src.load(P)["candidates"]:
            p = pointer("candidates", name)
            rows.append([
                design_name(name), src.num(P, p + "/alpha", digits=2),
                src.num(P, p + "/norm_mae_mean"),
                src.num(P, p + "/f1_mean", digits=2),
                src.num(P, p + "/snr_median", digits=2),
            ])
    return (
        _conditions.search_context(
            src, "search/compare.json", estimator="the search's closed-form ridge "
            "surrogate inside the inner folds (its outer-test judge as in the "
            "comparison)",
        )
        + src.image("search/stability.png",
                    "Stability of the search's pick over lamp resamples")
        + _judged_note(src)
        + src.image("search/pareto.png",
                    "Pareto front: estimation error vs classification vs SNR")
        + (f"<p>Rule: {src.text(P, '/rule')}.</p>" if src.exists(P) else "")
        + table(["candidate", "alpha", "normalised MAE", "level-2 F1",
                 "median SNR, weakest band (P4 scenes)"], rows,
                caption="Pareto candidates")
    )
