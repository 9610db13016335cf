"""Physical lamp models: fit quality and leave-one-lamp-out validation against
the measured lamps of each class (`bandopt.lampmodels.write_validation`).

Run:   python -m experiments.lamp_models [--classes hps lps ...] [--samples 200]
Writes results/library/ lamp_models.json (per-class summary, settings),
lamp_models.csv (one row per measured lamp), lamp_models.png, and
lamp_models_manifest.json.
"""

import argparse
from pathlib import Path

from bandopt.provenance import add_allow_dirty, refuse_dirty_at_start


ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "results" / "library"


def main(argv: list[str] | None = None) -> int:
    import jax

    jax.config.update("jax_enable_x64", True)
    from bandopt.lampmodels import write_validation

    p = argparse.ArgumentParser(prog="python -m experiments.lamp_models")
    p.add_argument("--classes", nargs="*", default=None)
    p.add_argument("--samples", type=int, default=200)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--max-lamps",
        type=int,
        default=16,
        help="validate at most this many measured lamps per class (seeded random "
        "subset; 0: all)",
    )
    p.add_argument("--out", type=Path, default=OUT)
    add_allow_dirty(p)
    args = p.parse_args(argv)
    refuse_dirty_at_start(p, args, args.out)
    write_validation(
        args.out,
        classes=args.classes,
        samples=args.samples,
        seed=args.seed,
        max_lamps=args.max_lamps or None,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
