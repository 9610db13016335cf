"""The tables and sentences of a study's README section, read from its
summary: cells of means ± SD and paired differences, per-class means, the
held-out-class (unseen types) summaries, and the section of a study that
scores an estimator against a variant of it (`variant_text`)."""

import numpy as np

from ..inversion import SUMMARY_COLUMNS


BASE = "inversion-moon-mix-metric-narrow"


SHIFT = "inversion-moon-mix-metric-narrow-shift"
"""Without and with shifted copies of direct-emission LEDs in every prior."""


GRID = (0.0, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0)
"""`bandopt.inversion.INTERVAL_OFFSET_GRID` (checked by the tests; named
here so `--help` needs no JAX)."""


SHIFTS = (-10.0, -7.5, -5.0, -2.5, 2.5, 5.0, 7.5, 10.0)
"""`bandopt.inversion.PEAK_SHIFTS_NM` (checked by the tests)."""


COLUMNS = ("LER", "G", "CCT", "CCT_mired", "LER_covered", "LER_width")
"""Summary columns compared by partition, shift minus base."""


PAIRED_DIGITS = {"LER": 1, "G": 3, "CCT": 0, "CCT_mired": 1, "LER_covered": 3,
                 "LER_width": 1}  # fmt: skip


CLASS_KEYS = ("LER", "G", "CCT", "CCT_mired", "LER_covered", "level1_correct")


def fmt_cell(r, m, digits) -> str:
    """`mean ± SD` of summary row `r`'s column `m` at `digits` decimals
    ("n/a" where it has none)."""
    v, sd = r.get(m), r.get(f"{m}_sd")
    if v is None:
        return "n/a"
    return f"{v:.{digits}f} ± {sd:.{digits}f}" if sd is not None else f"{v:.{digits}f}"


def diff_cells(p: dict, columns=(("LER", 1), ("G", 3), ("CCT", 0))) -> list[str]:
    """Table cells `mean ± SD` of a paired row's differences of `columns`
    ((summary column, decimals); default LER, G and CCT)."""
    cells = []
    for m, d in columns:
        v, sd = p.get(f"{m}_diff"), p.get(f"{m}_diff_sd")
        cells.append("n/a" if v is None else f"{v:+.{d}f} ± {(sd or 0):.{d}f}")
    return cells


def where_lines(by_class) -> list[str]:
    """One line saying where each held-out class's pixels went (its three
    most frequent level-1 families and their fractions) from an unseen-types
    `by_class`; none when no class has `level1_predicted`."""
    where = {
        c: row["level1_predicted"]
        for c, row in (by_class or {}).items()
        if row.get("level1_predicted")
    }
    if not where:
        return []
    parts = [
        f"{c} → " + ", ".join(f"{k} {v:.2f}" for k, v in list(frac.items())[:3])
        for c, frac in where.items()
    ]
    return [
        "Where each held-out class's pixels went (level-1 family, fraction): "
        + "; ".join(parts)
        + "."
    ]


def unseen_lines(unseen) -> list[str]:
    """README lines per unseen-types run of `unseen` (label -> `overall` and
    `by_class`): coverage of LER, G and CCT, level-1 type right, unexplained
    and out-of-range counts, then `where_lines`."""
    lines = []
    for label, u in (unseen or {}).items():
        o = u["overall"]
        lines += [
            "",
            f"Unseen lamp types (recommended bands, `{label}`, partition 0; each "
            "scored class held out in turn): coverage LER "
            f"{o['LER_covered']:.2f}, G {o['G_covered']:.2f}, CCT "
            f"{o['CCT_covered']:.2f}; level-1 type right {o['level1_correct']:.2f}; "
            f"unexplained {o['unexplained']:.2f}; out of range {o['out_of_range']}.",
        ]
        lines += where_lines(u.get("by_class"))
    return lines


def base_paired_lines(paired, base: str, columns) -> list[str]:
    """Table rows `| band set | differences |` of the `paired` rows compared
    with `base` (`vs`), cells `diff_cells(p, columns)`."""
    return [
        f"| {p['band_set']} | " + " | ".join(diff_cells(p, columns)) + " |"
        for p in paired
        if p.get("vs") == base
    ]


