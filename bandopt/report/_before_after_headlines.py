"""The headline numbers of each experiment folder: which result files hold
them (`EXPERIMENTS`, `HEADLINES`), one extractor per file giving (key,
quantity label, value), and where a run records the number of lamps it
used."""

from ._before_after_files import Files
from ._checks import spatial_median


# ---------------------------------------------------------------------------
# headline extractors: (key, quantity label, value) per experiment and file

Headline = tuple[str, str, object]
MAE_UNITS = {"LER": "lm/W", "G": "1", "CCT": "K"}


def _keyed(f: Files, name: str, table, obj=None) -> list[Headline]:
    """Headlines (key, label, value at path) of `table`, rows (key, label,
    path inside file `name` or inside `obj`, a part of it)."""
    return [(key, label, f.get(name, path, obj)) for key, label, path in table]


def _search_compare(f: Files) -> list[Headline]:
    n = "compare.json"
    rec = f.get(n, "pareto/recommended")
    design = f.get(n, f"designs/{rec}")
    out = _keyed(
        f,
        n,
        (
            ("chosen_n", "chosen number of free bands (+ pan)", "band_count/chosen_n"),
            (
                "best_n",
                "band count with the lowest normalised MAE",
                "band_count/best_n",
            ),
        ),
    )
    out.append(("recommended", "recommended design", rec))
    out += _keyed(
        f,
        n,
        [("norm_mae", "recommended: normalised MAE [1]", "norm_mae_mean")]
        + [
            (f"mae_{m}", f"recommended: {m} MAE [{u}]", f"mae_mean/{m}")
            for m, u in MAE_UNITS.items()
        ]
        + [("f1", "recommended: level-2 macro F1 [1]", "f1_mean")],
        design,
    )
    for ref in ("sdgsat-1", "nightsat"):
        out += _keyed(
            f,
            n,
            [
                (
                    f"reduction_{ref}_{m}",
                    f"{m} MAE reduction vs {ref} [1]",
                    f"reductions/{ref}/recommended/{m}/reduction",
                )
                for m in MAE_UNITS
            ],
        )
    return out


def _search_bands(f: Files) -> list[Headline]:
    n = "recommended_bands.json"
    bands = f.get(n, "bands")
    return [
        ("band_names", "recommended bands", [f.get(n, "name", b) for b in bands]),
        ("centre_nm", "band centres [nm]", [f.get(n, "centre_nm", b) for b in bands]),
        ("fwhm_nm", "band FWHM [nm]", [f.get(n, "fwhm_nm", b) for b in bands]),
    ]


def _classify_summary(f: Files) -> list[Headline]:
    n = "summary.json"
    chosen = f.get(n, "chosen_n_bands")
    out = [
        ("chosen_n", "chosen number of bands", chosen),
        (
            "nested_l2",
            "chosen n: nested level-2 macro F1 [1]",
            f.get(n, "recommended/bands/level2_macro_f1_nested"),
        ),
    ]
    for noise in ("noisy", "noise_free"):
        out += [
            (
                f"rec_{noise}_{lvl}",
                f"recommended set, {noise.replace('_', '-')}: {lvl} macro F1 [1]",
                f.get(n, f"recommended/{noise}/{lvl}/macro_f1"),
            )
            for lvl in ("level1", "level2")
        ]
    for r in f.get(n, "band_count"):
        if f.get(n, "method", r) == "nlopt":
            k = f.get(n, "n_bands", r)
            out += [
                (
                    f"nested_{k}_{lvl}",
                    f"{k} bands (nested, nlopt): {lvl} macro F1 [1]",
                    f.get(n, f"{lvl}_macro_f1", r),
                )
                for lvl in ("level1", "level2")
            ]
    refs = f.get(n, "reference_sensors")
    names = ["sdgsat-1", "nightsat", "viirs-dnb"]
    names += [
        r["sensor"]
        for r in refs
        if str(r.get("sensor", "")).startswith("spectral") and r.get("noise")
    ]
    for s in names:
        r = f.row(n, refs, sensor=s, noise=True)
        out += [
            (
                f"ref_{s}_{lvl}",
                f"{s} (photon noise): {lvl} macro F1 [1]",
                f.get(n, f"{lvl}_macro_f1", r),
            )
            for lvl in ("level1", "level2")
        ]
    goal = f.get(n, f"goal/{chosen}")
    out += [
        (
            "goal_margin",
            "chosen n: level-2 F1 margin over best reference [1]",
            f.get(n, "margin", goal),
        ),
        (
            "goal_met",
            "goal (>= 10 points above best reference) met",
            f.get(n, "met", goal),
        ),
    ]
    return out


