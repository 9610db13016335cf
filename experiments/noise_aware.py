"""Noise-aware band design: how the optimum bands move with signal level.

Photon noise of the thesis Table 2.3 sensor (shot noise, 256 TDI stages) is
added to the band signal of every scene (one seeded normal draw per scene and
band, common random numbers so the loss stays smooth and deterministic);
narrow bands collect fewer electrons and pay for it in the ratio estimators.
For each signal level (noise-free, then EN 13201 classes from bright to dim)
the joint target is searched with 3 free bands + the fixed pan band on all
scored lamps (outer-fold CV loss), each level a resumable task.

Run:  python -m experiments.noise_aware [--levels none,C0,P4,P6] [--bands 3]
Writes results/noise_aware/: noise_aware.json, bands_vs_signal.png,
manifest.json, tasks/.
"""

import argparse
import json
import sys
from pathlib import Path


def main(argv=None) -> int:
    from bandopt import configure

    configure()
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--levels", default="none,C0,P4,P6")
    p.add_argument("--bands", type=int, default=3)
    p.add_argument("--max-evals", type=int, default=300)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--out", default="results/noise_aware")
    args = p.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bandopt.provenance import write_manifest
    from bandopt.search import make_task, print_progress, run_sweep

    levels = [None if v.lower() == "none" else v for v in args.levels.split(",")]
    tasks = [
        make_task(
            target="all",
            n_bands=args.bands,
            pan="fixed",
            fold="final",
            seed=args.seed,
            max_evals=args.max_evals,
            preset="search",
            noise=lv,
        )
        for lv in levels
    ]
    res = run_sweep(tasks, args.out, workers=args.workers, progress=print_progress)
    rows = []
    for lv, r in zip(levels, res, strict=True):
        if r is None:
            continue
        free = [b for b in r["bands"]["bands"] if b["name"] != "PAN"]
        rows.append(
            {
                "level": lv or "noise-free",
                "cv_loss": r["loss"],
                "bands": sorted((b["centre_nm"], b["fwhm_nm"]) for b in free),
            }
        )
    out = Path(args.out)
    (out / "noise_aware.json").write_text(
        json.dumps(
            {
                "rows": rows,
                "note": "3 free bands + fixed pan, target all, all scored lamps; "
                "sensor: thesis Table 2.3 (shot noise only)",
            },
            indent=2,
        )
        + "\n"
    )
    fig, ax = plt.subplots(figsize=(8, 0.8 + 0.7 * len(rows)))
    for i, r in enumerate(rows):
        for c, f in r["bands"]:
            ax.barh(i, f, left=c - f / 2, height=0.5, alpha=0.6, color="C0")
            ax.plot([c], [i], "k|")
        ax.text(905, i, f"loss {r['cv_loss']:.3f}", va="center", fontsize=8)
    ax.set_yticks(range(len(rows)), [r["level"] for r in rows])
    ax.set_xlim(380, 960)
    ax.set_xlabel("wavelength [nm] (bars: centre ± FWHM/2)")
    ax.set_title("Optimum bands against signal level (brighter at top)")
    ax.invert_yaxis()
    fig.tight_layout()
    fig.savefig(out / "bands_vs_signal.png", dpi=120)
    plt.close(fig)
    write_manifest(out, seed=args.seed, config={"tasks": tasks})
    if Path(args.out) == Path("results/noise_aware"):
        # the README section quotes the committed results only
        from experiments.readme_sections import write as write_section

        write_section("noise-aware")
    for r in rows:
        print(
            f"{r['level']:>10s}: loss {r['cv_loss']:.4f}  "
            + "  ".join(f"{c:.0f}/{f:.0f}" for c, f in r["bands"])
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