def held_out_by_class(recs) -> dict:
    """Per held-out class: lamp count and the mean of each of the summary's
    columns a held-out class has (`inversion.SUMMARY_COLUMNS` but level-2,
    never in the prior, and CCT in mired)."""
    columns = [c for c in SUMMARY_COLUMNS if c not in ("CCT_mired", "level2_correct")]
    out = {}
    for c in sorted({r["held_out_class"] for r in recs}):
        rs = [r for r in recs if r["held_out_class"] == c]
        row = {"lamps": len(rs), "level1_in_prior": rs[0]["level1_in_prior"]}
        for k in columns:
            v = [r[k] for r in rs if r.get(k) is not None]
            row[k] = float(np.mean(v)) if v else None
        row["out_of_range"] = int(sum(r["out_of_range"] for r in rs))
        pred = [r["level1_predicted"] for r in rs if "level1_predicted" in r]
        if pred:  # mean over the class's lamps of each lamp's pixel fractions
            keys = sorted({k for d in pred for k in d})
            frac = {k: float(np.mean([d.get(k, 0.0) for d in pred])) for k in keys}
            row["level1_predicted"] = dict(sorted(frac.items(), key=lambda kv: -kv[1]))
        out[c] = row
    return out


HELD_OUT_OVERALL = tuple(
    c
    for c in SUMMARY_COLUMNS
    if c.endswith(("_covered", "_width", "_width_mired"))
    or c in ("level1_correct", "unexplained")
)
"""The columns `held_out_overall` averages over held-out classes: coverage,
widths, level-1 right and `unexplained` of `inversion.SUMMARY_COLUMNS` (the
errors and level 2 mean nothing for a class the prior lacks)."""


def held_out_overall(recs) -> dict:
    """Class-balanced over held-out classes (each lamp's value averaged within
    its class first)."""
    bc = held_out_by_class(recs)
    res = {}
    for k in HELD_OUT_OVERALL:
        v = [row[k] for row in bc.values() if row.get(k) is not None]
        res[k] = float(np.mean(v)) if v else None
    res["level1_correct_where_family_in_prior"] = float(
        np.mean(
            [row["level1_correct"] for row in bc.values() if row["level1_in_prior"]]
        )
    )
    res["out_of_range"] = int(sum(row["out_of_range"] for row in bc.values()))
    return res


def held_out(recs) -> dict:
    """An unseen-types entry of held-out-class records `recs`: `by_class`
    (`held_out_by_class`) and `overall` (`held_out_overall`)."""
    return {"by_class": held_out_by_class(recs), "overall": held_out_overall(recs)}


def row_line(r: dict, surface: bool = True) -> str:
    """A summary row as a README table line: band set, surface (optional),
    estimator, MAE ± SD per metric, coverage per metric, level-1 right."""
    cov = "/".join(
        "n/a" if r.get(f"{m}_covered") is None else f"{r[f'{m}_covered']:.2f}"
        for m in ("LER", "G", "CCT")
    )
    l1 = r.get("level1_correct")
    where = f"{r['band_set']} | {r['surface']}" if surface else r["band_set"]
    return (
        f"| {where} | {r['estimator']} | "
        f"{fmt_cell(r, 'LER', 1)} | {fmt_cell(r, 'G', 3)} | {fmt_cell(r, 'CCT', 0)} | "
        f"{cov} | {'n/a' if l1 is None else f'{l1:.2f}'} |"
    )


def rows_table(rows, surface: bool = True, label=None) -> list[str]:
    """README table lines of summary `rows` (`row_line`), header first;
    `label(band_set)` renames the band sets (default as they are)."""
    head = ["| band set | surface | estimator" if surface else "| band set | estimator"]
    head[0] += " | LER [lm/W] | G | CCT [K] | coverage LER/G/CCT | level-1 right |"
    head.append("|---" * (8 if surface else 7) + "|")
    name = label or (lambda b: b)
    return head + [
        row_line({**r, "band_set": name(r["band_set"])}, surface=surface) for r in rows
    ]


def by_intervals(recs) -> dict:
    """Unseen-types records by their `"intervals"` tag (None when untagged:
    one kind of interval), in order of first appearance."""
    out: dict = {}
    for r in recs:
        out.setdefault(r.get("intervals"), []).append(r)
    return out


def by_class(records, estimators=(BASE, SHIFT)) -> dict:
    """Recommended bands: per estimator and held-out level-2 class, the mean
    over lamps and partitions of each lamp's error, coverage and level-1
    rate (where a change to the prior acts, e.g. the shifts on the amber
    LEDs, and whether any other class pays for it)."""
    out: dict = {}
    for est in estimators:
        rs = [
            r for r in records
            if r["band_set"] == "recommended" and r["estimator"] == est
        ]  # fmt: skip
        out[est] = class_means(rs)
    return out


