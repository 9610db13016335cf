"""The GSD study: the GSD needed to detect single street lamps (thesis 4.3).

Scenes (flux from lighting class M3 on the road, HPS spectrum, no Moon):

- `single`: one lamp (its flux that of the single-sided row);
- `rows`: a single-sided row for each spacing x mounting height (Table 4.8);
- `arrangements`: single-sided, staggered, opposite, central twin (Fig. 4.11,
  Table 4.9);
- `patterns`: the single-sided row with each distribution pattern (road
  optic, Lambertian, 70° cut-off, Illumina 0/5/20/50 % uplight profiles);
- `mixed`: the shipped `mixed-led-hps` layout (LED and HPS alternating).

Each scene is rendered once on a fine grid, then seen at every GSD with
`n_phases` sub-pixel phases of the pixel grid (noise seeded per phase);
detection thresholds are fixed in advance (`detect_lamps`). `run_gsd_study`
writes tables (CSV and JSON), PNG image grids with detection overlays,
cross-sections with the DoG response (Figs. 4.8-4.9), float32 TIFF images,
`summary.json` / `summary.md` with the GSD needed per arrangement, a
provenance manifest, and key "spatial" of results/recommendation.json.
"""

import csv
import dataclasses
import json
import statistics
import time
from pathlib import Path

import numpy as np

from ..datasets import atmosphere as atm
from ..provenance import write_manifest
from ..results import bands_record, recommended_band_set, update_recommendation
from ..sensor import reference_sensor
from ..strict_json import strict_dumps
from ._background import background_image
from ._detect import FALSE_ALARMS_PER_KM2
from ._imaging import GSDS_M, block_mean
from ._layout import arrangement, load_layout
from ._render import render, resolve_flux
from ._study_figures import figures
from ._sweep import F1_NEEDED, coarsest_gsd, gsd_sweep


@dataclasses.dataclass(frozen=True)
class GsdStudy:
    """Scenes, GSDs and the detection rule of the GSD study.

    Grid `dx_m` and scene size `length_m` x `width_m` [m]; `gsds_m` seen at
    `n_phases` grid phases each; rows at every `spacings_m` x `heights_m`
    [m]; `arrangements` and distribution `patterns` at `base_spacing_m`,
    `base_height_m` [m]; `lamp` spectrum lit for `lighting_class`; `bands`
    "recommended" (the "spectral" bands of results/recommendation.json) or a
    reference sensor; "needed" is the coarsest GSD with phase-mean F1 >=
    `f1_needed`; `atmosphere` a 6S (profile, aerosol, visibility) or None.

    The sensor: with `radiometry` (a results folder of `make radiometry`),
    each band's detection limit and saturation and the recommended linear
    bit depth from it (the limits of `bands`' own rows), else 14 bits
    between 0 and 1e-3. The ground: night-sky background plus, with `moon`
    (a named phase), moonlit ground (`background_image`). The detector: at
    `false_alarms_per_km2` (None: the MAD and relative thresholds), on band
    `detection_band` when the set has it (else the mean of the bands), with
    the lamp-free ground subtracted when `known_background` (a lunar model
    and daytime reflectance give it; else the edges between moonlit surfaces
    are found as lamps).
    """

    dx_m: float = 0.25
    length_m: float = 600.0
    width_m: float = 200.0
    gsds_m: tuple[float, ...] = GSDS_M
    spacings_m: tuple[float, ...] = (20.0, 30.0, 40.0, 50.0)
    heights_m: tuple[float, ...] = (6.0, 8.0, 10.0, 12.0)
    arrangements: tuple[str, ...] = (
        "single-sided",
        "staggered",
        "opposite",
        "central-twin",
    )
    patterns: tuple[str, ...] = (
        "road-optic",
        "lambertian",
        "cutoff",
        "lop-0",
        "lop-5",
        "lop-20",
        "lop-50",
    )
    base_spacing_m: float = 30.0
    base_height_m: float = 8.0
    lamp: str = "nist_traditional_hps"
    lighting_class: str = "M3"
    bands: str = "recommended"
    n_phases: int = 3
    seed: int = 0
    f1_needed: float = F1_NEEDED
    atmosphere: tuple | None = ("midlatitude_summer", "urban", 23.0)
    radiometry: str | None = "results/radiometry"
    moon: str | None = None
    false_alarms_per_km2: float | None = FALSE_ALARMS_PER_KM2
    detection_band: str | None = "PAN"
    known_background: bool = True

    @classmethod
    def quick(cls, **kw) -> "GsdStudy":
        """A coarser grid and fewer scenes (minutes instead of hours)."""
        base = dict(
            dx_m=0.5,
            length_m=400.0,
            spacings_m=(20.0, 40.0),
            heights_m=(6.0, 10.0),
            patterns=("road-optic", "lambertian", "lop-50"),
            n_phases=2,
        )
        return cls(**{**base, **kw})


