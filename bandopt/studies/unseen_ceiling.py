"""Ceiling of the level-1 family of unseen lamp types.

The goal for lamp types the library has never seen (each scored level-2
class held out in turn) is the level-1 family (led, hid, fluorescent,
incandescent, lps) right for >= 90 % of lamps (`GOAL`). This measures what
is attainable at all with a classifier trained on the library's other
types: the bare lamp spectrum, without surface, atmosphere, Moon or noise,
binned to 5, 10, 20 and 50 nm, and the noise-free values of the recommended
bands (`results/recommendation.json`) of the same spectra; each
fed to a 1-nearest-neighbour classifier and to logistic regression (C = 1
and C = 0.01, classes balanced), trained on the measured lamps of the other
scored classes (`bandopt.studies._ceiling`). A class whose family has no
other class (incandescent_halogen) cannot be named by such a classifier: it
is skipped and reported. Also with the unscored measured lamps (led_rgb,
lps) in training, as the inversion's prior holds them; with, besides those,
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
`results/README.md` (default output only; `_ceiling_text`). Scored: measured
lamps only; modelled lamps train in the `with_physical_models` variant only
(beyond 780 nm a third of the measured lamps are the library's NIR
extension: see `visible_only`). Deterministic (the model samples are
seeded, `MODEL_SEED`; the solvers too).
"""

import argparse
import hashlib
import json
import time
from pathlib import Path

import numpy as np

from .. import inversion as inv_mod
from ..datasets.lamps import library
from ..datasets.nir import EXTENSION_START_NM
from ..provenance import add_allow_dirty, refuse_dirty_at_start
from ..search import get_context
from ._ceiling import (
    BANDS_FEATURE as BANDS_FEATURE,
    CLASSIFIERS as CLASSIFIERS,
    FEATURES as FEATURES,
    GOAL as GOAL,
    LOG_FLOOR as LOG_FLOOR,
    MAX_ITER as MAX_ITER,
    MODEL_SAMPLES as MODEL_SAMPLES,
    MODEL_SEED as MODEL_SEED,
    MODEL_SPREAD as MODEL_SPREAD,
    RESOLUTIONS_NM as RESOLUTIONS_NM,
    band_log_values as band_log_values,
    best_classifiers as best_classifiers,
    binned_log_spectra as binned_log_spectra,
    ceiling as ceiling,
    held_out_class_accuracy as held_out_class_accuracy,
    lamp_features as lamp_features,
    make_classifier as make_classifier,
    physical_model_spectra as physical_model_spectra,
)
from ._ceiling_text import figure as figure, readme_text as readme_text
from ._units import RECOMMENDED, band_set, log as _log, write_outputs


OUT = "results/unseen_ceiling"
INVERSION_SOURCE = Path("results/estimate_mix/summary.json")
"""Where the inversion's unseen-types numbers are read from."""
INVERSION_LABELS = ("inversion-moon", "inversion-moon-mix")
"""The inversion runs of `INVERSION_SOURCE` shown beside the ceiling."""


def log(msg: str) -> None:
    """Progress line on stderr, `[unseen_ceiling HH:MM:SS] msg`."""
    _log(msg, "unseen_ceiling")


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


def run(argv=None) -> int:
    """Compute the study (command line `argv`: `--out`) and write its outputs;
    returns the exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help=f"output (default {OUT})")
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    out = Path(args.out or OUT)
    refuse_dirty_at_start(ap, args, out)
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
    results = ceiling(lamp_features(lamps.spectra, grid, w), l1, l2, say=log)
    both = lamps + always
    log("with the unscored measured lamps also in training:")
    alt = ceiling(
        lamp_features(both.spectra, grid, w),
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
        lamp_features(np.vstack([np.asarray(both.spectra), m_sp]), grid, w),
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
    heading = "## Ceiling of the level-1 family of unseen lamp types"
    return write_outputs(
        out,
        summary,
        [(figure, "ceiling.png")],
        section=("unseen-ceiling", readme_text, heading) if args.out is None else None,
        seed=0,
        say=log,
        t0=t0,
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
