"""Radiometric sampling: radiance distributions, detection limit, saturation,
SNR/NER and bit depth per band (thesis sections 2.5.2-2.5.3 and 4.2).

- `radiance_groups`, `distribution_rows`: band radiance of lamp scenes,
  moonlit surfaces, direct uplight and fires (Tables 4.5-4.6).
- `night_sky_radiance`, `background_band_radiance`: the natural floor.
- `LimitRule`, `recommend_limits`, `sensitivity_rows`, `snr_ner`,
  `electrons_for_snr`, `radiance_for_snr`, `bits_for_linear`.
- `LinearQuantiser`, `TwoGainQuantiser`, `SqrtQuantiser`, `make_quantiser`.
- `measure`, `score`, `bit_depth_rows`: errors per bit depth (Table 4.7).
- `RadiometryConfig`, `compute`, `load_band_set`, `plot_histograms`: the
  analysis (writes nothing; `bandopt radiometry` and `make radiometry` write
  the results).
- `study_band_set`, `study_out_dir`, `readme_text`, `write_readme`: the study
  of the results folder (`make radiometry`): "ours" read from its
  recommendation.json, the output folder, the README section.
"""

from ._background import (
    BACKGROUND_UNCERTAINTY_FACTOR as BACKGROUND_UNCERTAINTY_FACTOR,
    NIGHT_SKY_MAG_ARCSEC2 as NIGHT_SKY_MAG_ARCSEC2,
    ZERO_POINT_W_M2_NM as ZERO_POINT_W_M2_NM,
    background_band_radiance as background_band_radiance,
    night_sky_radiance as night_sky_radiance,
    surface_brightness_to_radiance as surface_brightness_to_radiance,
)
from ._bitdepth import (
    Measurements as Measurements,
    bit_depth_rows as bit_depth_rows,
    measure as measure,
    score as score,
)
from ._distributions import (
    GROUPS as GROUPS,
    PERCENTILES as PERCENTILES,
    RadianceGroups as RadianceGroups,
    distribution_rows as distribution_rows,
    radiance_groups as radiance_groups,
    radiance_percentiles as radiance_percentiles,
)
from ._instrument import (
    F_NUMBER_LIMIT as F_NUMBER_LIMIT,
    apply_change as apply_change,
    f_number_for as f_number_for,
    gsd_m as gsd_m,
    instrument_changes as instrument_changes,
)
from ._limits import (
    LimitRule as LimitRule,
    Limits as Limits,
    bits_for_linear as bits_for_linear,
    electrons_for_snr as electrons_for_snr,
    radiance_for_snr as radiance_for_snr,
    recommend_limits as recommend_limits,
    sensitivity_rows as sensitivity_rows,
    snr_ner as snr_ner,
)
from ._quantisers import (
    SCHEMES as SCHEMES,
    AbstractQuantiser as AbstractQuantiser,
    LinearQuantiser as LinearQuantiser,
    SqrtQuantiser as SqrtQuantiser,
    TwoGainQuantiser as TwoGainQuantiser,
    make_quantiser as make_quantiser,
)
from ._report import (
    DEFAULT_BAND_SET as DEFAULT_BAND_SET,
    RadiometryConfig as RadiometryConfig,
    compute as compute,
    distribution_set as distribution_set,
    load_band_set as load_band_set,
    plot_histograms as plot_histograms,
)
from ._study import (
    readme_text as readme_text,
    study_band_set as study_band_set,
    study_out_dir as study_out_dir,
    write_readme as write_readme,
)
