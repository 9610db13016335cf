"""The search's candidates judged by the shipped estimator, clean and
perturbed: which band design `bandopt evaluate` itself serves best.

The band search (`make run`) explores with a closed-form ridge surrogate and
scores its designs with a plain inversion on moonless, unperturbed scenes;
`bandopt evaluate` ships another estimator (`estimators.InversionConfig`
defaults: blends, shifted and Planck spectra in the prior, calibrated
intervals and probabilities, the Moon told) and users hand it spectra with
background, noise, a coarser slit and mixed pixels. This study judges the
search's candidates on that footing: a configuration of the robustness study
(`bandopt.robustness.RobustnessStudy`: lamp-grouped partitions, the inversion
fitted once per (partition, band set) on the training lamps, held-out
measured lamps scored) whose band sets are the search's candidate designs
and the reference sensors, and whose rows are the clean spectra and a set of
realistic measurement effects (`JUDGE_PERTURBATIONS`).

Each (band set, partition) gets one loss, the mean over the rows of

    J = (e + c) / 2,  e = mean over LER, G, CCT of class-balanced MAE / SD,
                      c = 1 - (level-1 right + level-2 right) / 2,

with SD the class-balanced SD of each metric's truth the search normalises by
(`compare.json` "truth_sd"), so estimation and classification count alike.
The choice (`choose`) is the design with the fewest bands whose loss is
within one SD (over partitions) of the best design's, paired by partition:
the search's own band-count rule, applied to the shipped estimator.
"""

import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .. import robustness as rb
from ..estimate import METRICS
from ..folds import paired_lamp_ci
from ..provenance import write_manifest
from ..radiometry import RadiometryConfig
from ..results import RESULTS_DIR, update_recommendation
from ..sensor import BandSet
from ..sensor.reference import load_band_set
from ..strict_json import strict_dumps
from ._judge_instrument import choose_under_instrument, instrument_check
from ._judge_outputs import figure, readme_text, trade_figure


OUT = RESULTS_DIR / "judge"
"""Where `make judge` writes."""

SEARCH = RESULTS_DIR / "search"
"""The band search whose candidates are judged (`make run`)."""

JUDGE_PERTURBATIONS = (
    rb.Perturbation("clean"),
    rb.Perturbation("background-skyglow", 0.01),
    rb.Perturbation("noise", 100.0),
    rb.Perturbation("resolution", 5.0),
    rb.Perturbation("shift", 1.0),
    rb.Perturbation("mixture", 0.1),
    rb.Perturbation("truncation", 780.0),
)
"""The judge's rows: the clean spectra and one realistic level of each
measurement effect of the robustness study (sky glow at 1 % of the visible
power, SNR 100 per nm, a 5 nm slit, a 1 nm shift, 10 % of another lamp type,
a spectrum measured to 780 nm and extended by the product). The type left
out of the prior is not a row: its pixels should be flagged, not typed, so
their level-1 score says nothing about the bands."""

REFERENCES = ("nightsat", "sdgsat-1")
"""Reference sensors judged beside the candidates (same partitions, same
estimator, same rows)."""


def candidates(search: Path = SEARCH) -> list[tuple[str, BandSet]]:
    """The search's candidate designs as band sets, in band-count order: the
    stability medoid of every band count at alpha 0 (`compare.json`
    "designs" ... "stability": the design the search recommends at that
    count) and the recommended design (`recommended_bands.json`, labelled by
    its set name in `compare.json` "pareto"). Each carries the recommended
    set's pan band, slit shape and data range."""
    search = Path(search)
    compare = json.loads((search / "compare.json").read_text())
    rec_path = search / "recommended_bands.json"
    rec = BandSet.from_json(rec_path)
    rec_doc = json.loads(rec_path.read_text())
    pan = rec_doc["bands"][-1]
    if pan["name"].upper() != "PAN":
        raise ValueError(
            f"{rec_path}: bands[-1]: expected the pan band, got {pan['name']!r}"
        )
    lo, hi = rec_doc["range_nm"]
    shape = float(pan["shape_k"])
    rec_key = compare["pareto"]["recommended"]
    out: list[tuple[str, BandSet]] = []
    for key, design in compare["designs"].items():
        stab = design.get("stability")
        if stab is None:
            continue
        c = [*map(float, stab["centre_nm"]), float(pan["centre_nm"])]
        f = [*map(float, stab["fwhm_nm"]), float(pan["fwhm_nm"])]
        names = [f"B{i + 1}" for i in range(len(c) - 1)] + ["PAN"]
        out.append(
            (
                key,
                BandSet.from_physical(
                    c, f, shape, names=names, name=key, lower_nm=lo, upper_nm=hi,
                    min_fwhm_nm=min(f) - 1e-6,
                ),
            )
        )  # fmt: skip
    if rec_key not in {k for k, _ in out}:
        out.append((rec_key, rec))
    return sorted(out, key=lambda kb: (len(kb[1].names), kb[0]))


