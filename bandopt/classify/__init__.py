"""Lamp-type classification: scale-free features, one-vs-all KNN (scikit-learn)
with k chosen by nested lamp-grouped cross-validation, or the physics-based
inversion's hierarchical posterior (`evaluate_inversion`, the same folds and
scores); F1 per class, confusion matrices, a reject option, and band selection
for classification (nlopt global search of the real F1; a differentiable
soft-nearest-neighbour surrogate with optimistix)."""

from ..forward import (
    CONDITIONS as CONDITIONS,
    LEVELS as LEVELS,
    ScenarioTable as ScenarioTable,
    radiance_from_response as radiance_from_response,
    resolve_level as resolve_level,
    scenario_table as scenario_table,
)
from ..knn import (
    FEATURE_KINDS as FEATURE_KINDS,
    K_GRID as K_GRID,
    choose_k as choose_k,
    features as features,
    macro_f1_int as macro_f1_int,
    make_classifier as make_classifier,
    neighbour_labels as neighbour_labels,
    vote_proba as vote_proba,
)
from ._evaluate import (
    ESTIMATORS as ESTIMATORS,
    evaluate_band_set as evaluate_band_set,
    summary as summary,
)
from ._features import deduplicate as deduplicate
from ._influence import (
    BAND_COUNT_TOLERANCE as BAND_COUNT_TOLERANCE,
    FACTORS as FACTORS,
    BandCountChoice as BandCountChoice,
    EstimationInfluence as EstimationInfluence,
    IdentificationInfluence as IdentificationInfluence,
    Influence as Influence,
    choose_band_count as choose_band_count,
    influence as influence,
    influence_estimates as influence_estimates,
    influence_identification as influence_identification,
)
from ._inversion import (
    evaluate_inversion as evaluate_inversion,
    hierarchical_types as hierarchical_types,
    inversion_conditions as inversion_conditions,
    table_lamps as table_lamps,
    table_moon as table_moon,
)
from ._metrics import (
    REJECT_THRESHOLD as REJECT_THRESHOLD,
    UNKNOWN as UNKNOWN,
    confidence_curve as confidence_curve,
    confusion as confusion,
    f1_from_confusion as f1_from_confusion,
    reject as reject,
    reject_curve as reject_curve,
    scores as scores,
    withhold as withhold,
)
from ._predict import (
    TRAINING_SCENARIOS as TRAINING_SCENARIOS,
    available_atmospheres as available_atmospheres,
    predict_lamp_types as predict_lamp_types,
    training_table as training_table,
)
from ._scores import (
    REJECT_GRID as REJECT_GRID,
    BandSetScores as BandSetScores,
    LevelScores as LevelScores,
    class_order as class_order,
    outer_splits as outer_splits,
)
from ._search import (
    SOFT_TEMPERATURE as SOFT_TEMPERATURE,
    SearchBox as SearchBox,
    SearchData as SearchData,
    cv_macro_f1 as cv_macro_f1,
    nlopt_search as nlopt_search,
    search_data as search_data,
    soft_nn_loss as soft_nn_loss,
    surrogate_search as surrogate_search,
)