RADIOMETRY_SETS = ("sdgsat-1", "nightsat", "viirs-dnb")
RADIANCE = "W m-2 sr-1 nm-1"


def _radiometry_summary(f: Files) -> list[Headline]:
    n = "summary.json"
    out = _keyed(
        f,
        n,
        (
            (
                "linear_bits",
                "recommended linear bit depth",
                "bit_depth/recommended_linear_bits",
            ),
            (
                "companded_bits",
                "recommended companded bit depth",
                "bit_depth/recommended_companded_bits",
            ),
            (
                "ner_bits",
                "linear bits for a step <= NER at the limit",
                "bits_linear_step_le_ner_at_limit",
            ),
        ),
    )
    clip = f.row(n, f.get(n, "bit_depth_table"), scheme="clip")
    out += [
        (
            f"clip_{m}",
            f"noise, clipped, unquantised: {m} MAE [{u}]",
            _num(f.get(n, f"{m}_mae", clip)),
        )
        for m, u in MAE_UNITS.items()
    ]
    out.append(
        (
            "clip_f1",
            "noise, clipped, unquantised: level-2 macro F1 [1]",
            f.get(n, "macro_f1", clip),
        )
    )
    return out


def _radiometry_limits(f: Files) -> list[Headline]:
    n = "limits.csv"
    rows = f.load(n)
    out = []
    for r in (r for r in rows if r.get("band_set") == "ours"):
        b = f.get(n, "band", r)
        out += [
            (
                f"ours_{b}_limit",
                f"ours {b}: detection limit [{RADIANCE}]",
                _num(f.get(n, "detection_limit_w_m2_sr_nm", r)),
            ),
            (
                f"ours_{b}_saturation",
                f"ours {b}: saturation [{RADIANCE}]",
                _num(f.get(n, "saturation_w_m2_sr_nm", r)),
            ),
            (
                f"ours_{b}_bits",
                f"ours {b}: linear bits for a step <= NER",
                int(_num(f.get(n, "bits_linear_step_le_ner_at_limit", r))),
            ),
        ]
    if not out:
        raise ValueError(f"{f.where(n)}: no rows of band set 'ours'.")
    for s in RADIOMETRY_SETS:
        sel = [r for r in rows if r.get("band_set") == s]
        if not sel:
            raise ValueError(f"{f.where(n)}: no rows of band set {s!r}.")
        lim = [_num(f.get(n, "detection_limit_w_m2_sr_nm", r)) for r in sel]
        sat = [_num(f.get(n, "saturation_w_m2_sr_nm", r)) for r in sel]
        bits = [int(_num(f.get(n, "bits_linear_step_le_ner_at_limit", r))) for r in sel]
        out += [
            (
                f"{s}_limit",
                f"{s}: detection limit, min-max over bands [{RADIANCE}]",
                [min(lim), max(lim)],
            ),
            (
                f"{s}_saturation",
                f"{s}: saturation, min-max over bands [{RADIANCE}]",
                [min(sat), max(sat)],
            ),
            (
                f"{s}_bits",
                f"{s}: linear bits for a step <= NER, max over bands",
                max(bits),
            ),
        ]
    return out


def _spatial_summary(f: Files) -> list[Headline]:
    n = "summary.json"
    per = f.get(n, "gsd_needed_m")
    scenes = {k: f.get(n, "coarsest_gsd_m", v) for k, v in per.items()}
    out = [
        (
            "median_gsd",
            "median coarsest working GSD, rows and arrangements [m]",
            _or_none(spatial_median(f.load(n))),
        ),
        (
            "single_gsd",
            "single lamp: coarsest working GSD [m]",
            _or_none(f.get(n, "gsd_needed_m/single/coarsest_gsd_m")),
        ),
    ]
    out += [
        (
            f"arrangement_{a}",
            f"{a}: coarsest working GSD [m]",
            _or_none(f.get(n, f"gsd_needed_m/{a}/coarsest_gsd_m")),
        )
        for a in f.get(n, "config/arrangements")
    ]
    out += [
        ("scenes", "scenes", len(scenes)),
        ("never", "scenes detected at no GSD", sum(v is None for v in scenes.values())),
    ]
    return out


def _spatial_overlap(f: Files) -> list[Headline]:
    n = "overlap.json"
    rows = f.get(n, "rows")
    return [
        (
            "overlap_gsd",
            "overlapping lamp types: GSDs [m]",
            [f.get(n, "gsd_m", r) for r in rows],
        ),
    ] + [
        (
            f"overlap_{k}",
            f"overlapping lamp types: {label} by GSD [1]",
            [f.get(n, k, r) for r in rows],
        )
        for k, label in (
            ("macro_f1", "macro F1"),
            ("f1_pure", "F1 one-type pixels"),
            ("f1_mixed", "F1 mixed pixels"),
        )
    ]