def study(
    band_sets: Sequence[tuple[str, str]],
    *,
    partitions: int = 4,
    **kwargs,
) -> rb.RobustnessStudy:
    """The robustness study configured as the judge: `band_sets` ((label,
    band-set file or reference name) pairs), `JUDGE_PERTURBATIONS` (unless
    `perturbations=` is given) and `partitions` lamp partitions; other
    `RobustnessStudy` fields as keywords (small test runs)."""
    kwargs.setdefault("perturbations", JUDGE_PERTURBATIONS)
    return rb.RobustnessStudy(
        band_sets=tuple(band_sets), partitions=partitions, **kwargs
    )


def losses(summary: dict, truth_sd: dict, band_sets: Sequence[str]) -> dict:
    """Per band set: the loss J of each partition (module docstring), and
    its estimation part e and classification part c, each the mean over the
    summary's rows of that band set. Rows: the perturbations of
    `summary["perturbations"]`; a band set missing a row or a partition
    raises."""
    rows = {(r["band_set"], r["perturbation"]): r for r in summary["rows"]}
    labels = list(summary["perturbations"])
    out = {}
    for b in band_sets:
        es, cs = [], []
        for lab in labels:
            if (b, lab) not in rows:
                raise ValueError(f"summary: no row for band set {b!r}, {lab!r}")
            r = rows[(b, lab)]
            e = np.mean(
                [
                    np.asarray(r[f"{m}_per_partition"], float) / truth_sd[m]
                    for m in METRICS
                ],
                axis=0,
            )
            c = 1.0 - 0.5 * (
                np.asarray(r["level1_correct_per_partition"], float)
                + np.asarray(r["level2_correct_per_partition"], float)
            )
            es.append(e)
            cs.append(c)
        e, c = np.mean(es, axis=0), np.mean(cs, axis=0)
        if not np.all(np.isfinite(e) & np.isfinite(c)):
            raise ValueError(f"summary: band set {b!r} has undefined errors")
        out[b] = {
            "J_per_partition": (0.5 * (e + c)).tolist(),
            "estimation_per_partition": e.tolist(),
            "classification_per_partition": c.tolist(),
        }
        for part in ("J", "estimation", "classification"):
            v = np.asarray(out[b][f"{part}_per_partition"])
            out[b][part] = float(v.mean())
            out[b][f"{part}_sd"] = float(v.std(ddof=1)) if v.size > 1 else None
    return out


def choose(loss: dict, n_bands: dict) -> dict:
    """The judged choice among `loss`'s band sets (`losses`; `n_bands`: each
    set's total band count): the best is the lowest mean J; each set's paired
    difference to the best (J - J_best per partition, mean and SD); chosen:
    the fewest bands whose mean difference is at most its SD (ties: lower
    J). With one partition the SD is undefined and the best is chosen."""
    best = min(loss, key=lambda b: loss[b]["J"])
    jb = np.asarray(loss[best]["J_per_partition"])
    diff = {}
    for b, v in loss.items():
        d = np.asarray(v["J_per_partition"]) - jb
        sd = float(d.std(ddof=1)) if d.size > 1 else None
        diff[b] = {"mean": float(d.mean()), "sd": sd}
    within = [
        b for b in loss
        if b == best or (diff[b]["sd"] is not None and diff[b]["mean"] <= diff[b]["sd"])
    ]  # fmt: skip
    chosen = min(within, key=lambda b: (n_bands[b], loss[b]["J"]))
    return {
        "rule": "fewest bands whose loss J is within one SD (over partitions, "
        "paired) of the lowest mean J",
        "best": best,
        "chosen": chosen,
        "within_one_sd": sorted(within, key=lambda b: (n_bands[b], b)),
        "difference_to_best": diff,
    }


PARTS = ("J", "estimation", "classification")
"""The loss and its two parts, as `losses` and `paired` name them."""

INTERVAL_NOTE = (
    "ci95: 95 % percentile bootstrap interval of the paired difference "
    "(per partition the class-balanced mean over held-out lamps, then the "
    "mean over partitions, as `mean`), lamps resampled within level-2 class "
    "(2,000 draws, seed 0); a lamp's loss in a partition is its mean over "
    "the rows"
)
"""What a `ci95` of `paired` is."""