def study_atmosphere(study: GsdStudy) -> tuple[tuple | None, str]:
    """The configured 6S table if the package ships it, else None, with a note
    saying which."""
    if study.atmosphere is None:
        return None, "none requested"
    if atm.resolve_setting("auto") == "none":
        return None, "6S tables not installed (`make atmospheres`); rendered without"
    return study.atmosphere, (
        "6S upward transmittance at nadir: direct for the pixel's own ground, "
        "diffuse for k = 0.1 x the tile's mean (scene.DEFAULT_NEIGHBOURHOOD, "
        "lit street in a dark district; bandopt.spatial.render)"
    )


DEFAULT_OUT = Path("results/spatial")
"""Where the shipped study writes: only a run into it writes key "spatial" of
results/recommendation.json (a variant such as `--moon full --out ...`
keeps its results in its own folder)."""


def study_bands(study: GsdStudy):
    """The study's band set: "recommended" is the "spectral" band set of
    results/recommendation.json, any other name a reference sensor."""
    if study.bands == "recommended":
        bands = recommended_band_set("spectral")
        if bands is None:
            raise ValueError(
                "GsdStudy.bands='recommended': results/recommendation.json has no "
                "'spectral' band set; run `make run` or name a reference sensor."
            )
        return bands
    return reference_sensor(study.bands)


def study_sensor(study: GsdStudy, band_names) -> dict:
    """`observe`'s sensor keywords: bit depth, per-band detection limit and
    saturation from `study.radiometry` (the rows of this band set: "ours"
    for the recommended bands), else 14 bits between 0 and 1e-3."""
    if study.radiometry is None:
        return {"bit_depth": 14, "saturation_w_m2_sr_nm": 1e-3,
                "detection_limit_w_m2_sr_nm": 0.0}  # fmt: skip
    folder = Path(study.radiometry)
    label = "ours" if study.bands == "recommended" else study.bands
    with open(folder / "limits.csv", newline="") as fh:
        rows = {r["band"]: r for r in csv.DictReader(fh) if r["band_set"] == label}
    missing = [b for b in band_names if b not in rows]
    if missing:
        raise ValueError(
            f"{folder / 'limits.csv'}: no rows of band set {label!r} for bands "
            f"{missing}; re-run `make radiometry`."
        )
    summary = json.loads((folder / "summary.json").read_text())
    bits = (summary.get("bit_depth") or {}).get("recommended_linear_bits")
    if bits is None:
        raise ValueError(
            f"{folder / 'summary.json'}: no bit_depth.recommended_linear_bits."
        )
    return {
        "bit_depth": int(bits),
        "detection_limit_w_m2_sr_nm": np.array(
            [float(rows[b]["detection_limit_w_m2_sr_nm"]) for b in band_names]
        ),
        "saturation_w_m2_sr_nm": np.array(
            [float(rows[b]["saturation_w_m2_sr_nm"]) for b in band_names]
        ),
    }


