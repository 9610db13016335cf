"""The robustness study configured as a tolerance scan: how far may the
built filters deviate before the shipped estimator's errors grow by more than
10 %?

Rows (`tolerance_perturbations`): the clean spectra measured through the
nominal bands (the nominal score), then through as-built sensors, each band's
centre and FWHM moved one band at a time, and every band's leakage floor and
angle of incidence at once (`Perturbation` kinds "band-centre", "band-fwhm",
"leakage", "aoi"). The estimator is the one fitted to the nominal bands
(uncalibrated: a deviation nobody measured), on the same held-out lamps,
scenes and noise draws as the nominal row, so every row is paired with it.

The grid reaches far past any filter maker's tolerance (±40 nm, FWHM x 0.5-2,
5 % leakage, 30 deg), so each interval ends where the 1.10x criterion fails,
not where the scan stops; an end that still passes at the grid's edge is
marked open (`open_low` / `open_high`: "at least that far").

Criterion (`MAX_ERROR_RATIO`, the search's): per metric, the class-balanced
MAE (mean over partitions) at most 1.10x the nominal row's.
"""

from pathlib import Path

from ..estimate import METRICS
from ..search import MAX_ERROR_RATIO
from ..sensor.reference import resolve_band_set
from ..strict_json import strict_dumps
from ._study import BAND_SETS, Perturbation, RobustnessStudy


CENTRE_SHIFTS_NM = (-40.0, -20.0, -10.0, -5.0, -2.0, 2.0, 5.0, 10.0, 20.0, 40.0)
"""Centre shifts scanned, one band at a time [nm]."""

FWHM_FACTORS = (0.5, 0.7, 0.85, 1.15, 1.4, 2.0)
"""FWHM factors scanned, one band at a time [1]."""

LEAKAGES = (1e-4, 1e-3, 1e-2, 5e-2)
"""Leakage floors scanned, all bands at once (optical density 4 to 5 %) [1]."""

AOI_DEG = (5.0, 10.0, 20.0, 30.0)
"""Angles of incidence scanned, all bands at once [deg]."""

SCANS = (
    ("band-centre", "centre_nm", 0.0),
    ("band-fwhm", "fwhm_factor", 1.0),
    ("leakage", "leakage", 0.0),
    ("aoi", "aoi_deg", 0.0),
)
"""(row kind, name in `tolerance.json`, nominal value)."""


def tolerance_perturbations(names) -> tuple[Perturbation, ...]:
    """The scan's rows for a band set with band `names`: clean first."""
    rows = [Perturbation("clean")]
    for b in names:
        rows += [Perturbation("band-centre", d, b) for d in CENTRE_SHIFTS_NM]
        rows += [Perturbation("band-fwhm", f, b) for f in FWHM_FACTORS]
    rows += [Perturbation("leakage", v) for v in LEAKAGES]
    rows += [Perturbation("aoi", v) for v in AOI_DEG]
    return tuple(rows)


def _scan(points: list[dict], nominal: float) -> dict:
    """One deviation's interval from its scan `points` (value, ok): the
    contiguous passing run around `nominal`, the first failing value beyond
    each end (None: the grid's edge still passes, the end is open)."""
    pts = sorted(points, key=lambda p: p["value"])
    vals = [p["value"] for p in pts]
    ok = [p["within"] for p in pts]
    below = [i for i, v in enumerate(vals) if v < nominal]
    above = [i for i, v in enumerate(vals) if v > nominal]
    lo, fail_lo = nominal, None
    for i in reversed(below):
        if not ok[i]:
            fail_lo = vals[i]
            break
        lo = vals[i]
    hi, fail_hi = nominal, None
    for i in above:
        if not ok[i]:
            fail_hi = vals[i]
            break
        hi = vals[i]
    return {
        "interval": [lo, hi],
        "fails_at": [fail_lo, fail_hi],
        "open_low": bool(below) and fail_lo is None,
        "open_high": bool(above) and fail_hi is None,
        "points": pts,
    }


def tolerance_intervals(summary: dict, band_set: str = "recommended") -> dict:
    """`tolerance.json` of a tolerance scan's robustness summary: per band
    the centre-shift and FWHM-factor intervals, and the leakage and angle of
    incidence intervals (all bands), each with its scan points (per metric
    MAE ratio to nominal, the largest, level-1 right) and where it fails."""
    rows = [r for r in summary["rows"] if r["band_set"] == band_set]
    clean = next((r for r in rows if r["kind"] == "clean"), None)
    if clean is None:
        raise ValueError(f"summary: no clean row for band set {band_set!r}.")
    nominal = {m: clean[m] for m in METRICS}
    groups: dict = {}
    for r in rows:
        for kind, name, nom in SCANS:
            if r["kind"] != kind:
                continue
            ratio = {m: r[m] / nominal[m] for m in METRICS}
            point = {
                "value": r["value"],
                "ratio": ratio,
                "max_ratio": max(ratio.values()),
                "within": bool(all(v <= MAX_ERROR_RATIO for v in ratio.values())),
                "level1_correct": r.get("level1_correct"),
                "level1_correct_diff": r.get("level1_correct")
                - clean.get("level1_correct")
                if r.get("level1_correct") is not None
                and clean.get("level1_correct") is not None
                else None,
            }
            key = (r.get("band") or "all", name, nom)
            groups.setdefault(key, []).append(point)
    per_band: dict = {}
    every: dict = {}
    for (band, name, nom), pts in groups.items():
        iv = _scan(pts, nom)
        if band == "all":
            every[name] = iv
        else:
            per_band.setdefault(band, {})[name] = iv
    return {
        "rule": f"every metric's class-balanced MAE (mean over partitions) at "
        f"most {MAX_ERROR_RATIO}x the nominal row's; the estimator fitted to the "
        "nominal bands reads the as-built sensor (uncalibrated); one band at a "
        "time for centre and FWHM, all bands for leakage and angle of incidence",
        "band_set": band_set,
        "partitions": clean.get("partitions"),
        "nominal_mae": nominal,
        "nominal_level1_correct": clean.get("level1_correct"),
        "per_band": per_band,
        **every,
    }


