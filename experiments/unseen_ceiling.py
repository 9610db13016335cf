"""Ceiling of the level-1 family of unseen lamp types.

Issue 12 asks that, for lamp types the library has never seen (each scored
level-2 class held out in turn), the level-1 family (led, hid, fluorescent,
incandescent, lps) is right for >= 90 % of lamps. The physics-based inversion
on the scenes of `make study NAME=estimate-mix` gets about 0.4 (class mean). This
measures what is attainable at all with a classifier trained on the library's
other types: the bare lamp spectrum, without surface, atmosphere, Moon or
noise, binned to 5, 10, 20 and 50 nm, and the noise-free values of the
recommended bands (`results/search/recommended_bands.json`) of the same
spectra; each fed to a 1-nearest-neighbour classifier and to logistic
regression (C = 1 and C = 0.01, classes balanced), trained on the measured
lamps of the other scored classes. A class whose family has no other class
(incandescent_halogen) cannot be named by such a classifier: it is skipped
and reported. Also with the unscored measured lamps (led_rgb, lps) in
training, as the inversion's prior holds them; with, besides those,
uncalibrated samples of every physical lamp model of `bandopt.lampmodels`
(what physics says the technologies can emit, fitted to no measured lamp,
`with_physical_models`); with the spectra cut at 780 nm, where the
library's NIR extension begins; and, for comparison, the inversion's
level-1 accuracy on the scenes as read from
`results/estimate_mix/summary.json` (`unseen_types`; not recomputed).

    python -m experiments.unseen_ceiling [--out DIR]

Writes `summary.json` (per feature set and classifier: class mean, lamp mean,
per held-out class the accuracy and the fractions of its lamps given each
family; the skipped classes; the same with the unscored lamps in training
and cut at 780 nm; the inversion's numbers read from estimate_mix),
`ceiling.png`, `manifest.json` and the `unseen-ceiling` section of
`results/README.md` (default output only). Scored: measured lamps only;
modelled lamps train in the `with_physical_models` variant only (beyond
780 nm a third of the measured lamps are the library's NIR extension: see
`visible_only`). Deterministic (the model samples are seeded, `MODEL_SEED`;
the solvers too).
"""

import argparse
import hashlib
import json
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np


RESOLUTIONS_NM = (5, 10, 20, 50)
"""Bin widths of the binned spectra [nm]."""
BANDS_FEATURE = "bands"
"""Feature-set label of the recommended bands' values."""
FEATURES = (*(f"{r} nm" for r in RESOLUTIONS_NM), BANDS_FEATURE)
"""Feature-set labels, in table order."""
CLASSIFIERS = ("1-NN", "logistic C=1", "logistic C=0.01")
"""Classifier labels (`make_classifier`)."""
GOAL = 0.9
"""Issue 12's goal for the level-1 family of unseen lamp types [1]."""
LOG_FLOOR = 1e-6
"""Floor on a bin's fraction of the spectrum before the log [1] (a bin
without light, e.g. beyond a LED's emission, would be log 0)."""
INVERSION_SOURCE = Path("results/estimate_mix/summary.json")
"""Where the inversion's unseen-types numbers are read from."""
INVERSION_LABELS = ("inversion-moon", "inversion-moon-mix")
"""The inversion runs of `INVERSION_SOURCE` shown beside the ceiling."""
MAX_ITER = 5000
"""Iteration cap of the logistic regressions (converged well below it)."""
MODEL_SAMPLES = 100
"""Modelled lamps per physical model family in the `with_physical_models`
variant."""
MODEL_SPREAD = 1.0
"""Standard deviation of those samples' unconstrained parameters z about the
family's default start (`lampmodels.Family.z_init`) [1]."""
MODEL_SEED = 0
"""Seed of those samples."""


def log(msg: str) -> None:
    print(
        f"[unseen_ceiling {time.strftime('%H:%M:%S')}] {msg}",
        file=sys.stderr,
        flush=True,
    )


def _log_fractions(values: np.ndarray, what: str) -> np.ndarray:
    """log of each row's values as fractions of the row's sum, floored at
    `LOG_FLOOR`; a row without light is an error."""
    total = values.sum(axis=1, keepdims=True)
    if np.any(total <= 0) or not np.all(np.isfinite(values)):
        bad = np.flatnonzero((total[:, 0] <= 0) | ~np.isfinite(values).all(axis=1))
        raise ValueError(
            f"{what}: rows {bad[:5].tolist()} have no light (sum <= 0) or a "
            "non-finite value."
        )
    return np.log(np.maximum(values / total, LOG_FLOOR))


