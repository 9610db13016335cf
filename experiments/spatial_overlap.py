"""Lamp-type identification where two lamp types share pixels, per GSD.

Run:   python -m experiments.spatial_overlap [--quick]
Writes results/spatial/overlap.{json,csv,png} and overlap_manifest/manifest.json.

Layout: the shipped `mixed-led-hps` arrangement (HPS and LED lamps alternating
along a single-sided row). Bands: the classification bands of
results/recommendation.json when present, else SDGSAT-1. Each lamp type's
band image is resampled to the GSD, the sum gets photon noise and 14-bit
quantisation, and each lit pixel is classified (`bandopt.classify`).
"""

import argparse
import json
from pathlib import Path


GSDS_M = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0)


def _bands(results: Path):
    from bandopt.results import recommended_band_set
    from bandopt.sensor import reference_sensor

    bands = recommended_band_set("classification", results_dir=results)
    if bands is not None:
        return bands, "results/recommendation.json classification"
    return reference_sensor("sdgsat-1"), "sdgsat-1 (no classification bands found)"


def main(argv=None) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from tqdm import tqdm

    import bandopt
    from bandopt.provenance import write_manifest
    from bandopt.spatial import (
        lamp_type_f1_when_overlapping,
        load_layout,
        per_type_radiance,
        render,
    )

    bandopt.configure()
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="coarser grid, fewer GSDs")
    p.add_argument("--out", default="results/spatial")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    bands, source = _bands(Path("results"))
    atmosphere = ("midlatitude_summer", "urban", 23.0)
    from bandopt.datasets import atmosphere as atm

    if atm.resolve_setting("auto") == "none":  # no 6S tables: no atmosphere
        atmosphere = None
    dx = 1.0 if args.quick else 0.5
    scene = render(load_layout("mixed-led-hps"), bands, dx_m=dx, atmosphere=atmosphere)
    per_type = per_type_radiance(scene, bands)
    rows = []
    gsds = GSDS_M[1:5] if args.quick else GSDS_M
    for g in tqdm(gsds, desc="overlap", unit="GSD"):
        rows.append(
            lamp_type_f1_when_overlapping(
                scene, bands, g, per_type=per_type, seed=args.seed
            ).as_dict()
        )
    (out / "overlap.json").write_text(
        json.dumps(
            {"bands": source, "atmosphere": atmosphere, "dx_m": dx, "rows": rows},
            indent=2,
            default=float,
        )
        + "\n"
    )
    import pandas as pd

    flat = [
        {k: v for k, v in r.items() if k != "f1_per_class"}
        | {f"f1_{c}": f for c, f in r["f1_per_class"].items()}
        for r in rows
    ]
    pd.DataFrame(flat).to_csv(out / "overlap.csv", index=False)
    fig, ax = plt.subplots(figsize=(6, 4))
    g = [r["gsd_m"] for r in rows]
    for key, lab in (
        ("macro_f1", "all lit pixels"),
        ("f1_pure", "pure pixels"),
        ("f1_mixed", "mixed pixels (>= 10 % other type)"),
    ):
        ax.plot(g, [r[key] for r in rows], "o-", label=lab)
    ax.plot(g, [r["mixed_fraction"] for r in rows], "k--", label="fraction mixed")
    ax.set_xscale("log")
    ax.set_xlabel("GSD [m]")
    ax.set_ylabel("level-2 macro F1 / fraction")
    ax.set_ylim(0, 1)
    ax.set_title("Lamp type where HPS and LED light share pixels")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "overlap.png", dpi=120)
    plt.close(fig)
    write_manifest(
        out / "overlap_manifest",
        seed=args.seed,
        config={**vars(args), "bands": source, "gsds_m": list(gsds)},
    )
    for r in rows:
        print(
            f"GSD {r['gsd_m']:>5g} m  lit {r['n_lit']:>6d}  mixed "
            f"{r['mixed_fraction']:.2f}  F1 {r['macro_f1']:.2f} (pure "
            f"{r['f1_pure']:.2f}, mixed {r['f1_mixed']:.2f})"
        )
    return out / "overlap.json"


if __name__ == "__main__":
    main()
