"""The radiometry analysis: distributions, limits, SNR/NER, bit depth, for
one band set (and the reference sensors); the rows of its tables and the
bit-depth rule are in `_tables`.

`compute` returns the tables, summary and recommendation and writes nothing:
`bandopt radiometry --out DIR` (`bandopt.cli.run_radiometry`) writes them
into DIR, and `make radiometry` (with `_study`) owns results/radiometry, its
README section and the "radiometry" key of results/recommendation.json.
"""

import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from ..datasets import atmosphere as atm
from ..forward import cropped
from ..scene import DEFAULT_SURFACES, LIGHTING_CLASSES, build_scenarios
from ..sensor import (
    REFERENCE_SENSORS,
    SensorParams,
    reference_sensor,
    resolve_band_set,
)
from ._background import (
    BACKGROUND_UNCERTAINTY_FACTOR,
    NIGHT_SKY_MAG_ARCSEC2,
)
from ._bitdepth import bit_depth_rows
from ._distributions import GROUPS, RadianceGroups, distribution_rows, radiance_groups
from ._instrument import instrument_changes
from ._limits import (
    LimitRule,
    Limits,
    bits_for_linear,
    recommend_limits,
    sensitivity_rows,
)
from ._tables import (
    quantisation_noise_rows,
    quantisers_for,
    recommend_bits,
    snr_rows,
)


DEFAULT_BAND_SET = "sdgsat-1"
"""Band set used for "ours" when results/recommendation.json has no
"spectral" bands: the SDGSAT-1 Glimmer PAN + blue/green/red set."""


@dataclasses.dataclass(frozen=True)
class RadiometryConfig:
    """Scenario sets and settings of the experiment.

    Distribution set (all lamps): `surfaces` (mean reflectances), `atmospheres`
    (`"all"`: every 6S combination, falling back to `"none"` with a note when
    the tables are missing), `moons`, `classes` (all EN 13201 classes), direct
    uplight at `uplight_ratio`, fires at `fire_temperatures_k` burning
    `fire_fraction` of the pixel with `fire_emissivity`.
    Bit-depth set (scored lamps only): `eval_*`. Quantisers: linear at
    `bit_depths`, two-gain and square-root at `companding_bits`. `mode`:
    "full" or "quick" (`quick()`), recorded in every output.
    """

    surfaces: tuple[str, ...] = (*DEFAULT_SURFACES, "snow")
    atmospheres: str | tuple = "all"
    moons: tuple = (None, "full", "first_quarter")
    classes: tuple[str, ...] = tuple(LIGHTING_CLASSES)
    uplight_ratio: float = 0.05
    fire_temperatures_k: tuple[float, ...] = (
        700.0,
        800.0,
        900.0,
        1000.0,
        1100.0,
        1200.0,
    )
    fire_fraction: float = 0.01
    fire_emissivity: float = 0.9
    eval_surfaces: tuple[str, ...] = ("asphalt", "road", "sidewalk", "grass")
    eval_atmospheres: str | tuple = (
        ("midlatitude_summer", "urban", 23.0),
        ("tropical", "urban", 5.0),
    )
    eval_moons: tuple = (None, "full")
    eval_classes: tuple[str, ...] = ("P6", "P4", "P1", "C0")
    bit_depths: tuple[int, ...] = (8, 10, 12, 14, 16)
    companding_bits: tuple[int, ...] = (8, 10, 12)
    references: bool = True
    bit_depth_table: bool = True
    lamps: tuple[str, ...] | None = None
    seed: int = 0
    mode: str = "full"

    @classmethod
    def quick(cls, **kw) -> "RadiometryConfig":
        """A small configuration (seconds): few surfaces, one atmosphere."""
        base = dict(
            surfaces=("asphalt", "sidewalk", "snow"),
            atmospheres="none",
            classes=("P6", "P1", "C0"),
            moons=(None, "full"),
            fire_temperatures_k=(700.0, 1200.0),
            eval_surfaces=("asphalt", "sidewalk"),
            eval_atmospheres="none",
            eval_classes=("P6", "C0"),
            bit_depths=(8, 12, 16),
            companding_bits=(8,),
            references=False,
            mode="quick",
        )
        base.update(kw)
        return cls(**base)

    def as_dict(self) -> dict:
        return json.loads(json.dumps(dataclasses.asdict(self), default=str))


# ------------------------------------------------------------------------------
# inputs