class LampLosses(NamedTuple):
    """`lamp_losses`: J, e and c per (band set, lamp, partition, row), and
    each lamp's level-2 class."""

    losses: dict[tuple, tuple[float, float, float]]
    classes: dict[str, str]


def lamp_losses(records: Sequence[dict], truth_sd: dict) -> LampLosses:
    """Per (band set, lamp, partition, row) of `records` (robustness records:
    one per held-out lamp), that lamp's J, e and c (module docstring), and
    per lamp its level-2 class. A record without every metric (a lamp whose
    every pixel was flagged `unexplained`) has no loss."""
    out = LampLosses({}, {})
    for r in records:
        if any(r.get(m) is None for m in METRICS):
            continue
        e = float(np.mean([float(r[m]) / truth_sd[m] for m in METRICS]))
        c = 1.0 - 0.5 * (float(r["level1_correct"]) + float(r["level2_correct"]))
        key = (r["band_set"], r["lamp"], r["partition"], r["perturbation"])
        out.losses[key] = (0.5 * (e + c), e, c)
        out.classes[r["lamp"]] = r["level2"]
    return out


def _lamp_ci(per_lamp: LampLosses, ours: str, other: str) -> dict:
    """Per part, the 95 % interval of the paired difference ours - other
    (`paired_lamp_ci`: per partition class-balanced over held-out lamps,
    then the mean over partitions), each (lamp, partition) its mean over the
    rows both band sets have a loss in (`lamp_losses`)."""
    diffs: dict[tuple, list] = {}
    for key, v in per_lamp.losses.items():
        if key[0] != ours:
            continue
        w = per_lamp.losses.get((other, *key[1:]))
        if w is not None:
            diffs.setdefault(key[1:3], []).append(np.subtract(v, w))
    if not diffs:
        return {}
    keys = sorted(diffs)
    d = np.asarray([np.mean(diffs[k], axis=0) for k in keys])
    lamps = [k[0] for k in keys]
    obs = {
        "lamps": lamps,
        "classes": [per_lamp.classes[x] for x in lamps],
        "groups": [k[1] for k in keys],
    }
    out = {}
    for i, part in enumerate(PARTS):
        _, lo, hi = paired_lamp_ci(d[:, i], **obs)
        out[part] = [lo, hi]
    return out


def paired(
    loss: dict, ours: str, others: Sequence[str], per_lamp: LampLosses | None = None
) -> dict:
    """Paired differences ours - other in J, e and c, per partition: mean and
    SD (negative: ours is better); with `per_lamp` (`lamp_losses`) also the
    95 % interval over lamps (`ci95`, `INTERVAL_NOTE`)."""
    out = {}
    for o in others:
        out[o] = {}
        ci = _lamp_ci(per_lamp, ours, o) if per_lamp is not None else {}
        for part in PARTS:
            d = np.asarray(loss[ours][f"{part}_per_partition"]) - np.asarray(
                loss[o][f"{part}_per_partition"]
            )
            out[o][part] = {
                "mean": float(d.mean()),
                "sd": float(d.std(ddof=1)) if d.size > 1 else None,
                **({"ci95": ci[part]} if part in ci else {}),
            }
    return out


def verdict(
    summary: dict,
    truth_sd: dict,
    band_sets: Sequence[str],
    n_bands: dict,
    searched: str,
    references: Sequence[str],
    records: Sequence[dict] | None = None,
) -> dict:
    """The judge's result (`judge.json`): losses per band set, the choice
    among the candidates (`band_sets` minus `references`), the search's own
    recommendation `searched` against it, and the chosen design against each
    reference sensor, paired by partition; with the study's `records`, each
    paired difference also with its 95 % interval over lamps."""
    loss = losses(summary, truth_sd, band_sets)
    per_lamp = lamp_losses(records, truth_sd) if records is not None else None
    cands = [b for b in band_sets if b not in references]
    choice = choose({b: loss[b] for b in cands}, n_bands)
    clean = {
        r["band_set"]: {
            k: r.get(k)
            for k in (
                "level1_correct",
                "level2_correct",
                *METRICS,
                "ECE",
                "unexplained",
            )
        }
        for r in summary["rows"]
        if r["kind"] == "clean"
    }
    return {
        "loss": "J = (e + c) / 2 per partition, mean over rows; e = mean over "
        "LER, G, CCT of class-balanced MAE / truth SD; c = 1 - (level-1 right "
        "+ level-2 right) / 2",
        "truth_sd": truth_sd,
        "rows": list(summary["perturbations"]),
        "n_bands": n_bands,
        "losses": loss,
        "choice": choice,
        "searched": searched,
        "agrees_with_search": choice["chosen"] == searched,
        "searched_minus_chosen": paired(loss, searched, [choice["chosen"]], per_lamp)[
            choice["chosen"]
        ],
        "chosen_minus_reference": paired(loss, choice["chosen"], references, per_lamp),
        **({"interval_note": INTERVAL_NOTE} if per_lamp is not None else {}),
        "clean": clean,
    }


