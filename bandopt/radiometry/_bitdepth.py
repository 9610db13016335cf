"""What bit depth costs: LER/G/CCT errors and lamp-type F1 after photon noise
and quantisation (thesis section 4.2.2, Table 4.7).

Pipeline per (scheme, bits): signal electrons of every lamp scene from the
exact photon integral, Gaussian photon/read/dark noise from *common random
numbers* (the same draws for every scheme, so differences come from the
quantiser alone), back to band radiance with the flat-field responsivity,
then `quantiser(L)` (encode, decode). The measured radiances feed

- the LER/G/CCT estimators of `bandopt.estimate` (ridge on centred log band
  ratios, ridge strength and degree by inner folds), fitted on the training
  lamps of each outer fold of `bandopt.folds.nested_lamp_splits` and scored
  on the test lamps: class-balanced MAE over lamps;
- the lamp-type classifier of `bandopt.classify` (`evaluate_band_set`,
  level-2 macro F1 over the pooled outer test folds).

`models="standin"` scores with simple stand-ins instead, named in the result
(`estimator`, `classifier` fields): scikit-learn ridge on centred log band
ratios, and KNN (k = 5) on sum-normalised radiances, both on the same
lamp-grouped outer folds. There is no silent fallback: if the project's
models fail, the error propagates.
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from ..classify import evaluate_band_set
from ..datasets.lamps import library
from ..estimate import (
    LampTable,
    fit_estimator,
    lamp_abs_errors,
    lamp_truth,
    log_ratio_features,
)
from ..folds import (
    N_OUTER_FOLDS,
    class_balanced_mae,
    nested_lamp_splits,
    stratified_lamp_folds,
)
from ..forward import band_measurement, scenario_table
from ..names import validate_method
from ..photometry import metrics
from ..scene import ScenarioSet
from ..sensor import SensorParams


MODELS = ("bandopt", "standin")
"""Scoring models of `score`: the project's (`bandopt.estimate`,
`bandopt.classify`) or the stand-ins (module docstring)."""


@dataclasses.dataclass(frozen=True)
class Measurements:
    """Lamp scenes of a scenario set as rows (C order over lamp, surface,
    atmosphere, Moon, class).

    - `clean`: noise-free band radiance, `(n, b)`. [W m⁻² sr⁻¹ nm⁻¹]
    - `noisy`: with photon noise, not quantised, `(n, b)`. [W m⁻² sr⁻¹ nm⁻¹]
    - `responsivity_e`: flat-field responsivity, `(b,)`. [e- per W m⁻² sr⁻¹ nm⁻¹]
    - `lamp_of`: lamp index of each row, `(n,)`.
    """

    clean: np.ndarray
    noisy: np.ndarray
    responsivity_e: np.ndarray
    lamp_of: np.ndarray


def measure(
    scen: ScenarioSet, bands, params: SensorParams | None = None, *, seed: int = 0
) -> Measurements:
    """Noise-free and noisy band radiances of every lamp scene:
    `bandopt.forward.band_measurement` (module docstring), draws
    `bandopt.forward.noise_draws(seed, scenes, bands)`."""
    m = band_measurement(scen, bands, sensor=params, noise=True, key=seed)
    b = m.clean.shape[-1]
    clean = np.asarray(m.clean).reshape(-1, b)
    noisy = np.asarray(m.radiance).reshape(-1, b)
    lamp_of = np.repeat(
        np.arange(len(scen.lamp_ids)), clean.shape[0] // len(scen.lamp_ids)
    )
    return Measurements(clean, noisy, np.asarray(m.responsivity_e), lamp_of)


# ------------------------------------------------------------------------------
# scoring


def _lamp_meta(scen: ScenarioSet):
    lib = library()
    rec = {r.id: r for r in lib.records}
    classes = np.asarray([rec[i].level2 for i in scen.lamp_ids], dtype=object)
    return classes


def _estimation_scores(radiance, scen, lamp_of, classes, seed, standin=False):
    """Class-balanced test MAE per metric over lamp-grouped outer folds."""
    splits = nested_lamp_splits(classes, seed=seed)
    spectra = np.asarray(scen.factors.lamp)
    grid = np.asarray(scen.factors.wavelength_nm)
    if standin:
        errs, valid = _standin_estimation(radiance, spectra, grid, lamp_of, splits)
        name = "stand-in: sklearn Ridge on centred log band ratios"
    else:
        truth, valid = lamp_truth(spectra, grid)
        table = LampTable(lamp_of, classes, truth, valid)
        errs = np.full((len(classes), 3), np.nan)
        for s in splits:
            est = fit_estimator(radiance, table, s.train, s.inner)
            pred = np.asarray(est.predict(jnp.asarray(radiance)))
            errs[s.test] = lamp_abs_errors(pred, table, s.test)
        name = "bandopt.estimate.fit_estimator"
    out = {}
    for m, metric in enumerate(("LER", "G", "CCT")):
        ok = np.isfinite(errs[:, m])
        out[f"{metric}_mae"] = class_balanced_mae(errs[ok, m], classes[ok])
    out["estimator"] = name
    return out


def _standin_estimation(radiance, spectra, grid, lamp_of, splits):
    """Stand-in estimator: sklearn Ridge(alpha=1e-3) on centred log ratios."""
    from sklearn.linear_model import Ridge  # sklearn: start-up time

    vis = (grid >= 380) & (grid <= 780)
    m = metrics(spectra[:, vis], grid[vis])
    truth = np.stack(
        [np.asarray(m["LER"]), np.asarray(m["G"]), np.asarray(m["CCT"])], 1
    )
    valid = np.isfinite(truth)
    valid[:, 2] &= ~np.asarray(m["CCT_flag"])
    x = np.asarray(log_ratio_features(radiance))
    errs = np.full(truth.shape, np.nan)
    for s in splits:
        tr = np.isin(lamp_of, s.train)
        for k in range(3):
            ok = tr & valid[lamp_of, k]
            y = truth[lamp_of, k] if k < 2 else 1e6 / truth[lamp_of, k]
            model = Ridge(alpha=1e-3).fit(x[ok], y[ok])
            pred = model.predict(x)
            pred = pred if k < 2 else 1e6 / pred
            for lamp in s.test:
                if valid[lamp, k]:
                    errs[lamp, k] = np.abs(
                        pred[lamp_of == lamp] - truth[lamp, k]
                    ).mean()
    return errs, valid


def _classification_score(
    radiance, scen, lamp_of, classes, seed, table_cache, standin=False
):
    if standin:
        return {
            "macro_f1": _standin_f1(radiance, lamp_of, classes, seed),
            "classifier": "stand-in: KNN k=5 on sum-normalised radiance",
        }
    if "table" not in table_cache:
        table_cache["table"] = scenario_table(scen)
    res = evaluate_band_set(
        table_cache["table"],
        None,
        levels=("level2",),
        noise=True,
        fold_seed=seed,
        radiance=radiance,
    )
    return {
        "macro_f1": float(res.level2.macro_f1),
        "classifier": "bandopt.classify.evaluate_band_set (level 2)",
    }


def _standin_f1(radiance, lamp_of, classes, seed):
    """Stand-in classifier: KNN (k = 5) on sum-normalised radiance, level-2
    macro F1 over the pooled outer test folds."""
    from sklearn.metrics import f1_score  # sklearn: start-up time
    from sklearn.neighbors import KNeighborsClassifier

    r = np.maximum(radiance, 0.0)
    tot = r.sum(1, keepdims=True)
    x = np.where(tot > 0, r / np.where(tot > 0, tot, 1.0), 1.0 / r.shape[1])
    y = classes[lamp_of]
    yt, yp = [], []
    for test in stratified_lamp_folds(classes, N_OUTER_FOLDS, seed):
        te = np.isin(lamp_of, test)
        clf = KNeighborsClassifier(5).fit(x[~te], y[~te])
        yt.append(y[te])
        yp.append(clf.predict(x[te]))
    return float(f1_score(np.concatenate(yt), np.concatenate(yp), average="macro"))


def score(
    radiance: np.ndarray,
    scen: ScenarioSet,
    lamp_of: np.ndarray,
    *,
    seed: int = 0,
    cache: dict | None = None,
    models: str = "bandopt",
) -> dict:
    """LER/G/CCT class-balanced test MAE [lm W⁻¹, 1, K] and level-2 macro F1
    of measured radiances `(n, b)` (module docstring). `models="bandopt"`
    (alias `"auto"`): the project's estimators and classifier, errors
    propagate; `"standin"`: the stand-ins. The result names which ran."""
    models = validate_method(models, MODELS, "models", aliases={"auto": "bandopt"})
    standin = models == "standin"
    cache = {} if cache is None else cache
    classes = _lamp_meta(scen)
    rad = np.asarray(radiance)
    out = _estimation_scores(rad, scen, lamp_of, classes, seed, standin)
    out.update(_classification_score(rad, scen, lamp_of, classes, seed, cache, standin))
    return out


def clipped_fractions(radiance: np.ndarray, detection_limit, saturation) -> dict:
    """Share of measurements at or below the detection limit (DN 0) and at or
    above saturation (DN max), over all bands and scenes. [1]"""
    r = np.asarray(radiance)
    return {
        "fraction_below_limit": float(np.mean(r <= np.asarray(detection_limit))),
        "fraction_saturated": float(np.mean(r >= np.asarray(saturation))),
    }


def bit_depth_rows(
    scen: ScenarioSet,
    bands,
    quantisers: dict,
    params=None,
    *,
    seed: int = 0,
    models: str = "bandopt",
) -> list[dict]:
    """Score every quantiser in `quantisers` (label -> (scheme, bits, quantiser
    or None)); references: scheme "none-clean" (noise-free), "none" (photon
    noise, no quantisation) and "clip" (photon noise clipped to the limits of
    the quantiser given, not quantised)."""
    meas = measure(scen, bands, params, seed=seed)
    cache: dict = {}
    rows = []
    for label, (scheme, bits, q) in quantisers.items():
        if scheme == "none-clean":
            rad = meas.clean
        elif q is None:
            rad = meas.noisy
        elif scheme == "clip":  # q only carries the limits
            lo = np.broadcast_to(np.asarray(q.detection_limit), meas.noisy.shape)
            hi = np.broadcast_to(np.asarray(q.saturation), meas.noisy.shape)
            rad = np.clip(meas.noisy, lo, hi)
        else:
            rad = np.asarray(jax.jit(q.__call__)(jnp.asarray(meas.noisy)))
        row = {"label": label, "scheme": scheme, "bits": bits}
        row.update(
            score(rad, scen, meas.lamp_of, seed=seed, cache=cache, models=models)
        )
        if q is not None:
            row.update(clipped_fractions(meas.noisy, q.detection_limit, q.saturation))
        rows.append(row)
    return rows
