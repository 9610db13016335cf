"""The overlap study: lamp-type identification where two lamp types share
pixels, per GSD.

Layout: the shipped `mixed-led-hps` arrangement (HPS and LED lamps alternating
along a single-sided row). Bands: the classification bands of
results/recommendation.json when present, else SDGSAT-1. Each lamp type's
band image is resampled to the GSD, the sum gets photon noise and 14-bit
quantisation, and each lit pixel is classified (`bandopt.classify`;
`lamp_type_f1_when_overlapping`). `run_overlap_study` writes
overlap.{json,csv,png} and overlap_manifest/manifest.json.
"""

from pathlib import Path

from ..datasets import atmosphere as atm
from ..provenance import write_manifest
from ..results import bands_record, recommended_band_set
from ..sensor import reference_sensor
from ..strict_json import strict_dumps
from ._imaging import GSDS_M
from ._layout import load_layout
from ._overlap import lamp_type_f1_when_overlapping, per_type_radiance
from ._render import render


OVERLAP_ATMOSPHERE = ("midlatitude_summer", "urban", 23.0)
"""6S (profile, aerosol, visibility [km]) of the overlap scene, when installed."""


def overlap_bands(results: Path):
    """The recommended design (the "spectral" bands of
    `results`/recommendation.json, the bands every other study judges),
    else SDGSAT-1; with a note saying which."""
    bands = recommended_band_set("spectral", results_dir=results)
    if bands is not None:
        return bands, "results/recommendation.json spectral (the recommended design)"
    return reference_sensor("sdgsat-1"), "sdgsat-1 (no recommended bands found)"


def run_overlap_study(
    out: Path,
    *,
    quick: bool = False,
    seed: int = 0,
    results: Path = Path("results"),
    config: dict | None = None,
) -> list[dict]:
    """Score lamp types on the mixed layout at every GSD (`quick`: a 1 m grid
    and 2-20 m) and write the outputs into `out`; `config` goes into the
    manifest beside the bands and GSDs. Returns the rows (one per GSD)."""
    import matplotlib  # plotting only: start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after matplotlib.use("Agg")
    import pandas as pd  # the CSV only: start-up time
    from tqdm import tqdm  # progress bar only: start-up time

    out.mkdir(parents=True, exist_ok=True)
    bands, source = overlap_bands(results)
    atmosphere = OVERLAP_ATMOSPHERE
    if atm.resolve_setting("auto") == "none":  # no 6S tables: no atmosphere
        atmosphere = None
    dx = 1.0 if quick else 0.5
    scene = render(load_layout("mixed-led-hps"), bands, dx_m=dx, atmosphere=atmosphere)
    per_type = per_type_radiance(scene, bands)
    rows = []
    gsds = GSDS_M[1:5] if quick else GSDS_M
    for g in tqdm(gsds, desc="overlap", unit="GSD"):
        rows.append(
            lamp_type_f1_when_overlapping(
                scene, bands, g, per_type=per_type, seed=seed
            ).as_dict()
        )
    (out / "overlap.json").write_text(
        strict_dumps(
            {
                "bands": source,
                "band_definitions": bands_record(bands),
                "atmosphere": atmosphere,
                "dx_m": dx,
                "rows": rows,
            },
            indent=2,
        )
        + "\n"
    )
    per_class = ("f1_per_class", "n_per_class", "n_predicted_per_class")
    flat = [
        {k: v for k, v in r.items() if k not in per_class}
        | {f"f1_{c}": f for c, f in r["f1_per_class"].items()}
        | {f"n_{c}": n for c, n in r["n_per_class"].items()}
        | {f"n_called_{c}": n for c, n in r["n_predicted_per_class"].items()}
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
        seed=seed,
        config={**(config or {}), "bands": source, "gsds_m": list(gsds)},
    )
    return rows
