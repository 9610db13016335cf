"""Searched band sets against reference sensors: pooled outer-fold errors with
lamp-bootstrap intervals, the best set per metric for the goal, and paired
error reductions (the single-split study's comparison).

A searched set is scored by pooling its outer folds' per-lamp test errors
(every scored lamp tested once); a reference sensor by its own outer-fold
evaluation on the same lamps. `mae_ci` gives the class-balanced MAE with a
95 % lamp bootstrap interval, `paired_reduction` the paired relative
reduction `1 - MAE_ours / MAE_ref` over the same lamps.
"""

import dataclasses
from collections.abc import Mapping, Sequence

from ..estimate import METRICS
from ._report import mae_ci, paired_reduction


OUTER_FOLDS = (0, 1, 2)
"""Outer folds pooled per searched set (`bandopt.folds.N_OUTER_FOLDS`)."""


def pool_folds(fold_results: Mapping) -> tuple[list, list] | None:
    """(lamp index, per-lamp errors) of the outer folds of one searched set
    (`run_task` results by fold), or None while a fold is missing."""
    idx, err = [], []
    for k in OUTER_FOLDS:
        r = fold_results.get(k)
        if r is None:
            return None
        idx += r["lamp_index"]
        err += r["lamp_errors"]
    return idx, err


def set_name(target: str, n_bands: int, pan: str) -> str:
    """`"all-n5+pan"`-style label of a searched set."""
    return f"{target}-n{n_bands}" + ("+pan" if pan != "none" else "")


@dataclasses.dataclass(frozen=True)
class Comparison:
    """`compare_with_references`' result (JSON-ready fields).

    - `references`: per sensor, band count, title and `mae_ci` per metric.
    - `ours`: per searched set, target, band count, pan, `mae_ci` per metric,
      its final bands, search wall time and loss spread.
    - `best_for_goal`: per metric, the set judged against the goal.
    - `reductions`: per sensor and metric, the paired reduction of the best
      set, the goal and whether it is met; `equal_band_count`: our joint set
      with the sensor's band count (pan included), per metric.
    """

    references: dict
    ours: dict
    best_for_goal: dict
    reductions: dict
    pooled: dict = dataclasses.field(repr=False, compare=False)

    def as_dict(self) -> dict:
        return {
            "references": self.references,
            "ours": self.ours,
            "best_for_goal": self.best_for_goal,
            "reductions": self.reductions,
        }


def compare_with_references(
    searched: Mapping[tuple[str, int, str], Mapping],
    references: Sequence[dict],
    classes,
    goal: Mapping[str, float],
    *,
    titles: Mapping[str, str] | None = None,
    goal_n_bands: int = 5,
) -> Comparison:
    """Compare searched sets with reference sensors.

    - `searched`: `(target, n_bands, pan)` -> `{fold: run_task result}`
      (folds 0-2 and optionally `"final"`); sets missing a fold are skipped.
    - `references`: `run_task` results of `kind="reference"` tasks.
    - `classes`: level-2 class of each lamp (class-balanced MAE).
    - `goal`: required relative reduction per metric (`METRICS`).
    - `goal_n_bands`: the free-band count the goal is judged at (with a pan
      band; the largest available otherwise).
    """
    ref_sum = {}
    for r in references:
        key = r["task"]["sensor"]
        ref_sum[key] = {
            "n_bands": len(r["bands"]["bands"]),
            **({"title": titles[key]} if titles and key in titles else {}),
            **mae_ci(r["lamp_errors"], r["lamp_index"], classes),
        }
    ours, pooled = {}, {}
    for (target, n, pan), folds in sorted(searched.items(), key=str):
        pool = pool_folds(folds)
        if pool is None:
            continue
        name = set_name(target, n, pan)
        pooled[name] = pool
        final = folds.get("final")
        ours[name] = {
            "target": target,
            "n_bands": n,
            "pan": pan,
            **mae_ci(pool[1], pool[0], classes),
            "final_bands": None if final is None else final["bands"],
            "search_wall_s": float(sum(f["wall_s"] for f in folds.values())),
            "spread": None if final is None else final["spread"],
        }
    best = {}
    for m in METRICS:
        cands = [
            k
            for k, v in ours.items()
            if v["n_bands"] == goal_n_bands
            and v["pan"] != "none"
            and v["target"] in (m.lower(), "all")
        ] or list(ours)
        if cands:
            best[m] = min(cands, key=lambda k: ours[k][m]["mae"])
    reductions = {}
    for r in references:
        key = r["task"]["sensor"]
        reductions[key] = {}
        for m, name in best.items():
            red = paired_reduction(
                pooled[name][1], r["lamp_errors"], pooled[name][0], r["lamp_index"],
                classes,
            )[m]  # fmt: skip
            reductions[key][m] = {
                "ours": name,
                **red,
                "goal": goal[m],
                "meets_goal": red["reduction"] >= goal[m],
            }
        b = ref_sum[key]["n_bands"]
        eq = set_name("all", b - 1, "fixed")
        if b >= 2 and eq in pooled:
            red = paired_reduction(
                pooled[eq][1], r["lamp_errors"], pooled[eq][0], r["lamp_index"],
                classes,
            )  # fmt: skip
            reductions[key]["equal_band_count"] = {
                "ours": eq,
                **{m: red[m] for m in METRICS},
            }
    return Comparison(ref_sum, ours, best, reductions, pooled)