def _load(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def recommendation_entry(
    result: dict,
    compare: dict,
    bands: BandSet,
    judge_json: str,
    stability_doc: dict | None = None,
) -> dict:
    """The "spectral" recommendation for the judged choice: the chosen
    design's bands (with the search's stability intervals of that design
    where it has them), how it was chosen, its loss, the search's own pick
    against it, and the search's surrogate score of the design (`test_mae`,
    from `compare.json`, so the search section's numbers stay traceable) and
    the solvers that found it (`search`: the search's `stability.json`
    optimiser notes, this design's convergence in `compare.json`)."""
    ch = result["choice"]
    key = ch["chosen"]
    design = compare.get("designs", {}).get(key, {})
    stab = design.get("stability") or {}
    rows = []
    for i, b in enumerate(bands.to_dict()["bands"]):
        name = b["name"]
        row = {"name": name, "centre_nm": b["centre_nm"], "fwhm_nm": b["fwhm_nm"]}
        for k, v in (("centre_interval_nm", b["centre_nm"]),
                     ("fwhm_interval_nm", b["fwhm_nm"])):  # fmt: skip
            ranges = stab.get(k) or []
            # the fixed PAN band (and a design without resamples): no range
            row[k] = [float(x) for x in ranges[i]] if i < len(ranges) else [v, v]
        rows.append(row)
    loss = result["losses"][key]
    entry = {
        "set": key,
        "bands": rows,
        "band_set": bands.to_dict(),
        "chosen_by": "judge",
        "intervals": "centre/fwhm_interval_nm: range (min-max) of the design "
        "over the search's lamp resamples (compare.json designs/<set>/"
        "stability); the PAN band is fixed",
        "tolerances": "from the shipped estimator's own scan of this design, "
        "results/robustness/tolerance/tolerance.json (make robustness "
        'ARGS="--config tolerance"); the search\'s tolerance scan, '
        "results/search/tolerance.json, is of the search's own pick",
        "rules": {
            "choice": ch["rule"],
            "loss": result["loss"],
            "rows": result["rows"],
            "design": stab.get("rule"),
        },
        "judge": {
            "J": loss["J"],
            "J_sd": loss["J_sd"],
            "partitions": len(loss["J_per_partition"]),
            "clean": result["clean"].get(key, {}),
            "chosen_minus_reference": result["chosen_minus_reference"],
        },
        "search_pick": {
            "set": result["searched"],
            "minus_chosen": result["searched_minus_chosen"],
        },
        "estimator": "shipped inversion (bandopt evaluate's defaults, "
        "estimators.InversionConfig), fitted per lamp partition on the "
        "training lamps; held-out measured lamps scored",
        "source": judge_json,
    }
    conv = design.get("convergence") or {}
    if stability_doc is not None and "optimiser" in stability_doc:
        opt = stability_doc["optimiser"]
        entry["search"] = {
            "global": opt["global"],
            "local": opt["local"],
            "designs_converged": conv.get("designs_converged"),
            "designs": conv.get("designs"),
        }
    if "mae_mean" in design:
        entry["test_mae"] = {
            "partitions": design.get("partitions"),
            "mae_mean": design["mae_mean"],
            "mae_sd": design.get("mae_sd"),
            "f1_mean": design.get("f1_mean"),
            "note": "the search's surrogate score of this design "
            "(compare.json), not the shipped estimator's",
        }
    return entry


def snr_medians(compare: dict, band_sets) -> dict:
    """Each judged band set's median SNR as the search computed it
    (`search.design_snr`: over its scenes at EN 13201 class P4, the weakest
    band's shot-noise SNR; not the SNR at the detection limit of
    `results/radiometry`) (`compare.json`: its designs and its reference
    sensors, the same instrument and scenes); band sets it lacks are left
    out."""
    out = {}
    for k in band_sets:
        for kind in ("designs", "references"):
            v = compare.get(kind, {}).get(k, {}).get("snr_median")
            if v is not None:
                out[k] = v
                break
    return out


def run(
    out: Path = OUT,
    *,
    search: Path = SEARCH,
    partitions: int = 4,
    only_partitions: Sequence[int] | None = None,
    resume: bool = False,
    instrument: RadiometryConfig | bool = True,
    log: Callable[[str], None] = lambda msg: None,
    **study_kwargs,
) -> dict | None:
    """Judge the candidates of the search in `search`: band-set files in
    `out/candidates/`, records in `out/records.jsonl.gz` (resumable per
    (partition, band set)), then `summary.json` (the robustness rows),
    `judge.json`, `judge.png`, `README.md`, the chosen design
    (`recommended_bands.json`), its "spectral" recommendation (in
    `results/recommendation.json` when `out` is the shipped `OUT`, else in
    `out/recommendation.json`) and the manifest. With
    `only_partitions`, only those units are computed and nothing is
    summarised (returns None); a later `resume=True` run joins them.
    `instrument`: the radiometry configuration of the instrument check
    (`_judge_instrument`; True: `make radiometry`'s, False: none)."""
    out = Path(out)
    cands = candidates(search)
    cand_dir = out / "candidates"
    cand_dir.mkdir(parents=True, exist_ok=True)
    band_sets = []
    for key, bands in cands:
        path = cand_dir / (
            key.replace(" ", "_").replace("+", "_").replace("=", "") + ".json"
        )
        bands.to_json(path)
        band_sets.append((key, str(path)))
    band_sets += [(r, r) for r in REFERENCES]
    st = study(band_sets, partitions=partitions, **study_kwargs)
    t0 = time.time()
    records = rb.run_study(
        st, out / "records.jsonl.gz", resume=resume, partitions=only_partitions,
        log=lambda m: log(f"{m} ({time.time() - t0:.0f} s)"),
    )  # fmt: skip
    if only_partitions is not None:
        return None
    summary = rb.summarise(records, st, versus=False)  # peers: paired in judge.json
    compare = json.loads((Path(search) / "compare.json").read_text())
    n_bands = {label: len(load_band_set(src).names) for label, src in band_sets}
    result = verdict(
        summary, compare["truth_sd"], [b for b, _ in band_sets], n_bands,
        compare["pareto"]["recommended"], REFERENCES, records,
    )  # fmt: skip
    result["snr_median"] = snr_medians(compare, result["losses"])
    result["snr_note"] = (
        "snr_median: the search's median over its scenes (EN 13201 class P4, "
        "shot noise only) of the weakest band's SNR (compare.json, the same "
        "instrument and scenes for designs and reference sensors), not the SNR "
        "at the detection limit of results/radiometry, which adds background, "
        "dark and read noise; the loss J does not weigh it, so "
        "the trade between a better estimate and a harder instrument is read "
        "beside it (results/radiometry gives the recommended design's exposure "
        "factor)"
    )
    result["narrowest_fwhm_nm"] = {
        label: float(np.min(load_band_set(src).fwhm_nm)) for label, src in band_sets
    }
    if instrument is not False:
        config = None if instrument is True else instrument
        inst = instrument_check(band_sets, config=config, log=log)
        loss = result["losses"]
        result["instrument"] = inst
        result["choice_under_instrument"] = choose_under_instrument(
            inst,
            [b for b, _ in band_sets if b not in REFERENCES],
            lambda meeting: choose({b: loss[b] for b in meeting}, n_bands)["chosen"],
            result["choice"]["chosen"],
        )
    (out / "summary.json").write_text(strict_dumps(summary, indent=2) + "\n")
    (out / "judge.json").write_text(strict_dumps(result, indent=2) + "\n")
    figure(result, out / "judge.png")
    trade_figure(result, out / "trade.png")
    (out / "README.md").write_text(readme_text(result))
    chosen = dict(band_sets)[result["choice"]["chosen"]]
    bands = BandSet.from_json(chosen)
    bands.to_json(out / "recommended_bands.json")
    shipped = out.resolve() == OUT.resolve()
    update_recommendation(
        "spectral",
        recommendation_entry(
            result,
            compare,
            bands,
            str(out / "judge.json"),
            _load(Path(search) / "stability.json"),
        ),
        path=None if shipped else out / "recommendation.json",
    )
    write_manifest(out, seed=st.seed, config={**st.to_dict(), "search": str(search)})
    return result
