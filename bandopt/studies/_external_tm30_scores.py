"""Scores of the external TM-30 check: per lamp from one `bandopt evaluate
--json` output (|error|, interval coverage, level-1 family, `unexplained`,
estimates out of the physical range), class-balanced summaries with 90 %
bootstrap intervals over lamps resampled within class, and paired
differences of two runs on the same lamps."""

from pathlib import Path

import numpy as np


METRICS = ("LER", "G", "CCT")
CCT_NULL_K = 25000.0
"""A null CCT estimate counts as this when scored (as in `make estimate`)."""
RANGE = {"LER": (0.0, 683.0), "CCT": (1000.0, 25000.0)}
"""Physical ranges an estimate must lie in (G: any finite value)."""
BOOTSTRAP = 2000
"""Bootstrap draws of the lamps (within class) for the 90 % intervals."""
SEED = 0
UNSCORED = ("led_rgb",)
"""TM-30 classes the library does not score: reported apart."""


def lamp_rows(evaluate_json: dict, classes: dict) -> list[dict]:
    """Per-lamp scores from one `bandopt evaluate --json` output. `classes`:
    file stem -> (level1, level2) of the lamp."""
    rows = []
    for lamp in evaluate_json["lamps"]:
        stem = Path(lamp["file"]).stem
        if stem not in classes:
            raise ValueError(
                f"evaluate output names an unknown lamp file {lamp['file']!r}."
            )
        level1, level2 = classes[stem]
        t, e, iv = lamp["true"], lamp["estimate"], lamp.get("interval90") or {}
        row = {
            "lamp": stem,
            "level1": level1,
            "level2": level2,
            "predicted_level1": lamp.get("predicted_level1"),
            "unexplained": bool(lamp.get("unexplained")),
        }
        row["level1_correct"] = row["predicted_level1"] == level1
        out = 0
        for m in METRICS:
            if t.get(m) is None or row["unexplained"]:
                # flagged, not guessed: its estimates are null, counted in
                # `unexplained`, not as errors
                row[m] = row[f"{m}_covered"] = None
                continue
            est = e.get(m)
            if est is not None:
                lo, hi = RANGE.get(m, (-np.inf, np.inf))
                out += int(not (np.isfinite(est) and lo <= est <= hi))
            v = CCT_NULL_K if (m == "CCT" and est is None) else est
            row[m] = None if v is None else float(abs(v - t[m]))
            bounds = iv.get(m)
            row[f"{m}_covered"] = (
                None
                if bounds is None or None in bounds
                else bool(bounds[0] <= t[m] <= bounds[1])
            )
        row["out_of_range"] = out
        rows.append(row)
    return rows


def _class_mean(rows, key, classes) -> float | None:
    per = []
    for c in classes:
        v = [r[key] for r in rows if r["level2"] == c and r.get(key) is not None]
        if v:
            per.append(float(np.mean(v)))
    return float(np.mean(per)) if per else None


def _balanced(rows, keys, classes, draws: int, seed: int) -> dict:
    """Each key's class-balanced mean over `rows` and its 90 % bootstrap
    interval (`key_ci90`; lamps resampled within class, seeded; None when no
    draw has a value)."""
    by = {c: [r for r in rows if r["level2"] == c] for c in classes}
    rng = np.random.default_rng(seed)
    boot = {k: [] for k in keys}
    for _ in range(draws):
        sample = [
            by[c][i] for c in classes for i in rng.integers(0, len(by[c]), len(by[c]))
        ]
        for k in keys:
            boot[k].append(_class_mean(sample, k, classes))
    out = {}
    for k in keys:
        v = [x for x in boot[k] if x is not None]
        out[k] = _class_mean(rows, k, classes)
        out[f"{k}_ci90"] = (
            [float(np.quantile(v, 0.05)), float(np.quantile(v, 0.95))] if v else None
        )
    return out


def summarise(rows: list[dict], *, draws: int = BOOTSTRAP, seed: int = SEED) -> dict:
    """Class-balanced means over the scored classes (`UNSCORED` apart), each
    with a 90 % bootstrap interval over lamps resampled within class; per
    class means; totals of out-of-range estimates and lamps."""
    scored = [r for r in rows if r["level2"] not in UNSCORED]
    classes = sorted({r["level2"] for r in scored})
    keys = (
        *METRICS,
        *(f"{m}_covered" for m in METRICS),
        "level1_correct",
        "unexplained",
    )
    by = {c: [r for r in scored if r["level2"] == c] for c in classes}
    out = {"lamps": len(scored), "classes": classes}
    out.update(_balanced(scored, keys, classes, draws, seed))
    out["by_class"] = {
        c: {"lamps": len(by[c]), **{k: _class_mean(by[c], k, [c]) for k in keys}}
        for c in classes
    }
    apart = [r for r in rows if r["level2"] in UNSCORED]
    out["unscored"] = {
        c: {
            "lamps": sum(r["level2"] == c for r in apart),
            **{k: _class_mean(apart, k, [c]) for k in keys},
        }
        for c in sorted({r["level2"] for r in apart})
    }
    out["out_of_range"] = int(sum(r["out_of_range"] for r in rows))
    return out


def paired(rows_a: list[dict], rows_b: list[dict], *, draws=BOOTSTRAP, seed=SEED):
    """Class-balanced difference a - b of each metric's |error| on the same
    lamps, with a 90 % bootstrap interval over lamps (within class)."""
    a = {r["lamp"]: r for r in rows_a if r["level2"] not in UNSCORED}
    b = {r["lamp"]: r for r in rows_b if r["level2"] not in UNSCORED}
    lamps = sorted(set(a) & set(b))
    diff = []
    for lamp in lamps:
        d = {"lamp": lamp, "level2": a[lamp]["level2"]}
        for m in METRICS:
            x, y = a[lamp][m], b[lamp][m]
            d[m] = None if x is None or y is None else x - y
        diff.append(d)
    classes = sorted({d["level2"] for d in diff})
    out = {"lamps": len(lamps)}
    out.update(_balanced(diff, METRICS, classes, draws, seed))
    return out