def _estimate_summary(f: Files) -> list[Headline]:
    n = "summary.json"
    out = []
    for r in f.load(n):
        key = "/".join(
            str(f.get(n, k, r)) for k in ("band_set", "estimator", "surface")
        )
        out.append(
            (
                f"mae_{key}",
                f"{key.replace('/', ', ')}: class-balanced MAE "
                "LER [lm/W], G [1], CCT [K]",
                [f.get(n, m, r) for m in MAE_UNITS],
            )
        )
    if not out:
        raise ValueError(f"{f.where(n)}: no rows.")
    return out


def _estimate_coverage(f: Files) -> list[Headline]:
    n = "coverage.json"
    out = []
    for part, label in (
        ("held_out_lamps", "held-out lamps"),
        ("unseen_types", "unseen types"),
    ):
        for key, cov in f.get(n, part).items():
            out.append(
                (
                    f"coverage_{part}_{key}",
                    f"90 % interval coverage, {label}, {key}: LER, G, CCT [1]",
                    [f.get(n, f"{m}_coverage", cov) for m in MAE_UNITS],
                )
            )
    return out


def _noise_aware(f: Files) -> list[Headline]:
    n = "noise_aware.json"
    out = []
    for r in f.get(n, "rows"):
        lvl = f.get(n, "level", r)
        bands = f.get(n, "bands", r)
        out += [
            (f"{lvl}_cv_loss", f"{lvl}: CV loss [1]", f.get(n, "cv_loss", r)),
            (f"{lvl}_centre_nm", f"{lvl}: band centres [nm]", [b[0] for b in bands]),
            (f"{lvl}_fwhm_nm", f"{lvl}: band FWHM [nm]", [b[1] for b in bands]),
        ]
    return out


# ---------------------------------------------------------------------------
# lamps used (experiment-specific: what the run's files record)


def _lamps_search(f):
    return f.get("compare.json", "context/n_lamps")


def _lamps_classify(f):
    return len(f.load("lamp_accuracy.csv"))


def _lamps_radiometry(f):
    return f.get("summary.json", "scenario_shape/0")


def _lamps_spatial(f):
    return f"1 ({f.get('summary.json', 'config/lamp')})"


def _lamps_estimate(f):
    return max(
        f.get("summary.json", "lamps_per_partition", r) for r in f.load("summary.json")
    )


EXPERIMENTS: dict[str, dict] = {
    "search": {
        "files": ("compare.json", "recommended_bands.json"),
        "headlines": (
            ("compare.json", _search_compare),
            ("recommended_bands.json", _search_bands),
        ),
        "lamps_used": (
            "compare.json",
            _lamps_search,
            "scored lamps, compare.json context/n_lamps",
        ),
    },
    "classify": {
        "files": ("summary.json", "lamp_accuracy.csv"),
        "headlines": (("summary.json", _classify_summary),),
        "lamps_used": (
            "lamp_accuracy.csv",
            _lamps_classify,
            "scored lamps, rows of lamp_accuracy.csv",
        ),
    },
    "radiometry": {
        "files": ("summary.json", "limits.csv"),
        "headlines": (
            ("summary.json", _radiometry_summary),
            ("limits.csv", _radiometry_limits),
        ),
        "lamps_used": (
            "summary.json",
            _lamps_radiometry,
            "lamps, summary.json scenario_shape/0",
        ),
    },
    "spatial": {
        "files": ("summary.json", "overlap.json"),
        "headlines": (
            ("summary.json", _spatial_summary),
            ("overlap.json", _spatial_overlap),
        ),
        "lamps_used": ("summary.json", _lamps_spatial, "summary.json config/lamp"),
    },
    "estimate": {
        "files": ("summary.json", "coverage.json"),
        "headlines": (
            ("summary.json", _estimate_summary),
            ("coverage.json", _estimate_coverage),
        ),
        "lamps_used": (
            "summary.json",
            _lamps_estimate,
            "scored lamps per partition, summary.json",
        ),
    },
    "noise_aware": {
        "files": ("noise_aware.json",),
        "headlines": (("noise_aware.json", _noise_aware),),
        "lamps_used": None,
    },
}
"""Per experiment folder: its key result files (besides manifest.json), the
headline extractor of each file, and where the number of lamps used is read."""

HEADLINES = {
    exp: [name for name, _ in spec["headlines"]] for exp, spec in EXPERIMENTS.items()
}


def _num(v) -> float:
    """A CSV cell (or JSON number) as a float."""
    return float(v)


def _or_none(v):
    """A GSD that is None means "no GSD works"."""
    return "none works" if v is None else v
