"""The classifiers of the unseen-ceiling study (`bandopt.studies.unseen_ceiling`)
and the features they see: bare lamp spectra binned or band-averaged, as
log fractions of their sum; each scored level-2 class held out in turn, a
classifier trained on the others names its level-1 family."""

import time
from collections.abc import Callable, Sequence

import numpy as np

from .. import lampmodels
from ..datasets.lamps import LEVEL2_PARENT
from ..forward import band_values


RESOLUTIONS_NM = (5, 10, 20, 50)
"""Bin widths of the binned spectra [nm]."""
BANDS_FEATURE = "bands"
"""Feature-set label of the recommended bands' values."""
FEATURES = (*(f"{r} nm" for r in RESOLUTIONS_NM), BANDS_FEATURE)
"""Feature-set labels, in table order."""
CLASSIFIERS = ("1-NN", "logistic C=1", "logistic C=0.01")
"""Classifier labels (`make_classifier`)."""
GOAL = 0.9
"""The goal for unseen lamp types: the level-1 family right for at least this
fraction of them (class mean) [1]."""
LOG_FLOOR = 1e-6
"""Floor on a bin's fraction of the spectrum before the log [1] (a bin
without light, e.g. beyond a LED's emission, would be log 0)."""
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


def binned_log_spectra(spectra, wavelength_nm, step_nm: float | int) -> np.ndarray:
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
    from sklearn.linear_model import LogisticRegression  # sklearn: start-up time
    from sklearn.neighbors import KNeighborsClassifier  # sklearn: start-up time
    from sklearn.pipeline import make_pipeline  # sklearn: start-up time
    from sklearn.preprocessing import StandardScaler  # sklearn: start-up time

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
    level1: Sequence[str] | np.ndarray,
    level2: Sequence[str] | np.ndarray,
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


def class_mean_score(r: dict) -> float:
    """A result's class mean, -1 when there is none (sorts below every value)."""
    return -1.0 if r["class_mean"] is None else r["class_mean"]


def top_feature(results: dict, best: dict) -> str:
    """The feature set whose best classifier has the highest class mean."""
    return max(results, key=lambda f: class_mean_score(results[f][best[f]]))


def best_classifiers(results: dict) -> dict:
    """{feature: the classifier with the highest class mean} (first of
    `CLASSIFIERS` on a tie). Chosen on the same held-out results it is
    scored on, so the best is an optimistic ceiling."""
    best = {}
    for feat, by in results.items():
        scores = [(class_mean_score(by[n]), -i, n) for i, n in enumerate(by)]
        best[feat] = max(scores)[2]
    return best


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


def lamp_features(spectra, grid, band_weights) -> dict:
    """The feature sets of `FEATURES` of bare spectra: {label: (l, f)}, binned
    at each of `RESOLUTIONS_NM` (`binned_log_spectra`) and band-averaged with
    `band_weights` (`band_log_values`)."""
    feats = {f"{r} nm": binned_log_spectra(spectra, grid, r) for r in RESOLUTIONS_NM}
    feats[BANDS_FEATURE] = band_log_values(spectra, band_weights)
    return feats