def resolve_atmospheres(spec) -> tuple[list, str]:
    """`"all"` -> every 6S combination, `"none"` -> no atmosphere, else the
    list itself, with a note saying which. Anything but "none" is asked as
    "auto" (`datasets.atmosphere.resolve_setting`): without the 6S tables it
    falls back to "none", stated in the note."""

    if isinstance(spec, str) and spec.lower() == "none":
        return ["none"], "no atmosphere (T = 1, no path radiance)"
    if atm.resolve_setting("auto") == "none":
        return ["none"], (
            f"6S tables missing in {atm.DATA_DIR} (`make atmospheres`); "
            "ran without atmosphere"
        )
    if isinstance(spec, str) and spec.lower() == "all":
        ids = atm.atmosphere_ids()
        return list(ids), f"all {len(ids)} 6S combinations"
    return list(spec), f"{len(spec)} 6S combinations"


def default_band_set():
    return reference_sensor(DEFAULT_BAND_SET)


def load_band_set(source: str):
    """A band set and its label from `source`: a reference sensor name, a
    band-set JSON file, or a recommendation JSON file (a top-level "spectral"
    key holding a band set; label "ours"). Returns `(bands, label, note)`.

    "ours" is not resolved here (that would read results/ behind the user's
    back): name the recommendation file, or run `make radiometry`."""
    if str(source).strip().lower() in ("ours", "recommended"):
        raise ValueError(
            f"--bands {source!r}: name the file holding the bands, e.g. "
            "results/recommendation.json (its 'spectral' key), or run "
            "`make radiometry` (python -m experiments.radiometry --bands ours)."
        )
    found = resolve_band_set(source)
    if found.key is not None:  # a recommendation file
        return found.bands, "ours", f"bands from {found.path} key '{found.key}'"
    if found.entry is None:
        return found.bands, found.label, f"band-set file {found.path}"
    return found.bands, found.label, found.entry.title


def distribution_set(config: RadiometryConfig):
    atms, note = resolve_atmospheres(config.atmospheres)
    scen = build_scenarios(
        lamps=config.lamps,
        surfaces=config.surfaces,
        atmospheres=atms,
        moons=config.moons,
        classes=config.classes,
        uplight_ratio=config.uplight_ratio,
        fire_temperatures_k=config.fire_temperatures_k,
        fire_fraction=config.fire_fraction,
        fire_emissivity=config.fire_emissivity,
        seed=config.seed,
    )
    return scen, note


def evaluation_set(config: RadiometryConfig):
    atms, note = resolve_atmospheres(config.eval_atmospheres)
    scen = build_scenarios(
        lamps=config.lamps,
        scored_only=config.lamps is None,
        surfaces=config.eval_surfaces,
        atmospheres=atms,
        moons=config.eval_moons,
        classes=config.eval_classes,
        seed=config.seed,
    )
    return scen, note


# ------------------------------------------------------------------------------
# figures


