"""Spatial sampling: the GSD needed to detect single street lamps (thesis 4.3).

Run:   python -m experiments.spatial [--quick] [--out results/spatial]

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
detection thresholds are fixed in advance (`bandopt.spatial.detect`).
Writes tables (CSV and JSON), PNG image grids with detection overlays,
cross-sections with the DoG response (Figs. 4.8-4.9), float32 TIFF images,
`summary.json` / `summary.md` with the GSD needed per arrangement, and a
provenance manifest.
"""

import argparse
import csv
import dataclasses
import json
import time
from pathlib import Path

import numpy as np


@dataclasses.dataclass(frozen=True)
class Config:
    dx_m: float = 0.25
    length_m: float = 600.0
    width_m: float = 200.0
    gsds_m: tuple[float, ...] = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0)
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
    bands: str = "viirs-dnb"
    n_phases: int = 3
    seed: int = 0
    f1_needed: float = 0.8
    atmosphere: tuple | None = ("midlatitude_summer", "urban", 23.0)


QUICK = dict(
    dx_m=0.5,
    length_m=400.0,
    spacings_m=(20.0, 40.0),
    heights_m=(6.0, 10.0),
    patterns=("road-optic", "lambertian", "lop-50"),
    n_phases=2,
)


def _atmosphere(cfg: Config):
    """The configured 6S table if the package ships it, else None (stated)."""
    if cfg.atmosphere is None:
        return None, "none requested"
    from bandopt.datasets import atmosphere as atm

    if atm.resolve_setting("auto") == "none":
        return None, "6S tables not installed (`make atmospheres`); rendered without"
    return cfg.atmosphere, (
        "6S upward transmittance at nadir: direct for the pixel's own ground, "
        "diffuse for k = 0.1 x the tile's mean (scene.DEFAULT_NEIGHBOURHOOD, "
        "lit street in a dark district; bandopt.spatial.render)"
    )


def scenes(cfg: Config):
    """(group, name, layout, params) for every scene of the study."""
    from bandopt.spatial import arrangement

    common = dict(
        length_m=cfg.length_m,
        width_m=cfg.width_m,
        lamps=(cfg.lamp,),
        flux_lm=None,
        lighting_class=cfg.lighting_class,
    )
    out = []
    out.append(
        (
            "single",
            "single",
            arrangement(
                "single",
                spacing_m=cfg.base_spacing_m,
                mounting_height_m=cfg.base_height_m,
                **{**common, "flux_lm": 0.0},
            ),
            {},
        )
    )
    for s in cfg.spacings_m:
        for h in cfg.heights_m:
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
    for a in cfg.arrangements:
        lay = arrangement(
            a,
            spacing_m=cfg.base_spacing_m,
            mounting_height_m=cfg.base_height_m,
            **common,
        )
        out.append(("arrangements", a, lay, {"arrangement": a}))
    for p in cfg.patterns:
        lay = arrangement(
            "single-sided",
            spacing_m=cfg.base_spacing_m,
            mounting_height_m=cfg.base_height_m,
            luminaire=p,
            name=f"pattern-{p}",
            **common,
        )
        out.append(("patterns", lay.name, lay, {"pattern": p}))
    return out