def study_scenes(study: GsdStudy) -> list[tuple]:
    """(group, name, layout, params) for every scene of the study (the
    single lamp with zero flux: `run_gsd_study` gives it the row's)."""
    common = dict(
        length_m=study.length_m,
        width_m=study.width_m,
        lamps=(study.lamp,),
        flux_lm=None,
        lighting_class=study.lighting_class,
    )
    base = dict(spacing_m=study.base_spacing_m, mounting_height_m=study.base_height_m)
    out = [
        (
            "single",
            "single",
            arrangement("single", **base, **{**common, "flux_lm": 0.0}),
            {},
        )
    ]
    for s in study.spacings_m:
        for h in study.heights_m:
            lay = arrangement(
                "single-sided",
                spacing_m=s,
                mounting_height_m=h,
                name=f"row-s{s:g}-h{h:g}",
                **common,
            )
            out.append(
                ("rows", lay.name, lay, {"spacing_m": s, "mounting_height_m": h})
            )
    for a in study.arrangements:
        out.append(
            ("arrangements", a, arrangement(a, **base, **common), {"arrangement": a})
        )
    for p in study.patterns:
        lay = arrangement(
            "single-sided", **base, luminaire=p, name=f"pattern-{p}", **common
        )
        out.append(("patterns", lay.name, lay, {"pattern": p}))
    return out


def assumptions(study: GsdStudy, sensor: dict) -> list[str]:
    """What the rendering and detection assume (summary.json, summary.md)."""
    if study.radiometry is None:
        quant = "14-bit, 0 to 1e-3 W m-2 sr-1 nm-1"
    else:
        quant = (
            f"{sensor['bit_depth']}-bit between each band's detection limit and "
            f"saturation from {study.radiometry} (the recommended radiometry)"
        )
    detector = (
        "DoG at a fixed false-alarm rate of "
        f"{study.false_alarms_per_km2:g} per km² (threshold u σ_D per pixel from the "
        "sensor's noise model, u = Φ⁻¹(1 - r GSD²/10⁶))"
        if study.false_alarms_per_km2 is not None
        else "DoG thresholds fixed in advance, identical for every GSD and scene"
    )
    return [
        "nadir view, flat Lambertian ground, single bounce, point luminaires",
        "adjacency: T_dir L(x) + k T_dif <L>_tile with the default "
        "neighbourhood (lit street in a dark district, k = 0.1; "
        "bandopt.spatial.render); lamp-light path radiance neglected",
        "PSF Gaussian with FWHM = 1 GSD, box pixel, photon noise (Table 2.3 "
        f"sensor, integration time from GSD at 600 km), {quant}",
        "ground: night-sky background"
        + (f" and moonlit ground ({study.moon} Moon)" if study.moon else ", no Moon"),
        detector
        + (f", on band {study.detection_band}" if study.detection_band else "")
        + (", the modelled lamp-free ground subtracted first"
           if study.known_background else ""),
        "match radius 5 m + GSD/√2 (pool offset plus half a pixel "
        "diagonal); twin poles are one target",
    ]


