"""The units a study is made of and kept by: band sets by name, the
records file a resumable run appends each finished (partition, band set)
unit to, the command line every partitioned study shares, its CSV tables
and the outputs every study ends with (`write_outputs`)."""

import argparse
import csv
import json
import sys
import time
from pathlib import Path

from ..provenance import add_allow_dirty, refuse_dirty_at_start, write_manifest
from ..results import (
    changed_band_sets,
    digests_path,
    recommended_band_set,
    record_digests,
    update_readme_section,
)
from ..sensor import BandSet
from ..sensor.reference import resolve
from ..strict_json import strict_dumps


CONTIGUOUS = "contiguous-"
"""Prefix of a band-set name "contiguous-N" (`band_set`)."""


RECOMMENDED = Path("results/recommendation.json")
"""Where "recommended" comes from: the "spectral" key of the recommendation
(the judge's choice after `make judge`, else the search's pick)."""


def log(msg: str, study: str = "study") -> None:
    """Progress line on stderr, `[study HH:MM:SS] msg`."""
    print(f"[{study} {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def load_records(
    rec_path: Path, *, keep: bool, say=None, digests: dict | None = None
) -> tuple[list, set]:
    """Records of a resumable run and its finished (partition, band set)
    units. Without `keep` the file is deleted first (results are
    recomputed, not replayed); an unreadable line (an interrupted write) is
    dropped with a message through `say` (default `log`).

    `digests` (band set name -> `results.band_digest`): a band set whose
    digest differs from the one recorded beside the records
    (`results.digests_path`) changed since its units ran; its records are
    dropped so its units rerun (the others are kept), and the current
    digests are recorded."""
    say = log if say is None else say
    side = digests_path(rec_path)
    if rec_path.is_file() and not keep:
        rec_path.unlink()
        side.unlink(missing_ok=True)
    changed = changed_band_sets(rec_path, digests)
    records, done = [], set()
    if rec_path.is_file():
        for i, line in enumerate(rec_path.read_text().splitlines()):
            try:
                r = json.loads(line)
            except json.JSONDecodeError:
                say(f"{rec_path}:{i + 1}: unreadable line dropped (interrupted write)")
                continue
            if r["band_set"] in changed:
                continue
            records.append(r)
            done.add((r["partition"], r["band_set"]))
        if changed:
            say(f"band sets changed since their records: {sorted(changed)} (rerun)")
            rec_path.write_text(
                "".join(strict_dumps(r, indent=None) + "\n" for r in records)
            )
    if digests:
        record_digests(rec_path, digests)
    return records, done


def band_set(name: str):
    """A study's band set by name: "recommended" (the recommendation's
    "spectral" bands),
    "contiguous-N" (N equal-width bands tiling the scenes' 380-900 nm,
    `BandSet.contiguous`) or a reference sensor."""
    if name == "recommended":
        bands = recommended_band_set("spectral", path=RECOMMENDED)
        if bands is None:
            raise SystemExit(
                f"{RECOMMENDED}: no 'spectral' band set; run `make run` (and "
                "`make judge`) first."
            )
        return bands
    if name.startswith(CONTIGUOUS):
        count = name[len(CONTIGUOUS) :]
        if not count.isdigit():
            raise ValueError(
                f"band set {name!r}: expected {CONTIGUOUS}N, N an integer."
            )
        return BandSet.contiguous(int(count))
    return resolve(name).build()


def keep_unit(rec_path: Path, recs: list[dict]) -> list[dict]:
    """Append a finished unit's records to `rec_path` (a resumable run keeps
    them whatever fails later) and return them."""
    with rec_path.open("a") as fh:
        for r in recs:
            fh.write(strict_dumps(r, indent=None) + "\n")
    return recs


def partition_args(argv, description: str, out: str, unseen: bool = True):
    """The command line of a partitioned, resumable study: `--partitions`,
    `--out` (default `out`), `--resume`, `--only-partitions` and, with
    `unseen`, `--no-unseen`, and `--allow-dirty`; (args, the partitions to
    compute). An output folder inside the repository's `results/` is refused
    here, before any computation, while the code tree is dirty
    (`bandopt.provenance.check_clean_tree`) unless `--allow-dirty` (which sets
    `BANDOPT_ALLOW_DIRTY=1` for the run's manifest too)."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--partitions", type=int, default=4, help="lamp partitions")
    ap.add_argument("--out", default=None, help=f"output (default {out})")
    ap.add_argument(
        "--resume",
        action="store_true",
        help="keep finished (partition, band set) units of records.jsonl",
    )
    if unseen:
        ap.add_argument("--no-unseen", action="store_true", help="skip unseen types")
    ap.add_argument(
        "--only-partitions",
        type=int,
        nargs="+",
        default=None,
        metavar="P",
        help="compute only these partitions' units (to run partitions in "
        "parallel processes with their own --out; concatenate their "
        "records.jsonl and summarise with --resume)",
    )
    add_allow_dirty(ap)
    args = ap.parse_args(argv)
    if args.partitions < 1:
        ap.error("--partitions must be >= 1.")
    only = args.only_partitions
    if only is not None and any(not 0 <= p < args.partitions for p in only):
        ap.error(f"--only-partitions {only}: each must be in 0..{args.partitions - 1}.")
    if only is not None and args.out is None:
        ap.error("--only-partitions needs its own --out (a partial summary).")
    refuse_dirty_at_start(ap, args, args.out or out)
    return args, range(args.partitions) if only is None else only


def write_csv(path: Path, rows) -> None:
    """`rows` (dicts) as a CSV table: the columns are every key in first-seen
    order, list and dict values are written as JSON."""
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        for r in rows:
            w.writerow(
                {
                    k: json.dumps(v) if isinstance(v, (list, dict)) else v
                    for k, v in r.items()
                }
            )


def write_outputs(
    out: Path,
    summary: dict,
    figures,
    *,
    section: tuple | None,
    seed,
    config: dict,
    say,
    t0: float,
) -> int:
    """The outputs a study ends with: `summary.json`, each of `figures`
    ((draw(summary, path), file name) pairs) into `out`, the study's page of
    the results README when `section` is given ((name, readme, heading):
    `update_readme_section` of `readme(summary)`; a default run),
    `manifest.json` (`seed`, `config`), and the closing progress line via
    `say` (`t0`: start time [s since the epoch]); returns the exit status 0."""
    (out / "summary.json").write_text(strict_dumps(summary, indent=2) + "\n")
    for draw, name in figures:
        draw(summary, out / name)
    if section is not None:
        name, readme, heading = section
        update_readme_section(name, readme(summary), heading=heading)
    write_manifest(out, seed=seed, config=config)
    say(f"done: {out} ({time.time() - t0:.0f} s)")
    return 0