def figure(tol: dict, path) -> None:
    """Largest MAE ratio to nominal against each deviation, one line per
    band (centre, FWHM) and for leakage and angle of incidence; the 1.10
    line marks the criterion."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for ax, name, xlabel in (
        (axes[0], "centre_nm", "centre shift [nm]"),
        (axes[1], "fwhm_factor", "FWHM factor"),
    ):
        for band, scans in tol["per_band"].items():
            if name not in scans:
                continue
            pts = scans[name]["points"]
            x = [p["value"] for p in pts]
            y = [p["max_ratio"] for p in pts]
            nom = 0.0 if name == "centre_nm" else 1.0
            x, y = zip(*sorted([*zip(x, y, strict=True), (nom, 1.0)]), strict=True)
            ax.plot(x, y, "o-", ms=3, label=band)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("largest MAE ratio to nominal (LER, G, CCT)")
        ax.set_yscale("log")
    others = (
        ("leakage", "leakage floor", "s-"),
        ("aoi_deg", "angle of incidence [deg]", "^-"),
    )
    for name, label, marker in others:
        if name not in tol:
            continue
        pts = tol[name]["points"]
        values = ", ".join(f"{p['value']:g}" for p in pts)
        y = [p["max_ratio"] for p in pts]
        axes[2].plot(range(1, len(pts) + 1), y, marker, label=f"{label}: {values}")
    axes[2].set_xlabel("scan step (values in the legend)")
    axes[2].set_yscale("log")
    for ax in axes:
        ax.axhline(MAX_ERROR_RATIO, color="k", ls="--", lw=1)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.suptitle(
        "Tolerances of the shipped estimator (fitted to the nominal bands): "
        f"dashed line {MAX_ERROR_RATIO}x nominal"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def readme_text(tol: dict) -> str:
    """The tolerance scan's `README.md`: one line per interval."""

    def fmt(iv, unit):
        lo, hi = iv["interval"]
        flo, fhi = iv["fails_at"]
        a = f"≤ {lo:g}" if iv["open_low"] else f"{lo:g}"
        b = f"≥ {hi:g}" if iv["open_high"] else f"{hi:g}"
        fails = (
            ", ".join(f"fails at {v:g}" for v in (flo, fhi) if v is not None)
            or "no failure within the scan"
        )
        return f"[{a}, {b}] {unit} ({fails})"

    lines = [
        "# Tolerances of the recommended bands under the shipped estimator",
        "",
        f"Rule: {tol['rule']}. Partitions: {tol['partitions']}. Nominal MAE: "
        + ", ".join(f"{m} {v:.4g}" for m, v in tol["nominal_mae"].items())
        + ".",
        "",
        "| band | centre shift | FWHM factor |",
        "|---|---|---|",
    ]
    for band, s in tol["per_band"].items():
        c = fmt(s["centre_nm"], "nm") if "centre_nm" in s else "not scanned"
        f = fmt(s["fwhm_factor"], "") if "fwhm_factor" in s else "not scanned"
        lines.append(f"| {band} | {c} | {f} |")
    lines.append("")
    for name, unit in (("leakage", ""), ("aoi_deg", "deg")):
        if name in tol:
            lines.append(f"- {name}, all bands: {fmt(tol[name], unit)}")
    return "\n".join(lines) + "\n"


def tolerance_study(band_sets=BAND_SETS[:1], **kwargs) -> RobustnessStudy:
    """The robustness study configured as the tolerance scan of the first
    of `band_sets` (default: our recommended bands): its rows are
    `tolerance_perturbations` of that set's band names; other
    `RobustnessStudy` fields as keywords."""
    names = list(resolve_band_set(band_sets[0][1]).bands.names)
    kwargs.setdefault("perturbations", tolerance_perturbations(names))
    return RobustnessStudy(band_sets=tuple(band_sets[:1]), **kwargs)


def write_tolerances(summary: dict, out, band_set: str | None = None) -> dict:
    """`tolerance.json`, `tolerance.png` and the intervals appended to the
    `README.md` of a finished tolerance scan in `out`; returns the JSON."""
    out = Path(out)
    band_set = band_set or summary["rows"][0]["band_set"]
    tol = tolerance_intervals(summary, band_set)
    (out / "tolerance.json").write_text(strict_dumps(tol, indent=1) + "\n")
    figure(tol, out / "tolerance.png")
    readme = out / "README.md"
    head = readme.read_text() if readme.is_file() else ""
    readme.write_text(readme_text(tol) + "\n" + head)
    return tol