def main(cfg: Config, out: Path) -> dict:
    import dataclasses as dc

    from tqdm import tqdm

    from bandopt.provenance import write_manifest
    from bandopt.sensor import reference_sensor
    from bandopt.spatial import gsd_sweep, load_layout, render, resolve_flux

    t0 = time.time()
    out.mkdir(parents=True, exist_ok=True)
    (out / "images").mkdir(exist_ok=True)
    bands = reference_sensor(cfg.bands)
    atmosphere, atm_note = _atmosphere(cfg)
    todo = scenes(cfg)
    # the single lamp gets the flux of the single-sided row at the base geometry
    row = next(
        lay
        for g, _, lay, _ in todo
        if g == "arrangements" and lay.meta[0][1] == "single-sided"
    )
    row_flux = float(resolve_flux(row).flux_lm[0])
    todo[0] = (
        todo[0][0],
        todo[0][1],
        dc.replace(
            todo[0][2],
            lamps=tuple(dc.replace(p, flux_lm=row_flux) for p in todo[0][2].lamps),
        ),
        {},
    )
    mixed = load_layout("mixed-led-hps")
    mixed = dc.replace(mixed, length_m=cfg.length_m, width_m=cfg.width_m)
    todo.append(("mixed", "mixed-led-hps", mixed, {}))

    rows, table, keep = [], [], {}
    for group, name, layout, params in tqdm(todo, desc="scenes", unit="scene"):
        scene = render(layout, bands, dx_m=cfg.dx_m, atmosphere=atmosphere)
        figures = group in ("single", "arrangements", "mixed", "patterns")
        sweep = gsd_sweep(
            scene,
            bands,
            cfg.gsds_m,
            n_phases=cfg.n_phases,
            seed=cfg.seed,
            keep_observations=figures,
        )
        flux = {"lamp_flux_lm": float(np.nanmax(scene.lamps.flux_lm))}
        for sc in sweep.scores:
            head = {"group": group, "scene": name, **params}
            rows += [{**head, **r, **flux} for r in sc.phase_rows()]
            mean = sc.mean_row()
            table.append(
                {**head, "gsd_m": sc.gsd_m, "n_targets": sc.n_targets, **flux, **mean}
            )
            if figures:
                keep[(name, sc.gsd_m)] = (sweep.first_phase[sc.gsd_m], scene)
        if group in ("single", "arrangements", "mixed"):
            _save_fine(out, name, scene)
    _write_tables(out, rows, table)
    needed = _needed(table, cfg)
    _figures(out, cfg, keep, table)
    summary = {
        "config": dc.asdict(cfg),
        "atmosphere": atm_note,
        "row_flux_lm": row_flux,
        "gsd_needed_m": needed,
        "seconds": round(time.time() - t0, 1),
        "thesis": "about 10 m in most cases (De Meester 2019, section 4.3)",
        "assumptions": [
            "nadir view, flat Lambertian ground, single bounce, point luminaires",
            "adjacency: T_dir L(x) + k T_dif <L>_tile with the default "
            "neighbourhood (lit street in a dark district, k = 0.1; "
            "bandopt.spatial.render); lamp-light path radiance neglected",
            "PSF Gaussian with FWHM = 1 GSD, box pixel, photon noise (Table 2.3 "
            "sensor, integration time from GSD at 600 km), 14-bit, saturation 1e-3",
            "DoG thresholds fixed in advance, identical for every GSD and scene",
            "match radius 5 m + GSD/√2 (pool offset plus half a pixel "
            "diagonal); twin poles are one target",
        ],
        "overlapping_lamp_types": "see overlap.json / overlap.png "
        "(python -m experiments.spatial_overlap, run by `make spatial`)",
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=str) + "\n")
    _markdown(out, summary, table, cfg)
    write_manifest(out, seed=cfg.seed, config=dc.asdict(cfg))
    _recommend(summary, cfg)
    return summary


def _recommend(summary: dict, cfg) -> None:
    """Add the GSD needed per arrangement to results/recommendation.json."""
    import statistics

    from bandopt.results import update_recommendation

    per = {k: v["coarsest_gsd_m"] for k, v in summary["gsd_needed_m"].items()}
    rows = [v for k, v in per.items() if k in cfg.arrangements or k.startswith("row-")]
    found = [v for v in rows if v is not None]
    update_recommendation(
        "spatial",
        {
            "gsd_needed_m_per_scene": per,
            "median_gsd_needed_m": statistics.median(found) if found else None,
            "scenes_never_detected": [k for k, v in per.items() if v is None],
            "rule": "coarsest GSD with single-lamp detection F1 >= "
            f"{cfg.f1_needed} (DoG, threshold fixed in advance)",
            "thesis": summary["thesis"],
        },
    )


def recommend_from_summary(out: Path) -> int:
    """Rewrite the spatial part of results/recommendation.json from the
    `summary.json` of a finished run, by the same rule as `main`."""
    path = out / "summary.json"
    if not path.is_file():
        raise SystemExit(f"{path}: no spatial summary; run the experiment first.")
    summary = json.loads(path.read_text())
    fields = {f.name for f in dataclasses.fields(Config)}
    cfg = Config(
        **{
            k: tuple(v) if isinstance(v, list) else v
            for k, v in summary["config"].items()
            if k in fields
        }
    )
    _recommend(summary, cfg)
    print(f"wrote key 'spatial' of results/recommendation.json from {path}")
    return 0


def _needed(table, cfg):
    """Per scene: `bandopt.spatial.coarsest_gsd` of its phase-mean F1."""
    from bandopt.spatial import coarsest_gsd

    res = {}
    for name in dict.fromkeys(r["scene"] for r in table):
        f1 = {r["gsd_m"]: r["f1"] for r in table if r["scene"] == name}
        res[name] = coarsest_gsd(f1, cfg.f1_needed).as_dict()
    return res


def _write_tables(out, rows, table):
    for name, data in (("detections_by_phase", rows), ("detections", table)):
        keys = list(dict.fromkeys(k for r in data for k in r))
        with open(out / f"{name}.csv", "w", newline="") as f:
            w = csv.DictWriter(f, keys)
            w.writeheader()
            w.writerows(data)
        (out / f"{name}.json").write_text(json.dumps(data, indent=1) + "\n")