def class_means(records, keys=CLASS_KEYS) -> dict:
    """Per level-2 class of `records`, the mean over its lamps' records of
    each of `keys` (None where no record has it) and its number of lamps."""
    out: dict = {}
    for c in sorted({r["level2"] for r in records}):
        cr = [r for r in records if r["level2"] == c]
        out[c] = {
            k: float(np.mean(v)) if v else None
            for k in keys
            for v in [[r[k] for r in cr if r.get(k) is not None]]
        }
        out[c]["lamps"] = len({r["lamp"] for r in cr})
    return out


def class_change_cells(before: dict, after: dict) -> list[str]:
    """Per level-2 class of `before` ({class: by_class row}) that both hold an
    LER for: "class (lamps) LER → LER lm/W, CCT CCT → CCT K", the README's
    per-class sentence of a change."""
    cells = []
    for c, a in before.items():
        b = after.get(c, {})
        if a.get("LER") is None or b.get("LER") is None:
            continue
        cells.append(
            f"{c} ({a['lamps']}) {a['LER']:.1f} → {b['LER']:.1f} lm/W, "
            f"CCT {a['CCT']:.0f} → {b['CCT']:.0f} K"
        )
    return cells


def reference_lines(paired, title: str, column: str, label=None) -> list[str]:
    """README lines: `title` and a table of reference sensors minus the
    recommended bands (`paired` rows of `paired_differences`), LER, G and
    CCT differences; `column` heads the estimator column, whose cells are
    `label(estimator)` (default the estimator's name)."""
    lines = [
        "",
        title,
        "",
        f"| compared | {column} | LER [lm/W] | G | CCT [K] |",
        "|---|---|---|---|---|",
    ]
    for p in paired:
        est = p["estimator"] if label is None else label(p["estimator"])
        cells = " | ".join(diff_cells(p))
        lines.append(f"| {p['band_set']} − {p['vs']} | {est} | {cells} |")
    return lines


def variant_text(
    summary: dict,
    variant: str,
    heading: str,
    what: str,
    change: str,
    base: str = BASE,
) -> str:
    """The README section of a study that scores `base` (default `BASE`)
    against `variant` (the same estimator with something added to every
    prior, said by `what`): rows, paired differences, per class (`change`:
    how the per-class sentence names the two, e.g. "without → with shifts"),
    unseen types."""
    lines = [
        heading,
        "",
        "The scenes, lamp partitions and folds of `make estimate`; surface "
        "unknown, the Moon told, blends in every prior, one band-error model per "
        "metric, the narrowest calibrated interval unit (`bandopt evaluate`'s "
        f"estimator); {summary['partitions']} partitions, class-balanced MAE "
        "over held-out measured lamps, mean ± SD over partitions. "
        f"{what} Generated from `summary.json`.",
        "",
        *rows_table(summary["rows"], surface=False),
    ]
    lines += [
        "",
        f"Paired by partition, `{variant}` minus `{base}` (negative = better or "
        "narrower):",
        "",
        "| band set | LER [lm/W] | G | CCT [K] | CCT [mired] | coverage LER "
        "| width LER [lm/W] |",
        "|---|---|---|---|---|---|---|",
    ]
    lines += base_paired_lines(
        summary["paired"], base, [(c, PAIRED_DIGITS[c]) for c in COLUMNS]
    )
    lines += reference_lines(
        [p for p in summary["paired"] if p.get("vs") != base],
        "Reference sensors minus recommended bands, same estimator:",
        "estimator",
    )
    classes = (summary.get("extra") or {}).get("by_class") or {}
    if classes.get(base) and classes.get(variant):
        cells = class_change_cells(classes[base], classes[variant])
        lines += [
            "",
            "Per held-out class (recommended bands, mean over lamps and "
            f"partitions; lamps per class), {change}: " + "; ".join(cells) + ".",
        ]
    for label, u in (summary.get("unseen_types") or {}).items():
        if label.endswith("(offset 0)"):
            continue  # the same fits' half-width intervals: not compared here
        o = u["overall"]
        lines += [
            "",
            f"Unseen lamp types (recommended bands, `{label}`; partition 0, each "
            "scored class held out in turn, intervals calibrated on training "
            f"classes held out in turn): coverage LER {o['LER_covered']:.2f}, G "
            f"{o['G_covered']:.2f}, CCT {o['CCT_covered']:.2f}; mean LER width "
            f"{fmt_cell(o, 'LER_width', 0)} lm/W; level-1 right "
            f"{o['level1_correct']:.2f}; unexplained {o['unexplained']:.2f}; out "
            f"of range {o['out_of_range']}.",
        ]
        lines += where_lines(u.get("by_class"))
    return "\n".join(lines) + "\n"