def run_gsd_study(study: GsdStudy, out: Path) -> dict:
    """Render every scene, sweep the GSDs, write the outputs into `out` and,
    when `out` is `DEFAULT_OUT`, key "spatial" of results/recommendation.json.
    Returns the summary."""
    from tqdm import tqdm  # progress bar only: start-up time

    t0 = time.time()
    out.mkdir(parents=True, exist_ok=True)
    (out / "images").mkdir(exist_ok=True)
    bands = study_bands(study)
    sensor = study_sensor(study, bands.names)
    detect = {
        "false_alarms_per_km2": study.false_alarms_per_km2,
        "detection_band": study.detection_band
        if study.detection_band in bands.names else None,
        "known_background": study.known_background,
    }  # fmt: skip
    atmosphere, atm_note = study_atmosphere(study)
    todo = study_scenes(study)
    # the single lamp gets the flux of the single-sided row at the base geometry
    row = next(
        lay
        for g, _, lay, _ in todo
        if g == "arrangements" and lay.meta[0][1] == "single-sided"
    )
    row_flux = float(resolve_flux(row).flux_lm[0])
    group, name, single, _ = todo[0]
    lamps = tuple(dataclasses.replace(p, flux_lm=row_flux) for p in single.lamps)
    todo[0] = (group, name, dataclasses.replace(single, lamps=lamps), {})
    mixed = load_layout("mixed-led-hps")
    mixed = dataclasses.replace(mixed, length_m=study.length_m, width_m=study.width_m)
    todo.append(("mixed", "mixed-led-hps", mixed, {}))

    rows, table, keep = [], [], {}
    for group, name, layout, params in tqdm(todo, desc="scenes", unit="scene"):
        scene = render(layout, bands, dx_m=study.dx_m, atmosphere=atmosphere)
        shown = group in ("single", "arrangements", "mixed", "patterns")
        sweep = gsd_sweep(
            scene,
            bands,
            study.gsds_m,
            n_phases=study.n_phases,
            seed=study.seed,
            keep_observations=shown,
            background=background_image(
                scene, bands, moon=study.moon, atmosphere=atmosphere
            ),
            **sensor,
            **detect,
        )
        flux = {"lamp_flux_lm": float(np.nanmax(scene.lamps.flux_lm))}
        for sc in sweep.scores:
            head = {"group": group, "scene": name, **params}
            rows += [{**head, **r, **flux} for r in sc.phase_rows()]
            mean = sc.mean_row()
            table.append(
                {**head, "gsd_m": sc.gsd_m, "n_targets": sc.n_targets, **flux, **mean}
            )
            if shown:
                keep[(name, sc.gsd_m)] = (sweep.first_phase[sc.gsd_m], scene)
        if group in ("single", "arrangements", "mixed"):
            _save_fine(out, name, scene)
    _write_tables(out, rows, table)
    needed = _needed(table, study)
    figures(out, study, keep, table)
    summary = {
        "config": dataclasses.asdict(study),
        "atmosphere": atm_note,
        "row_flux_lm": row_flux,
        "gsd_needed_m": needed,
        "seconds": round(time.time() - t0, 1),
        "thesis": "about 10 m in most cases (De Meester 2019, section 4.3)",
        "why": WHY,
        "assumptions": assumptions(study, sensor),
        "bands": bands_record(bands),
        "overlapping_lamp_types": "see overlap.json / overlap.png "
        "(python -m experiments.spatial_overlap, run by `make spatial`)",
    }
    (out / "summary.json").write_text(strict_dumps(summary, indent=2) + "\n")
    _markdown(out, summary, study)
    write_manifest(out, seed=study.seed, config=dataclasses.asdict(study))
    if out.resolve() == DEFAULT_OUT.resolve():  # a variant never replaces it
        recommend_spatial(summary, study)
    return summary


def _row_scenes(needed: dict, study: GsdStudy) -> list:
    """Coarsest GSD (or None) of the row and arrangement scenes."""
    return [
        v["coarsest_gsd_m"]
        for k, v in needed.items()
        if k in study.arrangements or k.startswith("row-")
    ]


def recommend_spatial(summary: dict, study: GsdStudy) -> None:
    """Put the GSD needed per scene under key "spatial" of
    results/recommendation.json."""
    per = {k: v["coarsest_gsd_m"] for k, v in summary["gsd_needed_m"].items()}
    found = [v for v in _row_scenes(summary["gsd_needed_m"], study) if v is not None]
    update_recommendation(
        "spatial",
        {
            "gsd_needed_m_per_scene": per,
            "median_gsd_needed_m": statistics.median(found) if found else None,
            "scenes_never_detected": [k for k, v in per.items() if v is None],
            "rule": "coarsest GSD with single-lamp detection F1 >= "
            f"{study.f1_needed} ("
            + (
                f"DoG at {study.false_alarms_per_km2:g} false alarms per km²"
                if study.false_alarms_per_km2 is not None
                else "DoG, threshold fixed in advance"
            )
            + ")",
            "thesis": summary["thesis"],
        },
    )


def recommend_from_summary(out: Path) -> int:
    """Rewrite key "spatial" of results/recommendation.json from the
    `summary.json` of a finished run in `out`, by the rule of `run_gsd_study`."""
    path = out / "summary.json"
    if not path.is_file():
        raise SystemExit(f"{path}: no spatial summary; run the experiment first.")
    summary = json.loads(path.read_text())
    fields = {f.name for f in dataclasses.fields(GsdStudy)}
    study = GsdStudy(
        **{
            k: tuple(v) if isinstance(v, list) else v
            for k, v in summary["config"].items()
            if k in fields
        }
    )
    recommend_spatial(summary, study)
    print(f"wrote key 'spatial' of results/recommendation.json from {path}")
    return 0


def _needed(table: list[dict], study: GsdStudy) -> dict:
    """Per scene: `coarsest_gsd` of its phase-mean F1."""
    res = {}
    for name in dict.fromkeys(r["scene"] for r in table):
        f1 = {r["gsd_m"]: r["f1"] for r in table if r["scene"] == name}
        res[name] = coarsest_gsd(f1, study.f1_needed).as_dict()
    return res


