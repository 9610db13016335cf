"""The report's sections, each built only from files of `results/`.

A section whose experiment has not been run says so in a MISSING box (and the
experiment is listed at the top of the report); nothing is skipped silently.

`bandopt.report.SECTIONS` names each section's builder as an attribute of
this module; the builders live in

- `_experiments`: the experiments, `Ctx` (one build's state),
  `experiments_status`, `missing_summary`;
- `_sections_sensor`: `recommended_sensor` (the thesis' Table 5.1);
- `_sections_search`: `comparison`, `band_count`, `search_figures`;
- `_sections_studies`: `classification`, `radiometry`, `spatial`, `overlap`,
  `inversion`;
- `_sections_provenance`: `provenance`, `consistency`;
- `_sections_verdict`: `verdict` (the first screen: targets, pass/fail).
"""

from ._experiments import (
    BY_KEY as BY_KEY,
    EXPERIMENTS as EXPERIMENTS,
    METRICS as METRICS,
    UNITS as UNITS,
    Ctx as Ctx,
    Experiment as Experiment,
    experiments_status as experiments_status,
    fmt as fmt,
    missing_summary as missing_summary,
)
from ._sections_provenance import (
    consistency as consistency,
    provenance as provenance,
)
from ._sections_search import (
    _converged_cell as _converged_cell,
    band_count as band_count,
    comparison as comparison,
    search_figures as search_figures,
)
from ._sections_sensor import (
    _interval_or_none as _interval_or_none,
    _leakage_and_aoi as _leakage_and_aoi,
    _tolerance_cell as _tolerance_cell,
    recommended_sensor as recommended_sensor,
)
from ._sections_studies import (
    classification as classification,
    inversion as inversion,
    overlap as overlap,
    radiometry as radiometry,
    spatial as spatial,
)
from ._sections_verdict import verdict as verdict
