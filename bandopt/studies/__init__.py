"""Studies as configurations, and the one machinery that runs them.

A study compares estimators on held-out measured lamps: the scenes, lamp
partitions and folds of the band search, estimators per band set and surface
mode, pairs compared paired by partition, and unseen types (each scored
class held out in turn). `Study` is its configuration; `STUDIES` the
registry (name -> `Study`, case and separators ignored); `run(study, argv)`
computes one, resumable per (partition, band set) unit, and writes its
records, summary, figure, manifest and README section. A new question about
the estimator is a new `Study` in `bandopt.studies.ablations`, registered
here, run by `make study NAME=...` (`make study` lists them).

- `_units`: band sets by name, the records file, the command line, CSV
  tables;
- `_text`: README cells, per-class means, `variant_text`;
- `_study`: `Study`, `run`, the default figure, the manifest;
- `library`, `moon`: two studies with machinery of their own (what a lamp
  the library lacks costs; the Moon's share of the error), run by
  `make estimate-library` and `make estimate-moon`;
- `unseen_ceiling` (`_ceiling`, `_ceiling_text`): what classifiers trained
  on the library's other lamp types attain on unseen types, from bare
  spectra, run by `make unseen-ceiling`;
- `estimate` (`_estimate_report`): the inversion against the ridge and
  kernel-ridge baselines per band set and surface mode, run by
  `make estimate`;
- `classification`, `classification_partitions`: lamp-type classification
  (its band search, the reference sensors, the conditions' influence:
  `make classify`) and fixed band sets classified over lamp partitions
  (`make classify-partitions`);
- `external_tm30`: `bandopt evaluate` run as a user runs it on the measured
  lamps of the IES TM-30-15 set the library lacks (`make external-tm30`);
- `judge`: the band search's candidate designs and the reference sensors
  judged by the shipped estimator on clean and perturbed held-out lamps, a
  configuration of the robustness study (`make judge`).
"""

from ..names import CanonicalMapping
from ._study import (
    BAND_SETS as BAND_SETS,
    UNKNOWN_ONLY as UNKNOWN_ONLY,
    Study as Study,
    figure as figure,
    manifest_config as manifest_config,
    oracle as oracle,
    run as run,
    unseen_records as unseen_records,
)
from ._text import (
    BASE as BASE,
    CLASS_KEYS as CLASS_KEYS,
    COLUMNS as COLUMNS,
    GRID as GRID,
    PAIRED_DIGITS as PAIRED_DIGITS,
    SHIFT as SHIFT,
    SHIFTS as SHIFTS,
    by_class as by_class,
    by_intervals as by_intervals,
    class_change_cells as class_change_cells,
    class_means as class_means,
    diff_cells as diff_cells,
    fmt_cell as fmt_cell,
    held_out_by_class as held_out_by_class,
    held_out_overall as held_out_overall,
    reference_lines as reference_lines,
    row_line as row_line,
    rows_table as rows_table,
    variant_text as variant_text,
    where_lines as where_lines,
)
from ._units import (
    CONTIGUOUS as CONTIGUOUS,
    RECOMMENDED as RECOMMENDED,
    band_set as band_set,
    keep_unit as keep_unit,
    load_records as load_records,
    log as log,
    partition_args as partition_args,
    write_csv as write_csv,
)
from .ablations import bands, defaults, intervals, mix, noise, planck, shift, tm30


STUDIES: CanonicalMapping[Study] = CanonicalMapping(
    {
        m.STUDY.name: m.STUDY
        for m in (mix, noise, intervals, shift, planck, defaults, tm30, bands)
    },
    what="study",
)
"""Registered studies: name (e.g. "estimate-planck") -> `Study`."""