def binned_log_spectra(spectra, wavelength_nm, step_nm: float) -> np.ndarray:
    """Spectra summed into bins of `step_nm`, as log fractions of each
    spectrum's total: (l, w) -> (l, n) with n = w // k bins of k =
    round(step_nm / grid spacing) samples from the first wavelength on;
    trailing samples that do not fill a bin are dropped (521 samples at 1 nm
    and 5 nm: 104 bins, 380-899 nm). Bin fractions are floored at
    `LOG_FLOOR` before the log.

    spectra: (l, w) spectral power, any unit (only shapes matter) [arb.].
    wavelength_nm: (w,) uniform grid [nm]. step_nm: bin width, at least the
    grid spacing [nm]."""
    spectra = np.asarray(spectra, float)
    grid = np.asarray(wavelength_nm, float)
    if spectra.ndim != 2 or grid.ndim != 1 or spectra.shape[1] != grid.size:
        raise ValueError(
            f"spectra must be (l, w) and wavelength_nm (w,): got {spectra.shape} "
            f"and {grid.shape}."
        )
    if grid.size < 2:
        raise ValueError("wavelength_nm: needs at least 2 samples.")
    dw = np.diff(grid)
    if np.any(dw <= 0) or not np.allclose(dw, dw[0], rtol=1e-6):
        raise ValueError("wavelength_nm: must be uniform and increasing.")
    k = round(float(step_nm) / float(dw[0])) if np.isfinite(step_nm) else 0
    if k < 1 or k > grid.size:
        raise ValueError(
            f"step_nm: {step_nm} nm; must be between the grid spacing "
            f"{dw[0]:g} nm and the grid's span ({grid.size} samples)."
        )
    n = (grid.size // k) * k
    binned = spectra[:, :n].reshape(spectra.shape[0], -1, k).sum(axis=2)
    return _log_fractions(binned, "spectra")


def band_log_values(spectra, band_weights) -> np.ndarray:
    """Noise-free band values of bare spectra as log fractions of their sum
    over bands: (l, w) x (b, w) -> (l, b). `band_weights`: band-averaging
    weights on the spectra's grid (`bandopt.inversion.band_weights_on`) [1];
    the values are `bandopt.forward.band_values`, as every measurement's."""
    # Lazy: importing this module stays free of JAX (its other helpers need none).
    from bandopt.forward import band_values

    spectra = np.asarray(spectra, float)
    w = np.asarray(band_weights, float)
    if spectra.ndim != 2 or w.ndim != 2 or spectra.shape[1] != w.shape[1]:
        raise ValueError(
            f"spectra (l, w) and band_weights (b, w) must share w: got "
            f"{spectra.shape} and {w.shape}."
        )
    return _log_fractions(np.asarray(band_values(spectra, w)), "band values")


def make_classifier(name: str):
    """A fresh classifier by label (`CLASSIFIERS`): 1-NN on the features as
    they are (Euclidean); logistic regression on standardised features, L2
    penalty C, classes weighted inversely to their training counts (lbfgs,
    deterministic; seeded anyway)."""
    from sklearn.linear_model import LogisticRegression
    from sklearn.neighbors import KNeighborsClassifier
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    if name == "1-NN":
        return KNeighborsClassifier(n_neighbors=1)
    for c in (1.0, 0.01):
        if name == f"logistic C={c:g}":
            return make_pipeline(
                StandardScaler(),
                LogisticRegression(
                    C=c, max_iter=MAX_ITER, class_weight="balanced", random_state=0
                ),
            )
    raise ValueError(f"classifier: unknown {name!r}; one of {', '.join(CLASSIFIERS)}.")


def held_out_class_accuracy(
    X,
    level1: Sequence[str],
    level2: Sequence[str],
    make: Callable[[], object],
    *,
    scored=None,
) -> dict:
    """Each scored level-2 class held out in turn: a classifier from `make()`
    is fitted on the level-1 labels of every other row (scored or not) and
    predicts the held-out class's rows.

    X: (l, f) features. level1, level2: (l,) labels. scored: (l,) bool, the
    rows that are held out and scored (default all); the others only train.

    Returns `accuracy` {class: fraction of its rows given its family} for the
    classes whose family has a training row, `skipped` {class: family} for
    the others (such a classifier cannot name the family), `predicted`
    {class: {family: fraction}} for every held-out class (skipped ones
    included), `lamps` {class: rows}, `class_mean` (each scored class equal
    weight) and `lamp_mean` (each scored row equal weight); the means are
    None when every class is skipped."""
    X = np.asarray(X, float)
    l1 = np.asarray(level1, dtype=object)
    l2 = np.asarray(level2, dtype=object)
    if X.ndim != 2 or l1.shape != (X.shape[0],) or l2.shape != (X.shape[0],):
        raise ValueError(
            f"X must be (l, f) and level1, level2 (l,): got {X.shape}, "
            f"{l1.shape}, {l2.shape}."
        )
    sc = np.ones(X.shape[0], bool) if scored is None else np.asarray(scored, bool)
    if sc.shape != (X.shape[0],):
        raise ValueError(f"scored must be (l,) = ({X.shape[0]},): got {sc.shape}.")
    accuracy, skipped, predicted, lamps = {}, {}, {}, {}
    n_right = n_scored = 0
    for c in sorted(set(l2[sc])):
        test = sc & (l2 == c)
        train = l2 != c
        families = set(l1[test])
        if len(families) != 1:
            raise ValueError(f"level2 class {c!r} spans families {sorted(families)}.")
        family = families.pop()
        pred = np.asarray(make().fit(X[train], l1[train]).predict(X[test]), object)
        names, counts = np.unique(pred.astype(str), return_counts=True)
        order = np.argsort(-counts, kind="stable")
        predicted[c] = {str(names[i]): float(counts[i] / pred.size) for i in order}
        lamps[c] = int(test.sum())
        if family not in set(l1[train]):
            skipped[c] = family
            continue
        right = pred == family
        accuracy[c] = float(right.mean())
        n_right += int(right.sum())
        n_scored += right.size
    return {
        "accuracy": accuracy,
        "skipped": skipped,
        "predicted": predicted,
        "lamps": lamps,
        "class_mean": float(np.mean(list(accuracy.values()))) if accuracy else None,
        "lamp_mean": n_right / n_scored if n_scored else None,
    }


def ceiling(features: dict, level1, level2, *, scored=None, say=None) -> dict:
    """`held_out_class_accuracy` for every feature set ({label: (l, f)}) and
    classifier (`CLASSIFIERS`): {feature: {classifier: result}}."""
    out = {}
    for feat, X in features.items():
        out[feat] = {}
        for name in CLASSIFIERS:
            t = time.time()
            r = held_out_class_accuracy(
                X, level1, level2, lambda name=name: make_classifier(name),
                scored=scored,
            )  # fmt: skip
            out[feat][name] = r
            if say is not None:
                cm, lm = (
                    "n/a" if r[k] is None else f"{r[k]:.3f}"
                    for k in ("class_mean", "lamp_mean")
                )
                say(
                    f"{feat:>6}, {name:<15}: class mean {cm}, lamp mean {lm} "
                    f"({time.time() - t:.1f} s)"
                )
    return out


def _score(r: dict) -> float:
    """A result's class mean, -1 when there is none (sorts below every value)."""
    return -1.0 if r["class_mean"] is None else r["class_mean"]


def _top(results: dict, best: dict) -> str:
    """The feature set whose best classifier has the highest class mean."""
    return max(results, key=lambda f: _score(results[f][best[f]]))


def best_classifiers(results: dict) -> dict:
    """{feature: the classifier with the highest class mean} (first of
    `CLASSIFIERS` on a tie). Chosen on the same held-out results it is
    scored on, so the best is an optimistic ceiling."""
    best = {}
    for feat, by in results.items():
        scores = [(_score(by[n]), -i, n) for i, n in enumerate(by)]
        best[feat] = max(scores)[2]
    return best


def inversion_from_summary(path) -> dict | None:
    """The inversion's level-1 accuracy on unseen types as stored in
    estimate_mix's `summary.json` (`unseen_types`): per run of
    `INVERSION_LABELS` the per-class `level1_correct` (fraction of each
    lamp's scene pixels given its family, averaged over the class's lamps),
    the families it gave (`level1_predicted`), and the class and lamp means
    over the classes whose family was in the prior. None if the file is
    absent or has no unseen-types study."""
    path = Path(path)
    if not path.is_file():
        return None
    data = json.loads(path.read_text())
    unseen = data.get("unseen_types") or {}
    runs = {}
    for label in INVERSION_LABELS:
        by = (unseen.get(label) or {}).get("by_class")
        if not by:
            continue
        acc = {
            c: r["level1_correct"]
            for c, r in by.items()
            if r.get("level1_in_prior") and r.get("level1_correct") is not None
        }
        n = {c: by[c]["lamps"] for c in acc}
        runs[label] = {
            "accuracy": acc,
            "skipped": sorted(c for c in by if c not in acc),
            "predicted": {c: r.get("level1_predicted") for c, r in by.items()},
            "lamps": {c: r["lamps"] for c, r in by.items()},
            "class_mean": float(np.mean(list(acc.values()))) if acc else None,
            "lamp_mean": (
                float(sum(acc[c] * n[c] for c in acc) / sum(n.values()))
                if acc
                else None
            ),
        }
    if not runs:
        return None
    return {
        "source": str(path),
        "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
        "read_not_recomputed": True,
        "scenes": "the scenes of `make estimate` (partition 0), recommended bands, "
        "Moon told; prior: measured lamps of the other classes and the unscored "
        "measured lamps",
        "runs": runs,
    }


def _confused(pred: dict, family: str | None) -> str:
    """'led 0.55' for the commonest wrong family of a class ('' if none)."""
    wrong = [(v, k) for k, v in (pred or {}).items() if k != family and v > 0]
    if not wrong:
        return ""
    v, k = max(wrong)
    return f"{k} {v:.2f}"


def _family_of(summary: dict, c: str) -> str | None:
    return summary.get("families", {}).get(c)


def _worst(summary: dict, r: dict, n: int = 2) -> str:
    rows = sorted(r["accuracy"].items(), key=lambda kv: (kv[1], kv[0]))[:n]
    cells = []
    for c, a in rows:
        conf = _confused(r["predicted"].get(c), _family_of(summary, c))
        cells.append(f"{c} {a:.2f}" + (f" (→ {conf})" if conf else ""))
    return ", ".join(cells)


def _visible_line(vis: dict, res: dict, best: dict) -> str:
    """The README sentence on the spectra cut at the extension's start: its
    best class mean, and the classes that lose >= 0.25 with the overall best
    features and classifier."""
    vr, vb = vis["results"], vis["best"]
    vf = _top(vr, vb)
    lo, hi = vis["range_nm"]
    n_ext = sum(vis["extended_lamps"].values())
    per_class = next(iter(next(iter(vr.values())).values()))["lamps"]
    n_all = sum(per_class.values())
    worst = max(vis["extended_lamps"], key=lambda c: vis["extended_lamps"][c])
    line = (
        f"Spectra cut to {lo:g}-{hi:g} nm ({n_all - n_ext} of the {n_all} lamps "
        f"are measured beyond, the others extended by the per-technology model of "
        f"`bandopt.datasets.nir`, e.g. {vis['extended_lamps'][worst]} of the "
        f"{per_class.get(worst, '?')} {worst}): best class mean "
        f"{_score(vr[vf][vb[vf]]):.2f} ({vf}, {vb[vf]})"
    )
    tf = _top(res, best)
    if tf in vr:
        a, b = res[tf][best[tf]]["accuracy"], vr[tf][best[tf]]["accuracy"]
        drops = sorted((b[c] - a[c], c) for c in a if c in b and a[c] - b[c] >= 0.25)
        if drops:
            line += f"; losing most with {tf}, {best[tf]}: " + ", ".join(
                f"{c} {a[c]:.2f} → {b[c]:.2f}" for _, c in drops
            )
    return line + "."


def _models_line(summary: dict) -> str | None:
    """The README sentence on the `with_physical_models` variant: its best
    class mean, the recommended bands', and where it stands against the goal."""
    var = summary.get("with_physical_models")
    if not var:
        return None
    mb, mr = var["best"], var["results"]
    mf = _top(mr, mb)
    top = mr[mf][mb[mf]]
    fams = ", ".join(var["models"])
    line = (
        f"With uncalibrated samples of every physical lamp model "
        f"(`bandopt.lampmodels`: {fams}; {var['samples_per_family']} per model, "
        f"z normal of SD {var['z_spread']:g} about its default start, fitted to "
        "no measured lamp; no fluorescent model exists) and the unscored lamps "
        f"also in training: best class mean {_score(top):.2f} ({mf}, {mb[mf]}"
        + (f"; worst {_worst(summary, top)}" if top["accuracy"] else "")
        + ")"
    )
    if BANDS_FEATURE in mr:
        b = mb[BANDS_FEATURE]
        line += f"; recommended bands {_score(mr[BANDS_FEATURE][b]):.2f} ({b})"
    reached = _score(top) >= summary["goal"]
    line += (
        ": at or above the goal." if reached else
        f": below the goal of {summary['goal']:.2f} even with what physics says "
        "these technologies can emit."
    )  # fmt: skip
    return line


def readme_text(summary: dict) -> str:
    """The `unseen-ceiling` section of `results/README.md` from `summary.json`."""
    res, best = summary["results"], summary["best"]
    goal = summary["goal"]
    any_r = next(iter(next(iter(res.values())).values()))
    n_cls = len(any_r["accuracy"])
    skipped = ", ".join(
        f"{c} ({f} has no other class)" for c, f in sorted(any_r["skipped"].items())
    )
    lines = [
        "## Ceiling of the level-1 family of unseen lamp types "
        "(`results/unseen_ceiling/`, `make unseen-ceiling`)",
        "",
        "Each scored level-2 class held out in turn; a classifier trained on the "
        "measured lamps of the other scored classes names the level-1 family of "
        "the held-out lamps from the bare lamp spectrum (no surface, atmosphere, "
        "Moon or noise), binned to 5-50 nm or as the noise-free values of the "
        "recommended bands; features: log of the values as fractions of their "
        f"sum. Class mean over the {n_cls} held-out classes whose family has "
        "another class (each class equal weight)"
        + (f"; skipped: {skipped}" if skipped else "")
        + f". Issue 12's goal: {goal:.2f}. Measured lamps only. Generated from "
        "`summary.json`.",
        "",
        "| features | " + " | ".join(CLASSIFIERS) + " | lamp mean (best) "
        "| worst held-out classes, best classifier (→ commonest wrong family) |",
        "|---|" + "---|" * (len(CLASSIFIERS) + 2),
    ]
    for feat, by in res.items():
        cells = []
        for name in CLASSIFIERS:
            v = by[name]["class_mean"]
            s = "n/a" if v is None else f"{v:.2f}"
            cells.append(f"**{s}**" if name == best[feat] else s)
        b = by[best[feat]]
        lm = "n/a" if b["lamp_mean"] is None else f"{b['lamp_mean']:.2f}"
        lines.append(
            f"| {feat} | " + " | ".join(cells) + f" | {lm} | {_worst(summary, b)} |"
        )
    top_feat = _top(res, best)
    top = res[top_feat][best[top_feat]]
    lines += [""]
    alt = summary.get("with_unscored_training_lamps")
    if alt:
        ab, ar = alt["best"], alt["results"]
        af = _top(ar, ab)
        extra = ", ".join(f"{c} {n}" for c, n in sorted(alt["lamps"].items()))
        line = (
            f"With the unscored measured lamps ({extra}) also in training, as in "
            f"the inversion's prior: best class mean {_score(ar[af][ab[af]]):.2f} "
            f"({af}, {ab[af]})"
        )
        if BANDS_FEATURE in ar:
            b = ab[BANDS_FEATURE]
            line += f"; recommended bands {_score(ar[BANDS_FEATURE][b]):.2f} ({b})"
        lines.append(line + ".")
        lines.append("")
    models = _models_line(summary)
    if models:
        lines += [models, ""]
    vis = summary.get("visible_only")
    if vis:
        lines += [_visible_line(vis, res, best), ""]
    inv = summary.get("inversion_on_scenes")
    if inv:
        parts = [
            f"`{k}` {r['class_mean']:.2f} (lamp mean {r['lamp_mean']:.2f})"
            for k, r in inv["runs"].items()
            if r["class_mean"] is not None
        ]
        lines += [
            "The inversion on the scenes (recommended bands, Moon told; read from "
            f"`{inv['source']}`, not recomputed; fraction of each lamp's scene "
            "pixels given its family), class mean over the classes whose family "
            "was in its prior: " + ", ".join(parts) + ".",
            "",
        ]
    cm = top["class_mean"]
    if cm is not None and cm < goal:
        lines.append(
            f"Best of all {len(res) * len(CLASSIFIERS)} combinations: {cm:.2f} "
            f"({top_feat}, {best[top_feat]}; chosen on the same held-out results, "
            "so if anything optimistic), below the goal of "
            f"{goal:.2f}: trained on the library's other types, none of these "
            "classifiers names the family of these held-out types often enough "
            "even from the noise-free lamp spectrum; band values are a function "
            "of the spectrum, so with such classifiers trained on this library "
            "no band set reaches the goal: the limit is what the library's "
            "other lamp types teach, not the bands alone."
        )
    elif cm is not None:
        lines.append(
            f"Best of all {len(res) * len(CLASSIFIERS)} combinations: {cm:.2f} "
            f"({top_feat}, {best[top_feat]}), at or above the goal of {goal:.2f}."
        )
    never = sorted(
        c
        for c in any_r["accuracy"]
        if max(res[f][n]["accuracy"][c] for f in res for n in res[f]) < goal
    )
    if never:
        cells = []
        for c in never:
            a = top["accuracy"][c]
            conf = _confused(top["predicted"].get(c), _family_of(summary, c))
            cells.append(f"{c} ({a:.2f}" + (f", → {conf}" if conf else "") + ")")
        lines.append(
            f"Below the goal with every feature set and classifier: "
            f"{', '.join(cells)} (in brackets: with {top_feat}, {best[top_feat]})."
        )
    return "\n".join(lines) + "\n"


def figure(summary: dict, path: Path) -> None:
    """Level-1 accuracy per held-out class: the best classifier of each
    feature set, the inversion on the scenes, and the goal."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    res, best = summary["results"], summary["best"]
    any_r = next(iter(next(iter(res.values())).values()))
    classes = sorted(any_r["lamps"])
    rows = ["class mean", *classes]
    binned = [f for f in res if f != BANDS_FEATURE]
    series = [
        (f"{f}: {best[f]}", res[f][best[f]], "o", plt.cm.viridis(0.8 * i / len(binned)))
        for i, f in enumerate(binned)
    ]
    if BANDS_FEATURE in res:
        b = best[BANDS_FEATURE]
        series.append((f"recommended bands: {b}", res[BANDS_FEATURE][b], "D", "C6"))
    inv = summary.get("inversion_on_scenes") or {"runs": {}}
    for k, (label, r) in enumerate(inv["runs"].items()):
        series.append(
            (f"inversion on scenes: {label}", r, "X^"[k % 2], ("C3", "C1")[k % 2])
        )
    height = 1.6 + 0.5 * len(rows)
    fig, ax = plt.subplots(figsize=(10, height))
    y = np.arange(len(rows))[::-1].astype(float)
    off = np.linspace(-0.3, 0.3, len(series))
    for j, (label, r, marker, colour) in enumerate(series):
        vals = [r["class_mean"], *(r["accuracy"].get(c) for c in classes)]
        v = np.array([np.nan if x is None else x for x in vals])
        ax.scatter(v, y + off[j], marker=marker, color=colour, s=36, label=label,
                   edgecolor="k", linewidth=0.3, zorder=3)  # fmt: skip
    for c, f in sorted(any_r["skipped"].items()):
        ax.text(0.02, y[rows.index(c)], f"not scored: no other {f} class in "
                "training", va="center", fontsize=8, color="0.3")  # fmt: skip
    ax.axvline(summary["goal"], color="k", ls="--", lw=1)
    ax.text(summary["goal"], y[0] + 0.55, f" goal {summary['goal']:.2f}",
            fontsize=8, va="bottom")  # fmt: skip
    for yy in y[:-1] - 0.5:
        ax.axhline(yy, color="0.85", lw=0.5)
    ax.axhline(y[0] - 0.5, color="0.4", lw=0.8)
    fam = summary.get("families", {})
    labels = [rows[0]] + [
        f"{c} ({fam.get(c, '?')}, {any_r['lamps'][c]})" for c in classes
    ]
    ax.set_yticks(y, labels, fontsize=9)
    ax.set_ylim(y[-1] - 0.6, y[0] + 0.9)
    ax.set_xlim(-0.02, 1.02)
    ax.set_xlabel(
        "level-1 family right [fraction of the held-out class's lamps; "
        "inversion: of their scene pixels]"
    )
    ax.grid(axis="x", alpha=0.3)
    ax.legend(
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=8,
        frameon=False,
        title="features: best classifier",
        title_fontsize=8,
    )
    ax.set_title(
        "Unseen lamp types, each held out in turn (family, lamps): bare lamp "
        "spectra, classifiers trained on the other classes",
        fontsize=10,
    )
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def physical_model_spectra(
    wavelength_nm, n_per_family: int, spread: float, seed: int
) -> tuple[np.ndarray, list[str], list[str]]:
    """Modelled lamps of every physical model family (`lampmodels.FAMILIES`),
    calibrated on NO measured lamp: z drawn from a normal of SD `spread` about
    the family's default start, through the family's bounds, one lumen each
    (`lampmodels.per_lumen`).

    Returns (spectra (n, w) [W nm⁻¹ lm⁻¹], level-1 family of each, model
    family of each). What physics says a technology can emit, without the
    library's lamps of it: for training only, never scored."""
    # Lazy: the module's pure helpers are imported by the tests without JAX.
    from bandopt import lampmodels
    from bandopt.datasets.lamps import LEVEL2_PARENT

    if n_per_family < 1 or not spread > 0:
        raise ValueError(
            f"n_per_family must be >= 1 and spread > 0 (got {n_per_family}, {spread})."
        )
    grid = np.asarray(wavelength_nm, float)
    rng = np.random.default_rng(seed)
    rows, level1, fams = [], [], []
    for name, fam in lampmodels.FAMILIES.items():
        parents = {LEVEL2_PARENT[c] for c in fam.classes}
        if len(parents) != 1:
            raise ValueError(f"model family {name!r} spans families {parents}.")
        z = fam.z_init() + spread * rng.standard_normal((n_per_family, len(fam.params)))
        sp = lampmodels.per_lumen(grid, lampmodels.model_spectra(fam, z, grid))
        ok = np.all(np.isfinite(sp), axis=1)
        rows.append(sp[ok])
        level1 += [parents.pop()] * int(ok.sum())
        fams += [name] * int(ok.sum())
    return np.vstack(rows), level1, fams


def _features(lamps, grid, band_weights) -> dict:
    return _features_of(lamps.spectra, grid, band_weights)


def _features_of(spectra, grid, band_weights) -> dict:
    feats = {f"{r} nm": binned_log_spectra(spectra, grid, r) for r in RESOLUTIONS_NM}
    feats[BANDS_FEATURE] = band_log_values(spectra, band_weights)
    return feats


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--out", default=None, help="output (default results/unseen_ceiling)"
    )
    args = ap.parse_args(argv)

    from bandopt import configure

    configure()
    from bandopt import inversion as inv_mod
    from bandopt.datasets.lamps import library
    from bandopt.datasets.nir import EXTENSION_START_NM
    from bandopt.provenance import write_manifest
    from bandopt.results import update_readme_section
    from bandopt.search import get_context
    from bandopt.studies import RECOMMENDED, band_set  # JAX only when run

    out = Path(args.out or "results/unseen_ceiling")
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    ctx = get_context("search", None, 0, "auto")
    lamps, always, _, _ = inv_mod.context_setup(ctx)
    grid = np.asarray(ctx.wavelength_nm, float)
    bands = band_set("recommended")
    w = inv_mod.band_weights_on(bands, grid)
    log(
        f"{len(lamps.ids)} scored measured lamps, {len(always.ids)} unscored; "
        f"{len(bands.names)} recommended bands ({time.time() - t0:.0f} s)"
    )
    l1, l2 = list(lamps.level1), list(lamps.level2)
    results = ceiling(_features(lamps, grid, w), l1, l2, say=log)
    both = lamps + always
    log("with the unscored measured lamps also in training:")
    alt = ceiling(
        _features(both, grid, w),
        list(both.level1),
        list(both.level2),
        scored=np.arange(len(both.ids)) < len(lamps.ids),
        say=log,
    )
    log(
        f"with the unscored measured lamps and {MODEL_SAMPLES} uncalibrated "
        "samples of each physical lamp model also in training:"
    )
    m_sp, m_l1, m_fam = physical_model_spectra(
        grid, MODEL_SAMPLES, MODEL_SPREAD, MODEL_SEED
    )
    with_models = ceiling(
        _features_of(np.vstack([np.asarray(both.spectra), m_sp]), grid, w),
        list(both.level1) + m_l1,
        list(both.level2) + [f"model:{f}" for f in m_fam],
        scored=np.arange(len(both.ids) + len(m_l1)) < len(lamps.ids),
        say=log,
    )
    vis = grid <= EXTENSION_START_NM
    log(f"spectra cut at {EXTENSION_START_NM:g} nm (measured for every lamp):")
    visible = ceiling(
        {f"{r} nm": binned_log_spectra(lamps.spectra[:, vis], grid[vis], r)
         for r in RESOLUTIONS_NM},
        l1, l2, say=log,
    )  # fmt: skip
    records = {r.id: r for r in library(wavelength_nm=grid).select().records}
    extended = {}
    for i, c in zip(lamps.ids, lamps.level2, strict=True):
        extended[c] = extended.get(c, 0) + int(records[i].extended)
    families = {}
    for f, c in zip(lamps.level1, lamps.level2, strict=True):
        families.setdefault(c, f)
    summary = {
        "goal": GOAL,
        "features": list(FEATURES),
        "classifiers": list(CLASSIFIERS),
        "families": dict(sorted(families.items())),
        "results": results,
        "best": best_classifiers(results),
        "best_note": "the classifier with the highest class mean per feature set, "
        "chosen on the same held-out results (an optimistic ceiling)",
        "with_unscored_training_lamps": {
            "lamps": {
                c: int(np.sum(np.asarray(always.level2, object) == c))
                for c in sorted(set(always.level2))
            },
            "results": alt,
            "best": best_classifiers(alt),
        },
        "with_physical_models": {
            "models": {f: int(m_fam.count(f)) for f in sorted(set(m_fam))},
            "level1": {f: l for f, l in sorted(zip(m_fam, m_l1, strict=True))},
            "samples_per_family": MODEL_SAMPLES,
            "z_spread": MODEL_SPREAD,
            "seed": MODEL_SEED,
            "note": "training also holds the unscored measured lamps and modelled "
            "lamps of every physical model family of bandopt.lampmodels, "
            "calibrated on no measured lamp (z normal about the family's default "
            "start); they train and are never held out or scored; fluorescent "
            "lamps have no physical model",
            "modelled_lamps_used": True,
            "results": with_models,
            "best": best_classifiers(with_models),
        },
        "visible_only": {
            "range_nm": [float(grid[vis][0]), float(grid[vis][-1])],
            "note": "binned spectra cut at the end of the range every lamp is "
            "measured in; beyond it the library extends some spectra by the "
            "per-technology model of bandopt.datasets.nir (`extended_lamps`)",
            "extended_lamps": dict(sorted(extended.items())),
            "results": visible,
            "best": best_classifiers(visible),
        },
        "inversion_on_scenes": inversion_from_summary(INVERSION_SOURCE),
        "features_note": "bare lamp spectra per lumen on the 380-900 nm, 1 nm grid; "
        "binned (trailing samples that do not fill a bin dropped) or band-averaged "
        "with the recommended bands' responses; log of the fractions of their sum "
        f"(floored at {LOG_FLOOR:g}); no surface, atmosphere, Moon or noise",
        "bands": {
            "recommended": str(RECOMMENDED),
            "names": list(bands.names),
            "centre_nm": [float(v) for v in np.asarray(bands.centre_nm)],
            "fwhm_nm": [float(v) for v in np.asarray(bands.fwhm_nm)],
        },
        "training_lamps": "measured lamps of the other scored classes "
        "(`with_unscored_training_lamps`: also the unscored measured lamps)",
        "scored_lamps": "measured lamps only",
        "modelled_lamps_used": True,
        "modelled_lamps_note": "only in the `with_physical_models` variant, "
        "where they train and are never scored",
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    figure(summary, out / "ceiling.png")
    if args.out is None:
        update_readme_section(
            "unseen-ceiling",
            readme_text(summary),
            heading="## Ceiling of the level-1 family of unseen lamp types",
        )
    write_manifest(
        out,
        seed=0,
        config={
            "resolutions_nm": list(RESOLUTIONS_NM),
            "features": list(FEATURES),
            "classifiers": list(CLASSIFIERS),
            "logistic_max_iter": MAX_ITER,
            "log_floor": LOG_FLOOR,
            "goal": GOAL,
            "bands": str(RECOMMENDED),
            "inversion_source": str(INVERSION_SOURCE),
            "inversion_labels": list(INVERSION_LABELS),
            "scored_lamps": "measured lamps only",
            "training_lamps": "measured lamps of the other scored classes; "
            "variant: also the unscored measured lamps",
            "visible_only_end_nm": EXTENSION_START_NM,
            "model_samples_per_family": MODEL_SAMPLES,
            "model_z_spread": MODEL_SPREAD,
            "model_seed": MODEL_SEED,
            "modelled_lamps_used": "variant with_physical_models only (training)",
        },
    )
    log(f"done: {out} ({time.time() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
