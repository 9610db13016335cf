"""Band search: optimistix local fits, nlopt global search, grid baseline, sweeps.

- `Space`, `Problem`, `make_problem`, `scenario_spectra`, `jitted_losses`
  (`_problem`): the search box and the cross-validated ridge loss;
- `global_search`, `NloptObjective` (`_global`): nlopt, the one JAX <-> nlopt adapter;
- `fit_local` (`_local`): optimistix BFGS / Levenberg-Marquardt on `BandSet` leaves;
- `grid_search`, `grid_pairs` (`_grid`): exhaustive 10 nm baseline;
- `get_context`, `PRESETS` (`_context`): a preset's scenario context, with
  the measurement effects of its lamp spectra (`_perturbed`);
- `make_task`, `run_task`, `evaluate_bands` (`_task`): one search;
- `run_sweep` (`_sweep`): parallel (spawned processes or Dask), resumable sweeps;
- `lamp_resamples`, `make_batch_data`, `batched_search` (`_stability`): all lamp
  resamples of one band count: nlopt explores each, optimistix BFGS fits from
  its best distinct points (all resamples and starts in one jitted, vmapped
  function, each fit's result recorded), with the joint
  estimation/classification loss and the band-overlap penalty (`_batch_loss`:
  the resamples, their shared arrays and the loss);
- `make_study_task`, `run_study_task`, `SCORERS` (`_study`): stability-study
  tasks and the pluggable outer-fold estimator (a `FittedScorer`, whose
  `hyper` a refit can keep); `_analysis`: the stated rules
  (band count, Pareto knee, medoid design);
- `run_noise_aware`, `noise_aware_tasks` (`_noise_aware`): the optimum bands
  per signal level, photon noise of the Table 2.3 sensor (`make noise-aware`);
- `tolerance_analysis`, `perturbed_bands`, `specification_interval`
  (`_tolerance`): specification intervals of a band set, with the estimator
  fitted to the nominal bands and its coefficients refitted on the perturbed
  (as-built) ones, hyper-parameters fixed (`CALIBRATION_FIXED`);
- `SearchOptions`, `STUDY`, `DEFAULT_OUT` (`_options`): what a run of
  `python -m experiments.search` does and where it writes;
- `run_study` (`_stability_study`): the stability study (`make run`), its
  tasks and cached sweeps in `_study_sweep`, its README section in
  `_study_readme`, its figures in `_figures`;
- `single_split_sweep`, `single_split_compare`, `single_split_budget`
  (`_single_split`): the single-split study (one partition, nlopt per fold);
- `compare_solvers` (`_solvers`): the stability search against a plain Adam
  loop on the same resamples.
"""

from ._analysis import (
    COUNT_RULE as COUNT_RULE,
    DESIGN_RULE as DESIGN_RULE,
    NORMALISATION_NOTE as NORMALISATION_NOTE,
    PARETO_RULE as PARETO_RULE,
    band_count_choice as band_count_choice,
    design_intervals as design_intervals,
    knee as knee,
    lamp_mean_errors as lamp_mean_errors,
    pareto_mask as pareto_mask,
    partition_summary as partition_summary,
    truth_sd as truth_sd,
)
from ._compare import (
    Comparison as Comparison,
    compare_with_references as compare_with_references,
    pool_folds as pool_folds,
)
from ._context import (
    PRESETS as PRESETS,
    get_context as get_context,
)
from ._figures import (
    plot_error_vs_bands as plot_error_vs_bands,
    plot_pareto as plot_pareto,
    plot_stability as plot_stability,
    plot_v_band as plot_v_band,
)
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
from ._noise_aware import (
    noise_aware_tasks as noise_aware_tasks,
    run_noise_aware as run_noise_aware,
)
from ._options import (
    DEFAULT_OUT as DEFAULT_OUT,
    STUDY as STUDY,
    SearchOptions as SearchOptions,
)
from ._problem import (
    PAN_EDGES_NM as PAN_EDGES_NM,
    Problem as Problem,
    Space as Space,
    jitted_losses as jitted_losses,
    make_problem as make_problem,
    scenario_spectra as scenario_spectra,
)
from ._report import (
    mae_ci as mae_ci,
    paired_reduction as paired_reduction,
    plot_bands_over_lamps as plot_bands_over_lamps,
)
from ._single_split import (
    EVALS_PER_DIM as EVALS_PER_DIM,
    FOLDS as FOLDS,
    GOAL as GOAL,
    TARGETS as TARGETS,
    single_split_budget as single_split_budget,
    single_split_compare as single_split_compare,
    single_split_reference_tasks as single_split_reference_tasks,
    single_split_sweep as single_split_sweep,
    single_split_tasks as single_split_tasks,
    table_text as table_text,
    v_band_experiment as v_band_experiment,
)
from ._solvers import (
    ADAM as ADAM,
    adam_search as adam_search,
    compare_band_count as compare_band_count,
    compare_solvers as compare_solvers,
)
from ._stability import (
    batched_loss as batched_loss,
    batched_search as batched_search,
    design_loss as design_loss,
    lamp_resamples as lamp_resamples,
    local_fits as local_fits,
    make_batch_data as make_batch_data,
    single_loss as single_loss,
    sorted_design as sorted_design,
)
from ._stability_study import run_study as run_study
from ._study import (
    DEFAULT_SCORER as DEFAULT_SCORER,
    SCORER_NOTES as SCORER_NOTES,
    SCORERS as SCORERS,
    STUDY_TASK as STUDY_TASK,
    FittedScorer as FittedScorer,
    get_scorer as get_scorer,
    make_study_task as make_study_task,
    run_study_task as run_study_task,
    score_design as score_design,
    study_batch_data as study_batch_data,
    study_resamples as study_resamples,
    study_space as study_space,
    task_resamples as task_resamples,
)
from ._study_readme import study_readme_text as study_readme_text
from ._study_sweep import (
    RUNNER as RUNNER,
    StudyProgress as StudyProgress,
    study_sweep as study_sweep,
    study_tasks as study_tasks,
    task_cost as task_cost,
)
from ._sweep import (
    TaskResults as TaskResults,
    load_results as load_results,
    print_progress as print_progress,
    read_task_file as read_task_file,
    run_sweep as run_sweep,
    task_path as task_path,
)
from ._task import (
    TaskResult as TaskResult,
    evaluate_bands as evaluate_bands,
    make_task as make_task,
    run_task as run_task,
    task_id as task_id,
)
from ._tolerance import (
    AOI_N_EFF as AOI_N_EFF,
    CALIBRATION_FIXED as CALIBRATION_FIXED,
    LEAKAGE_NOTE as LEAKAGE_NOTE,
    MAX_ERROR_RATIO as MAX_ERROR_RATIO,
    ToleranceAnalysis as ToleranceAnalysis,
    perturbed_bands as perturbed_bands,
    specification_interval as specification_interval,
    tolerance_analysis as tolerance_analysis,
)
