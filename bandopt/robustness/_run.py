"""The robustness study's resumable run: units (partition x band set)
appended to a records file as they finish, kept on resume unless their band
set changed since (`bandopt.robustness`)."""

import gzip
import json
from collections.abc import Callable, Sequence
from pathlib import Path

from ..results import (
    DATA_KEY,
    band_digest,
    changed_band_sets,
    data_digest,
    digests_path,
    record_digests,
)
from ..sensor.reference import resolve_band_set
from ..strict_json import strict_dumps
from ._study import RobustnessStudy, partition, perturbed_lamps, run_partition


def _open(path: Path, mode: str):
    """A text file, gzip-compressed when its name ends in `.gz` (appending
    adds a gzip member; readers see one stream)."""
    return gzip.open(path, mode) if path.suffix == ".gz" else path.open(mode[0])


def load_records(
    path: Path, study: RobustnessStudy, resume: bool, digests: dict | None = None
):
    """Records of finished units `(partition, band set)` in `path` (JSON
    lines, gzip-compressed if it ends in `.gz`; a unit is
    finished when it holds every row the study can score in it) and the set
    of those units; an empty start without `resume` (the file is removed).

    `digests` (label -> `band_digest`): a band set whose digest differs from
    the one recorded beside the records (`digests_path`) has changed since
    its units ran, so its units are not finished (they rerun: a band set
    that changed, e.g. a new recommendation, is recomputed and the others
    are kept). A label without a recorded digest is kept as it is."""
    path = Path(path)
    side = digests_path(path)
    if not resume or not path.is_file():
        path.unlink(missing_ok=True)
        side.unlink(missing_ok=True)
        return [], set()
    changed = changed_band_sets(path, digests)
    recs = []
    with _open(path, "rt") as fh:
        try:
            for line in fh:
                try:
                    recs.append(json.loads(line))
                except json.JSONDecodeError:  # an interrupted write: unit reruns
                    continue
        except EOFError:  # a gzip member cut short by an interrupted write
            pass
    units: dict = {}
    for r in recs:
        units.setdefault((r["partition"], r["band_set"]), set()).add(r["perturbation"])
    need = {p.label for p in study.perturbations}
    done = {u for u, labels in units.items() if need <= labels and u[1] not in changed}
    kept = [
        r
        for r in recs
        if (r["partition"], r["band_set"]) in done and r["perturbation"] in need
    ]
    with _open(path, "wt") as fh:
        fh.writelines(strict_dumps(r, indent=None) + "\n" for r in kept)
    return kept, done


def run_study(
    study: RobustnessStudy,
    records_path: Path,
    *,
    resume: bool = False,
    partitions: Sequence[int] | None = None,
    log: Callable[[str], None] = lambda msg: None,
) -> list[dict]:
    """Every unit (partition x band set) of `study` not already in
    `records_path` (with `resume`), each appended there when finished;
    returns all records. `partitions`: a subset to compute (default all)."""
    bands = {label: resolve_band_set(src).bands for label, src in study.band_sets}
    digests = {label: band_digest(b) for label, b in bands.items()}
    digests[DATA_KEY] = data_digest()
    records, done = load_records(records_path, study, resume, digests)
    record_digests(records_path, digests)
    todo = range(study.partitions) if partitions is None else partitions
    for p in todo:
        if all((p, b) in done for b in bands):
            continue
        part = partition(study, p)
        perturbed = perturbed_lamps(study, part)
        log(
            f"partition {p}: {len(part.train)} training, {len(part.test)} held-out "
            f"lamps, {len(perturbed)} spectral rows"
        )
        for label, b in bands.items():
            if (p, label) in done:
                continue
            recs = run_partition(study, part, label, b, perturbed, log)
            with _open(Path(records_path), "at") as fh:
                fh.writelines(strict_dumps(r, indent=None) + "\n" for r in recs)
            records += recs
            log(f"partition {p}, {label}: done ({len(recs)} records)")
    return records
