"""Benchmark of the command line: start-up of a listing and the
memory of reading a large spectrum file, against the code before issue 15.

Run:   python -m experiments.bench_cli [--rows 5000000] [--repeat 3]
Writes results/bench/cli.json (+ cli_manifest/manifest.json).

1. Start-up: wall time of `bandopt library --json` in a fresh process (median
   of `--repeat` runs after one warm-up run that fills the listing cache and
   JAX's compilation cache).
2. Peak memory (maximum resident set size of the process, from `wait4`) and
   wall time of `bandopt metrics FILE --json` on a `--rows`-row CSV: a 2856 K
   Planck spectrum (CIE illuminant A) sampled every 1e-4 nm from 380 nm.

Both are measured for this checkout and for the pre-change code, commit
`BASELINE_COMMIT` (extracted with `git archive` into a temporary folder), in
the same run on the same machine: the ratio is meaningful even on a loaded
machine, the absolute times are not.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bandopt.strict_json import strict_dumps


BASELINE_COMMIT = "85d9335"
"""main before issue 15 (the CLI read CSVs as Python lists and built the
lamp library on every `library` call)."""

ROOT = Path(__file__).resolve().parents[1]
RUNNER = "import sys; from bandopt.cli import main; sys.exit(main())"


def measure(
    src: Path, argv: list[str], env_extra: dict | None = None, cwd=None
) -> dict:
    """Run `bandopt argv` with `src` first on the path, from the neutral
    folder `cwd` (`python -c` puts the working folder before PYTHONPATH);
    wall time [s] and peak resident memory [MiB] of that process alone
    (os.wait4)."""
    env = {**os.environ, "PYTHONPATH": str(src), **(env_extra or {})}
    t0 = time.perf_counter()
    p = subprocess.Popen(
        [sys.executable, "-c", RUNNER, *argv],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        cwd=cwd if cwd is not None else tempfile.gettempdir(),
    )
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    err = p.stderr.read().decode()
    p.stderr.close()
    rc = os.waitstatus_to_exitcode(status)
    if rc != 0:
        raise RuntimeError(f"{src}: bandopt {' '.join(argv)} failed ({rc}): {err}")
    return {"wall_s": round(wall, 3), "max_rss_mib": round(usage.ru_maxrss / 1024, 1)}


def check_source(src: Path) -> None:
    """The process measured must import bandopt from `src`."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    got = subprocess.run(
        [sys.executable, "-c", "import bandopt; print(bandopt.__file__)"],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        cwd=tempfile.gettempdir(),
    ).stdout.strip()
    if not Path(got).resolve().is_relative_to(src.resolve()):
        raise RuntimeError(f"bandopt imported from {got}, expected under {src}")


def planck_csv(path: Path, rows: int) -> Path:
    w = 380.0 + np.arange(rows) * 1e-4
    with path.open("w") as fh:
        fh.write("wavelength_nm,value\n")
        step = 500_000
        for i in range(0, rows, step):
            x = w[i : i + step]
            v = x**-5 / np.expm1(1.438776877e7 / (x * 2856.0))
            np.savetxt(fh, np.c_[x, v / 1e-14], fmt="%.4f,%.8g")
    return path


def baseline_source(tmp: Path) -> Path:
    dest = tmp / "baseline"
    dest.mkdir()
    archive = subprocess.run(
        ["git", "archive", BASELINE_COMMIT],
        cwd=ROOT,
        capture_output=True,
        check=True,
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


def startup(src: Path, repeat: int, cache: Path) -> dict:
    env = {"BANDOPT_CACHE": str(cache)}
    measure(src, ["library", "--json"], env)  # warm-up: caches filled
    runs = [measure(src, ["library", "--json"], env) for _ in range(repeat)]
    walls = [r["wall_s"] for r in runs]
    return {
        "median_s": round(statistics.median(walls), 3),
        "min_s": min(walls),
        "runs_s": walls,
        "max_rss_mib": max(r["max_rss_mib"] for r in runs),
    }


def main(argv=None) -> Path:
    from bandopt.provenance import write_manifest

    ap = argparse.ArgumentParser(prog="python -m experiments.bench_cli")
    ap.add_argument("--rows", type=int, default=5_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default="results/bench")
    args = ap.parse_args(argv)
    out = Path(args.out)
    result = {
        "baseline_commit": BASELINE_COMMIT,
        "note": (
            "baseline = main before issue 15, current = this checkout; both "
            "measured in this run on this machine (2 cores shared with other "
            "jobs: compare ratios, not absolute times). Start-up: median wall "
            "time of `bandopt library --json` after a warm-up run (current: "
            "served from the listing cache without importing JAX; baseline: "
            "builds the library each time). Memory: peak RSS of `bandopt "
            "metrics FILE --json` on a Planck-spectrum CSV of --rows rows "
            "(baseline: Python lists, ~310 B/row; current: streamed numpy "
            "chunks, 16 B/row)."
        ),
        "rows": args.rows,
        "repeat": args.repeat,
    }
    with tempfile.TemporaryDirectory(prefix="bench_cli-") as tmp:
        tmp = Path(tmp)
        base = baseline_source(tmp)
        csv = planck_csv(tmp / "planck.csv", args.rows)
        result["csv_bytes"] = csv.stat().st_size
        for name, src in (("baseline", base), ("current", ROOT)):
            check_source(src)
            print(f"[bench_cli] {name}: start-up ({src})", flush=True)
            s = startup(src, args.repeat, tmp / f"cache-{name}")
            print(f"[bench_cli] {name}: metrics on {args.rows} rows", flush=True)
            m = measure(src, ["metrics", str(csv), "--json"])
            result[name] = {"library_json_startup": s, "metrics_large_csv": m}
    b, c = result["baseline"], result["current"]
    rss = [r["metrics_large_csv"]["max_rss_mib"] for r in (c, b)]
    result["ratio_current_over_baseline"] = {
        "library_json_startup_median": round(
            c["library_json_startup"]["median_s"]
            / b["library_json_startup"]["median_s"],
            4,
        ),
        "metrics_peak_rss": round(rss[0] / rss[1], 4),
        "metrics_wall": round(
            c["metrics_large_csv"]["wall_s"] / b["metrics_large_csv"]["wall_s"], 4
        ),
    }
    out.mkdir(parents=True, exist_ok=True)
    path = out / "cli.json"
    path.write_text(strict_dumps(result, indent=2) + "\n")
    write_manifest(out / "cli_manifest", config=vars(args))
    print(json.dumps(result["ratio_current_over_baseline"], indent=2))
    print(f"wrote {path}")
    return path


if __name__ == "__main__":
    main()
    sys.exit(0)