def _save_fine(out, name, scene):
    """The fine radiance image box-averaged to 1 m (zlib-compressed float32 TIFF;
    the full 0.25 m grid would be ~8 MB per scene)."""
    import tifffile

    from bandopt.spatial import block_mean

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


def _figures(out, cfg, keep, table):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import tifffile

    names = [
        n
        for n in ("single", *cfg.arrangements, "mixed-led-hps")
        if (n, cfg.gsds_m[0]) in keep
    ]
    fig, axes = plt.subplots(
        len(names),
        len(cfg.gsds_m),
        figsize=(2.6 * len(cfg.gsds_m), 1.9 * len(names)),
        squeeze=False,
    )
    for a, name in enumerate(names):
        for b, gsd in enumerate(cfg.gsds_m):
            obs, scene = keep[(name, gsd)]
            tifffile.imwrite(
                out / "images" / f"{name}_gsd{gsd:g}m.tif",
                np.asarray(obs.image, np.float32),
                compression="zlib",
                metadata={"unit": "W m-2 sr-1 nm-1", "gsd_m": gsd},
            )
            ax = axes[a, b]
            _show(ax, obs, scene, zoom=True)
            s = obs.score
            ax.set_title(
                f"{name} {gsd:g} m\nP{s.precision:.2f} R{s.recall:.2f}", fontsize=7
            )
    fig.tight_layout()
    fig.savefig(out / "arrangements_by_gsd.png", dpi=100)
    plt.close(fig)
    for name in names:
        for gsd in cfg.gsds_m:
            obs, scene = keep[(name, gsd)]
            f, ax = plt.subplots(figsize=(9, 3.2))
            _show(ax, obs, scene, zoom=False)
            s = obs.score
            ax.set_title(
                f"{name}, GSD {gsd:g} m: precision {s.precision:.2f}, "
                f"recall {s.recall:.2f}, F1 {s.f1:.2f}",
                fontsize=9,
            )
            f.tight_layout()
            f.savefig(out / "images" / f"{name}_gsd{gsd:g}m.png", dpi=90)
            plt.close(f)
    _cross_sections(out, cfg, keep)
    _f1_plot(out, cfg, table)


def _show(ax, obs, scene, zoom):
    from bandopt.spatial import true_targets

    g = obs.grid
    ext = (g.x0_m, g.x0_m + g.nx * g.dx_m, g.y0_m, g.y0_m + g.ny * g.dx_m)
    pan = obs.image.mean(axis=0)
    ax.imshow(
        np.sqrt(np.maximum(pan, 0)),
        origin="lower",
        extent=ext,
        cmap="magma",
        aspect="auto" if zoom else "equal",
    )
    t = true_targets(scene)
    ax.plot(t[:, 0], t[:, 1], "o", mfc="none", mec="cyan", ms=4)
    d = obs.detections.xy_m
    if d.size:
        ax.plot(d[:, 0], d[:, 1], "+", color="lime", ms=6)
    if zoom:
        ax.set_xlim(t[:, 0].min() - 60, t[:, 0].max() + 60)
        ax.set_ylim(-50, 50)
        ax.set_xticks([])
        ax.set_yticks([])


def _cross_sections(out, cfg, keep):
    """Figures 4.8-4.9: single-lamp radiance and DoG response along and across."""
    import matplotlib.pyplot as plt

    from bandopt.spatial import cross_section

    data = {}
    for axis, fname in (
        ("along", "cross_section_along.png"),
        ("across", "cross_section_across.png"),
    ):
        fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        for gsd in cfg.gsds_m:
            if gsd > 50:
                continue
            obs, scene = keep[("single", gsd)]
            cs = cross_section(obs, scene, axis)
            sel = np.abs(cs["position_m"]) <= 80
            axes[0].step(
                cs["position_m"][sel],
                cs["radiance"][sel],
                where="mid",
                label=f"{gsd:g} m",
            )
            axes[1].step(cs["position_m"][sel], cs["dog"][sel], where="mid")
            data[f"{axis}_{gsd:g}m"] = {
                k: np.asarray(v).tolist() if np.ndim(v) else v for k, v in cs.items()
            }
        axes[0].set_ylabel("TOA radiance [W m-2 sr-1 nm-1]")
        axes[1].set_ylabel("DoG response")
        axes[1].set_xlabel(f"distance from the lamp {axis} the road [m]")
        axes[0].legend(fontsize=8, title="GSD")
        axes[0].set_title(f"Single lamp, cross-section {axis} the road")
        fig.tight_layout()
        fig.savefig(out / fname, dpi=100)
        plt.close(fig)
    (out / "cross_sections.json").write_text(json.dumps(data) + "\n")