def plot_histograms(
    groups: RadianceGroups, limits: Limits, path: Path, *, title: str
) -> Path:
    """Histograms of log10 band radiance per group, one panel per band, with
    the detection limit, saturation, scene requirement and background drawn."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")

    nb = len(groups.band_names)
    ncol = min(nb, 3)
    nrow = int(np.ceil(nb / ncol))
    fig, axes = plt.subplots(
        nrow, ncol, figsize=(5.2 * ncol, 3.6 * nrow), squeeze=False
    )
    colours = {"lamp": "C0", "moon": "C2", "uplight": "C1", "fire": "C3"}
    all_vals = [groups.flat(g) for g in GROUPS if groups.flat(g) is not None]
    top = max(max(float(v.max()) for v in all_vals), float(limits.saturation.max()))
    # left edge 2 decades under the background: darker values (a band a lamp
    # does not emit in, cold fires) are piled into the first bin
    lo = np.log10(float(limits.background.min()) / 100.0)
    hi = np.log10(top * 2)
    bins = np.linspace(lo, hi, 90)
    for j, band in enumerate(groups.band_names):
        ax = axes[j // ncol][j % ncol]
        for g in GROUPS:
            v = groups.flat(g)
            if v is None:
                continue
            x = np.log10(np.clip(v[:, j], 10.0**lo, None))
            ax.hist(
                x,
                bins=bins,
                density=True,
                histtype="step",
                color=colours[g],
                label=f"{g} ({len(x)})",
            )
        for val, style, lab in (
            (limits.detection_limit[j], "-", "detection limit"),
            (limits.saturation[j], "--", "saturation"),
            (limits.scene_requirement[j], "-.", "dim-scene requirement"),
            (limits.background[j], ":", "night-sky background"),
        ):
            ax.axvline(max(np.log10(val), lo), color="k", ls=style, lw=1, label=lab)
        ax.set_xlim(lo, hi)
        ax.set_title(f"{band} (left bin: everything darker)")
        ax.set_xlabel("log10 band radiance [W m-2 sr-1 nm-1]")
        ax.set_ylabel("density")
        ax.set_yscale("log")
    for k in range(nb, nrow * ncol):
        axes[k // ncol][k % ncol].axis("off")
    axes[0][0].legend(fontsize=7, loc="upper left")
    fig.suptitle(title)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ------------------------------------------------------------------------------
# the computation (writes nothing; the CLI and experiments/radiometry.py write)


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)


def analyse(scen, bands, label: str, params: SensorParams, rule: LimitRule) -> dict:
    """Distributions, limits, sensitivity and SNR/NER of one band set."""

    groups = radiance_groups(scen, bands)
    f, resp = cropped(scen, bands)
    limits = recommend_limits(groups, resp, f.wavelength_nm, params, rule)
    return {
        "groups": groups,
        "limits": limits,
        "distribution": distribution_rows(groups, band_set=label),
        "limit_rows": limits.rows(band_set=label),
        "sensitivity": sensitivity_rows(
            groups, resp, f.wavelength_nm, params, base=rule, band_set=label
        ),
        "snr": snr_rows(groups, limits, params, band_set=label),
        "bits_step_le_ner": bits_for_linear(limits, params),
    }


def compute(
    bands,
    label: str,
    *,
    config: RadiometryConfig | None = None,
    params: SensorParams | None = None,
    rule: LimitRule | None = None,
    note: str = "",
    log=print,
) -> dict:
    """Run the radiometry analysis for `bands` (and the reference sensors when
    `config.references`). Writes nothing. Returns a dict:

    - `summary`: JSON-ready summary (limits per band, rule, bit depth, the
      configuration with its `mode`);
    - `tables`: file name -> rows (`distributions.csv`, `limits.csv`,
      `sensitivity.csv`, `snr_ner.csv`, `quantisation_noise.csv`, and
      `bit_depth.csv` when computed);
    - `histograms`: band-set key -> `(groups, limits)` for `plot_histograms`;
    - `recommendation`: the value for key "radiometry" of a recommendation
      file, with `mode` and `settings` (what made it);
    - `manifest_config`: the configuration for the provenance manifest.
    """

    t0 = time.perf_counter()
    config = RadiometryConfig() if config is None else config
    params = SensorParams() if params is None else params
    rule = LimitRule() if rule is None else rule

    scen, atm_note = distribution_set(config)
    log(
        f"[radiometry] distribution set {scen.shape} ({atm_note}), "
        f"{time.perf_counter() - t0:.1f} s"
    )
    ours = analyse(scen, bands, label, params, rule)
    results = {label: ours}
    if config.references:
        for key, entry in REFERENCE_SENSORS.items():
            try:
                results[key] = analyse(scen, entry.build(), key, params, rule)
            except ValueError as err:
                log(f"[radiometry] {key}: skipped ({err})")
        log(f"[radiometry] reference sensors done, {time.perf_counter() - t0:.1f} s")

    dist, lim, sens, snr_tab = [], [], [], []
    histograms = {}
    for key, res in results.items():
        dist += res["distribution"]
        rows = res["limit_rows"]
        entry = REFERENCE_SENSORS.get(key)
        for j, r in enumerate(rows):
            r["bits_linear_step_le_ner_at_limit"] = int(res["bits_step_le_ner"][j])
            if entry is not None:
                r["published_bit_depth"] = entry.bit_depth
                r["published_detection_limit_w_m2_sr_nm"] = (
                    entry.detection_limit_w_m2_sr_nm
                )
        lim += rows
        sens += res["sensitivity"]
        snr_tab += res["snr"]
        histograms[_slug(key)] = (res["groups"], res["limits"], key)
    tables = {
        "distributions.csv": dist,
        "limits.csv": lim,
        "sensitivity.csv": sens,
        "snr_ner.csv": snr_tab,
    }

    limits = ours["limits"]
    qs = quantisers_for(limits, params, config.bit_depths, config.companding_bits)
    tables["quantisation_noise.csv"] = quantisation_noise_rows(
        ours["groups"], limits, params, qs, band_set=label
    )

    bit_rows, bits_rec, eval_note = [], None, ""
    if config.bit_depth_table:
        escen, eval_note = evaluation_set(config)
        log(f"[radiometry] bit-depth set {escen.shape} ({eval_note})")
        bit_rows = bit_depth_rows(escen, bands, qs, params, seed=config.seed)
        tables["bit_depth.csv"] = bit_rows
        bits_rec = recommend_bits(bit_rows)
        log(f"[radiometry] bit depth done, {time.perf_counter() - t0:.1f} s")

    sensor = {
        fld.name: np.asarray(getattr(params, fld.name)).tolist()
        for fld in dataclasses.fields(params)
    }
    summary = {
        "band_set": label,
        "band_set_note": note,
        "mode": config.mode,
        "bands": limits.rows(band_set=label),
        "rule": rule.as_dict(),
        "rule_text": (
            "L_min = max(L_req, L_bg) (and L_snr if sensor_limited): L_req the "
            "dim_percentile over lamps of the dimmest class on the darkest surface "
            "through the most absorbing atmosphere (per band, moonless); L_bg the "
            "natural night-sky background; L_snr the radiance where the photon "
            "model reaches snr_target; the sensor must reach snr_target at L_min "
            "(snr_at_limit, exposure_factor). L_max = headroom x "
            "saturation_percentile of lamp scenes (+ direct uplight). Fires apart."
        ),
        "background": {
            "source": "Patat2003 dark-time zenith sky brightness (B, V, R, I) with "
            "Bessell1998 zero points; context Leinert1998",
            "mag_arcsec2": NIGHT_SKY_MAG_ARCSEC2,
            "uncertainty_factor": BACKGROUND_UNCERTAINTY_FACTOR,
        },
        "sensor_params": sensor,
        "instrument_changes": instrument_changes(
            params, limits.exposure_factor, limits.band_names
        ),
        "bits_linear_step_le_ner_at_limit": int(np.max(ours["bits_step_le_ner"])),
        "bit_depth": bits_rec,
        "bit_depth_table": bit_rows,
        "atmospheres": atm_note,
        "bit_depth_set": eval_note,
        "scenario_shape": list(scen.shape),
        "config": config.as_dict(),
        "runtime_s": round(time.perf_counter() - t0, 1),
    }

    def per_band(values):
        return dict(zip(limits.band_names, values, strict=True))

    recommendation = {
        "band_set": label,
        "band_set_note": note,
        "mode": config.mode,
        "settings": {
            "radiometry": config.as_dict(),
            "rule": rule.as_dict(),
            "sensor_params": sensor,
        },
        "detection_limit_w_m2_sr_nm": per_band(limits.detection_limit.tolist()),
        "saturation_w_m2_sr_nm": per_band(limits.saturation.tolist()),
        "limited_by": per_band(limits.limited_by),
        "snr_at_limit": per_band(limits.snr_at_limit.tolist()),
        "bit_depth": None if bits_rec is None else bits_rec["recommended_linear_bits"],
        "bit_depth_companded": None
        if bits_rec is None
        else bits_rec["recommended_companded_bits"],
        "companding": None if bits_rec is None else bits_rec["recommended_companding"],
        "bit_depth_rule": None if bits_rec is None else bits_rec["rule"],
        "bands": [
            {"name": n, "centre_nm": float(c), "fwhm_nm": float(w)}
            for n, c, w in zip(
                bands.names,
                np.asarray(bands.centre_nm).tolist(),
                np.asarray(bands.fwhm_nm).tolist(),
                strict=True,
            )
        ],
        "bits_linear_step_le_ner_at_limit": summary["bits_linear_step_le_ner_at_limit"],
        "rule": rule.as_dict(),
    }
    manifest_config = {
        "band_set": label,
        "band_set_note": note,
        "rule": rule.as_dict(),
        "radiometry": config.as_dict(),
        "atmospheres": atm_note,
    }
    return {
        "summary": summary,
        "tables": tables,
        "histograms": histograms,
        "recommendation": recommendation,
        "manifest_config": manifest_config,
        "seed": config.seed,
    }
