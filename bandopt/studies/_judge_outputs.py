"""What the judge writes besides `judge.json`: its `README.md` text, the
loss figure (`judge.png`) and the trade figure (`trade.png`: error against
SNR and band width), from a `bandopt.studies.judge.verdict` result."""

from pathlib import Path

import numpy as np


def readme_text(result: dict) -> str:
    """`README.md` of the judge: the rule, the table of losses and the
    verdict."""
    ch = result["choice"]
    lines = [
        "# The search's candidates judged by the shipped estimator",
        "",
        "Written by `make judge` (`bandopt.studies.judge`); numbers from "
        "`judge.json`. Each band set: the shipped inversion fitted per lamp "
        "partition on the training lamps, held-out measured lamps scored on "
        "the rows " + ", ".join(result["rows"]) + ".",
        "",
        f"Loss: {result['loss']}. Rule: {ch['rule']}.",
        "",
        "| band set | bands | J | estimation e | classification c | "
        "clean level-1 | clean LER [lm/W] | clean G | clean CCT [K] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for b, v in result["losses"].items():
        c = result["clean"].get(b, {})

        def f(x, d):
            return "-" if x is None else f"{x:.{d}f}"

        sd = "" if v["J_sd"] is None else f" ± {v['J_sd']:.3f}"
        mark = " (chosen)" if b == ch["chosen"] else ""
        mark += " (search)" if b == result["searched"] else ""
        lines.append(
            f"| {b}{mark} | {result['n_bands'][b]} | {v['J']:.3f}{sd} | "
            f"{v['estimation']:.3f} | {v['classification']:.3f} | "
            f"{f(c.get('level1_correct'), 2)} | {f(c.get('LER'), 1)} | "
            f"{f(c.get('G'), 3)} | {f(c.get('CCT'), 0)} |"
        )
    d = result["searched_minus_chosen"]["J"]
    lines += [
        "",
        f"**Verdict.** Chosen: {ch['chosen']} (lowest J: {ch['best']}). "
        + (
            "The search's recommendation is the judged choice."
            if result["agrees_with_search"]
            else f"The search recommended {result['searched']}; its J is "
            f"{_spread(d)} against the choice, paired."
        ),
    ]
    for o, v in result["chosen_minus_reference"].items():
        lines.append(
            f"- chosen minus {o}: J {_spread(v['J'])}, estimation "
            f"{_spread(v['estimation'])}, classification "
            f"{_spread(v['classification'])} (negative: ours better)"
        )
    under = result.get("choice_under_instrument")
    if under is not None:
        inst = result["instrument"]
        target = inst["snr_target"]
        if under["chosen"] is not None:
            lines += ["", f"**Under the instrument** (SNR {target:g} at every "
                      f"band's detection limit): {under['chosen']}."]  # fmt: skip
        else:
            lines += [
                "",
                f"**Under the instrument** no candidate reaches SNR {target:g} at "
                f"its detection limit; the choice needs "
                f"{under['judged_exposure_factor']:.3g}x the exposure, the least "
                f"any candidate needs is {under['least_exposure_factor']:.3g}x "
                f"({under['least_exposure']}).",
            ]
        lines += [
            "",
            "| band set | limiting band | SNR at the limit | exposure factor |",
            "|---|---|---|---|",
        ]
        for b, v in inst["band_sets"].items():
            lines.append(
                f"| {b} | {v['limiting_band']} | {v['snr_at_limit']:.2f} | "
                f"{v['exposure_factor']:.3g} |"
            )
    if "interval_note" in result:
        lines += ["", f"Intervals: {result['interval_note']}."]
    return "\n".join(lines) + "\n"


def _spread(d: dict) -> str:
    """A paired difference as text: mean and its 95 % interval over lamps,
    or ± its SD over partitions when it has no interval."""
    if d.get("ci95") is not None:
        lo, hi = d["ci95"]
        return f"{d['mean']:+.3f} [{lo:+.3f}, {hi:+.3f}]"
    return f"{d['mean']:+.3f} ± {d['sd'] or 0:.3f}"


def trade_figure(result: dict, path: Path) -> None:
    """The trade the loss does not weigh: each judged band set's estimation
    error e and loss J against its SNR, coloured by its narrowest band's FWHM
    (a narrow band is a dim band), the chosen design and the search's pick
    marked. The SNR is the instrument check's (the limiting band's at its
    detection limit, `result["instrument"]`, with the SNR target drawn), or
    without it the search's median over its class P4 scenes (`snr_medians`);
    band sets without one are left out."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    inst = result.get("instrument")
    if inst is not None:
        snr = {b: v["snr_at_limit"] for b, v in inst["band_sets"].items()}
        xlabel = "SNR of the limiting band at its detection limit (make radiometry)"
    else:
        snr = result.get("snr_median", {})
        xlabel = "median SNR of the weakest band (class P4 scenes, shot noise)"
    fwhm = result.get("narrowest_fwhm_nm", {})
    sets = [b for b in result["losses"] if snr.get(b) and b in fwhm]
    if not sets:  # no band set has an SNR: nothing to draw, no file
        return
    from matplotlib.ticker import NullFormatter, ScalarFormatter  # plotting only

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.4), sharex=True, layout="constrained")
    for ax, part, title in zip(
        axes,
        ("estimation", "J"),
        ("estimation error e (MAE / truth SD)", "loss J"),
        strict=True,
    ):
        x = [snr[b] for b in sets]
        y = [result["losses"][b][part] for b in sets]
        err = [result["losses"][b][f"{part}_sd"] or 0.0 for b in sets]
        sc = ax.scatter(x, y, c=[fwhm[b] for b in sets], cmap="viridis", s=50,
                        zorder=3)  # fmt: skip
        ax.errorbar(x, y, yerr=err, fmt="none", ecolor="0.6", zorder=2)
        for b, xi, yi in zip(sets, x, y, strict=True):
            mark = ""
            if b == result["choice"]["chosen"]:
                mark = " (chosen)"
            elif b == result["searched"]:
                mark = " (search)"
            ax.annotate(b + mark, (xi, yi), fontsize=7, xytext=(4, 3),
                        textcoords="offset points")  # fmt: skip
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ticks = (0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50)
        hi = max(x) * 1.5
        if inst is not None:
            ax.axvline(inst["snr_target"], color="C3", ls="--", lw=1)
            ax.annotate("SNR target", (inst["snr_target"], 1.0), fontsize=7,
                        xycoords=("data", "axes fraction"), xytext=(3, -10),
                        textcoords="offset points", color="C3")  # fmt: skip
            hi = max(hi, inst["snr_target"] * 1.5)
        ax.set_xticks([t for t in ticks if min(x) / 1.5 <= t <= hi])
        ax.set_xlabel(xlabel)
        ax.set_title(title, fontsize=9)
        ax.grid(alpha=0.3)
    fig.colorbar(sc, ax=axes, label="narrowest band FWHM [nm]")
    fig.suptitle("Estimate against instrument: the shipped estimator's error "
                 "vs SNR (mean ± SD over partitions)", fontsize=10)  # fmt: skip
    fig.savefig(path, dpi=120)
    plt.close(fig)


def figure(result: dict, path: Path) -> None:
    """J per band set (per-partition points, mean ± SD), its estimation and
    classification parts."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    sets = list(result["losses"])
    fig, axes = plt.subplots(1, 3, figsize=(14, 1.5 + 0.45 * len(sets)), sharey=True)
    y = np.arange(len(sets))[::-1]
    for ax, part, title in zip(
        axes,
        ("J", "estimation", "classification"),
        ("loss J", "estimation e (MAE / truth SD)", "classification c (1 - right)"),
        strict=True,
    ):
        for yi, b in zip(y, sets, strict=True):
            v = result["losses"][b]
            pts = v[f"{part}_per_partition"]
            colour = "C3" if b == result["choice"]["chosen"] else "C0"
            ax.plot(pts, [yi] * len(pts), "o", ms=3, color="0.6")
            ax.errorbar(
                v[part], yi, xerr=v[f"{part}_sd"] or 0, fmt="s", color=colour, capsize=3
            )
        ax.set_title(title, fontsize=9)
        ax.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(y, sets, fontsize=8)
    fig.suptitle("search candidates judged by the shipped inversion (red: chosen)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