def _f1_plot(out, cfg, table):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(14, 4), sharey=True)
    for ax, group, key in (
        (axes[0], "arrangements", "arrangement"),
        (axes[1], "rows", None),
        (axes[2], "patterns", "pattern"),
    ):
        for name in dict.fromkeys(r["scene"] for r in table if r["group"] == group):
            rs = sorted(
                (r for r in table if r["scene"] == name), key=lambda r: r["gsd_m"]
            )
            ax.plot(
                [r["gsd_m"] for r in rs],
                [r["f1"] for r in rs],
                "o-",
                ms=3,
                label=name if key is None else rs[0][key],
            )
        ax.set_xscale("log")
        ax.axhline(cfg.f1_needed, color="grey", lw=0.8, ls="--")
        ax.set_title(group)
        ax.set_xlabel("GSD [m]")
        ax.legend(fontsize=6)
    axes[0].set_ylabel("F1 (mean over grid phases)")
    fig.tight_layout()
    fig.savefig(out / "f1_by_gsd.png", dpi=100)
    plt.close(fig)


def _markdown(out, summary, table, cfg):
    lines = [
        "# Spatial sampling: single-lamp detection by GSD",
        "",
        f"Atmosphere: {summary['atmosphere']}. Run time {summary['seconds']} s.",
        "",
        "F1 (mean over grid phases) per GSD; 'needed' = coarsest GSD with "
        f"F1 >= {cfg.f1_needed}.",
        "",
        "| scene | " + " | ".join(f"{g:g} m" for g in cfg.gsds_m) + " | needed |",
        "|---|" + "---|" * (len(cfg.gsds_m) + 1),
    ]
    for name, v in summary["gsd_needed_m"].items():
        f1 = [v["f1_by_gsd"].get(f"{g:g}", float("nan")) for g in cfg.gsds_m]
        need = v["coarsest_gsd_m"]
        lines.append(
            f"| {name} | "
            + " | ".join(f"{x:.2f}" for x in f1)
            + f" | {'none' if need is None else f'{need:g} m'} |"
        )
    arr = [
        v["coarsest_gsd_m"]
        for k, v in summary["gsd_needed_m"].items()
        if k in cfg.arrangements or k.startswith("row-")
    ]
    found = [a for a in arr if a is not None]
    lines += [
        "",
        "## Conclusion",
        "",
        f"Over the {len(arr)} row and arrangement scenes the coarsest GSD that "
        f"still detects single lamps (F1 >= {cfg.f1_needed}) has median "
        f"{np.median(found) if found else float('nan'):g} m; "
        f"{len(arr) - len(found)} scene(s) reach it at no GSD. The thesis found "
        "about 10 m in most cases.",
        "",
        "Why (see the cross-sections and the images): with no light sent "
        "straight up, a nadir sensor sees the lit ground, not the lamp. At "
        "1-5 m the light pool of a road optic is resolved into its lobes along "
        "the road and into the bright sidewalk strips across it, so the DoG "
        "finds several blobs per lamp: the one on the sidewalk beside the pole "
        "is the lamp, the others are false detections (precision about 0.5). "
        "Near 10 m one pool becomes one blob centred "
        "on its lamp. Once the GSD approaches half the spacing between "
        "neighbouring lamps (the 15 m of a staggered layout, 20 m rows with "
        "high poles), neighbouring pools merge into a continuous band and "
        "recall falls; at 50-100 m the road is a line. Luminaires that send "
        "light straight up (Illumina 20 % and 50 % profiles in the full run) "
        "are point-like "
        "targets and are found at every GSD down to 1 m.",
    ]
    lines += [
        "",
        "Assumptions: " + "; ".join(summary["assumptions"]) + ".",
        "",
        "Overlapping lamp types: " + summary["overlapping_lamp_types"] + ".",
    ]
    (out / "summary.md").write_text("\n".join(lines) + "\n")


def cli(argv=None) -> int:
    import bandopt

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="coarser grid, fewer scenes")
    p.add_argument("--out", default="results/spatial")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--recommend-only",
        action="store_true",
        help="only (re)write key 'spatial' of results/recommendation.json from "
        "the existing OUT/summary.json (no rendering)",
    )
    args = p.parse_args(argv)
    if args.recommend_only:
        return recommend_from_summary(Path(args.out))
    bandopt.configure()
    cfg = Config(seed=args.seed, **(QUICK if args.quick else {}))
    s = main(cfg, Path(args.out))
    for name, v in s["gsd_needed_m"].items():
        print(f"{name:28s} needed GSD: {v['coarsest_gsd_m']}  F1 {v['f1_by_gsd']}")
    print(f"done in {s['seconds']} s -> {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(cli())