def _write_tables(out: Path, rows: list[dict], table: list[dict]) -> None:
    for name, data in (("detections_by_phase", rows), ("detections", table)):
        keys = list(dict.fromkeys(k for r in data for k in r))
        with open(out / f"{name}.csv", "w", newline="") as f:
            w = csv.DictWriter(f, keys)
            w.writeheader()
            w.writerows(data)
        (out / f"{name}.json").write_text(strict_dumps(data, indent=1) + "\n")


def _save_fine(out: Path, name: str, scene) -> None:
    """The fine radiance image box-averaged to 1 m (zlib-compressed float32 TIFF;
    the full 0.25 m grid would be ~8 MB per scene)."""
    import tifffile  # image files only: start-up time

    f = max(1, round(1.0 / scene.grid.dx_m))
    tifffile.imwrite(
        out / "images" / f"{name}_1m.tif",
        np.asarray(block_mean(scene.radiance, f), np.float32),
        compression="zlib",
        metadata={
            "unit": "W m-2 sr-1 nm-1",
            "pixel_m": f * scene.grid.dx_m,
            "rendered_dx_m": scene.grid.dx_m,
        },
    )


WHY = (
    "Why (see the cross-sections and the images): with no light sent "
    "straight up, a nadir sensor sees the lit ground, not the lamp. At "
    "1-5 m the light pool of a road optic is resolved into its lobes along "
    "the road and into the bright sidewalk strips across it, so the DoG "
    "finds two or more blobs per lamp, each far above the noise: the one on "
    "the sidewalk beside the pole is the lamp, the others count as false "
    "detections (precision about 0.5, F1 about 0.67). They are light, not "
    "noise, so no false-alarm rate removes them; the detector would have to "
    "know a pool's shape. Near 10 m one pool becomes one blob centred on its "
    "lamp. Once the GSD approaches half the spacing between neighbouring "
    "lamps (the 15 m of a staggered layout, 20 m rows), neighbouring pools "
    "merge into a continuous band and recall falls; at 50-100 m the road is "
    "a line. A lamp alone stays one blob above the night sky at every GSD "
    "from 10 m. Luminaires that send half their light straight up (Illumina "
    "50 % profile) are point-like and are found from 1-2 m."
)
"""The reading of the study's figures that summary.md gives."""


def _markdown(out: Path, summary: dict, study: GsdStudy) -> None:
    gsds = study.gsds_m
    lines = [
        "# Spatial sampling: single-lamp detection by GSD",
        "",
        f"Atmosphere: {summary['atmosphere']}. Run time {summary['seconds']} s.",
        "",
        "F1 (mean over grid phases) per GSD; 'needed' = coarsest GSD with "
        f"F1 >= {study.f1_needed}.",
        "",
        "| scene | " + " | ".join(f"{g:g} m" for g in gsds) + " | needed |",
        "|---|" + "---|" * (len(gsds) + 1),
    ]
    for name, v in summary["gsd_needed_m"].items():
        f1 = [v["f1_by_gsd"].get(f"{g:g}", float("nan")) for g in gsds]
        need = v["coarsest_gsd_m"]
        lines.append(
            f"| {name} | "
            + " | ".join(f"{x:.2f}" for x in f1)
            + f" | {'none' if need is None else f'{need:g} m'} |"
        )
    arr = _row_scenes(summary["gsd_needed_m"], study)
    found = [a for a in arr if a is not None]
    lines += [
        "",
        "## Conclusion",
        "",
        f"Over the {len(arr)} row and arrangement scenes the coarsest GSD that "
        f"still detects single lamps (F1 >= {study.f1_needed}) has median "
        f"{np.median(found) if found else float('nan'):g} m; "
        f"{len(arr) - len(found)} scene(s) reach it at no GSD. The thesis found "
        "about 10 m in most cases.",
        "",
        WHY,
        "",
        "Assumptions: " + "; ".join(summary["assumptions"]) + ".",
        "",
        "Overlapping lamp types: " + summary["overlapping_lamp_types"] + ".",
    ]
    (out / "summary.md").write_text("\n".join(lines) + "\n")
