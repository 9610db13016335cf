"""Band search: optimistix local fits, nlopt global search, grid baseline, sweeps.

- `Space`, `Problem`, `make_problem`, `scenario_spectra`, `jitted_losses`
  (`_problem`): the search box and the cross-validated ridge loss;
- `global_search`, `NloptObjective` (`_global`): nlopt, the one JAX <-> nlopt adapter;
- `fit_local` (`_local`): optimistix BFGS / Levenberg-Marquardt on `BandSet` leaves;
- `grid_search`, `grid_pairs` (`_grid`): exhaustive 10 nm baseline;
- `make_task`, `run_task`, `get_context`, `evaluate_bands` (`_task`): one search;
- `run_sweep` (`_sweep`): parallel (spawned processes or Dask), resumable sweeps.
"""

from ._global import (
    ALGORITHMS as ALGORITHMS,
    NloptObjective as NloptObjective,
    global_search as global_search,
)
from ._grid import grid_pairs as grid_pairs, grid_search as grid_search
from ._local import (
    bandset_losses as bandset_losses,
    fit_local as fit_local,
    free_bandset as free_bandset,
)
from ._problem import (
    PAN_EDGES_NM as PAN_EDGES_NM,
    Problem as Problem,
    Space as Space,
    jitted_losses as jitted_losses,
    make_problem as make_problem,
    scenario_spectra as scenario_spectra,
)
from ._sweep import load_results as load_results, run_sweep as run_sweep
from ._task import (
    evaluate_bands as evaluate_bands,
    get_context as get_context,
    make_task as make_task,
    run_task as run_task,
    task_id as task_id,
)
