"""Robustness of the shipped estimate to what real spectra hold.

The library's lamps are measured with care; a user's lamp, or a field
campaign's, comes with background light, spectrometer noise, a coarser slit,
a wavelength-calibration error, a spectrum cut short and extended, another
lamp in the same pixel, or a lamp type the prior lacks. This study asks how
much each costs the estimator `bandopt evaluate` ships
(`evaluator.InversionConfig` defaults, surface unknown, the Moon told):

1. per lamp partition (a `search.Context` built with fold seed `p`, its outer
   fold `RobustnessStudy.fold` held out, lamp-grouped), the inversion is
   fitted once per band set on the training lamps;
2. each held-out measured lamp's spectrum is perturbed (`bandopt.perturb`),
   lit under the context's own scenes (`scene.ScenarioSet.with_lamps`) and
   measured with the band set under the context's noise rule
   (`Context.radiance_of`); the clean spectrum goes the same way, so every
   perturbed row is paired with the clean one on the same lamps and scenes;
3. "left out of the prior" perturbs the prior instead: each held-out lamp is
   scored by the same fit with every prior entry of its own level-2 class
   removed (`without_class`, also from the `unexplained` test's inner folds;
   the band-error model and intervals stay those of the full fit, so this is
   the cheap stand-in for a refit without the class,
   `inversion.leave_one_class_out`).

Truth: a pixel's LER, G and CCT are those of the spectrum its radiance comes
from (the perturbed one: background, noise and a second lamp are part of what
the pixel holds); its types are the lamp's own (the majority lamp in a
mixture). Records also keep the clean spectrum's truth.

Modules: `_study` (the perturbations, as-built sensors, partitions,
`run_partition` scoring one (partition, band set) unit), `_run` (the
resumable `run_study`: units kept unless their band set changed),
`_tolerance` (the study configured as a filter tolerance scan) and `_summary`
(`summarise`: records into rows, class-balanced means per partition, mean
± SD over partitions, ECE of the level-1 probabilities, paired differences
against clean).
"""

from ._outputs import readme_text as readme_text, write_outputs as write_outputs
from ._run import (
    band_digest as band_digest,
    digests_path as digests_path,
    load_records as load_records,
    run_study as run_study,
)
from ._study import (
    BAND_SETS as BAND_SETS,
    CONFIDENCE_DECIMALS as CONFIDENCE_DECIMALS,
    KINDS as KINDS,
    QUICK_PERTURBATIONS as QUICK_PERTURBATIONS,
    RECOMMENDED_BANDS as RECOMMENDED_BANDS,
    SENSOR_KINDS as SENSOR_KINDS,
    STUDY_PERTURBATIONS as STUDY_PERTURBATIONS,
    Extension as Extension,
    Partition as Partition,
    Perturbation as Perturbation,
    PerturbedLamps as PerturbedLamps,
    RobustnessStudy as RobustnessStudy,
    as_built as as_built,
    lamp_records as lamp_records,
    mixture_partners as mixture_partners,
    partition as partition,
    perturbed_lamps as perturbed_lamps,
    product_extension as product_extension,
    run_partition as run_partition,
    scene_spectra as scene_spectra,
    without_class as without_class,
)
from ._summary import (
    COLUMNS as COLUMNS,
    INTERVAL_NOTE as INTERVAL_NOTE,
    PAIRED as PAIRED,
    WIDTH_COLUMNS as WIDTH_COLUMNS,
    lamp_differences as lamp_differences,
    partition_answered as partition_answered,
    partition_ece as partition_ece,
    partition_width as partition_width,
    reliability as reliability,
    summarise as summarise,
)
from ._tolerance import (
    tolerance_intervals as tolerance_intervals,
    tolerance_perturbations as tolerance_perturbations,
    tolerance_study as tolerance_study,
    write_tolerances as write_tolerances,
)
