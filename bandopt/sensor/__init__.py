"""The sensor: band sets, slit functions, band radiance, photon noise, quantisation.

Thesis section 2.5 (`DeMeester2019`): band-integrated and band-averaged
radiance (Eqs. 2.13-2.14), the super-Gaussian slit function (Eq. 2.15), the
photon noise model (Eqs. 2.16-2.19, Table 2.3) and quantisation (Eqs.
2.20-2.21, corrected). Reference sensors live in `bandopt.sensor.reference`.
"""

from ._bands import (
    DATA_RANGE_NM as DATA_RANGE_NM,
    MIN_FWHM_NM as MIN_FWHM_NM,
    SHAPE_K_RANGE as SHAPE_K_RANGE,
    Bands as Bands,
    BandSet as BandSet,
    TabulatedBands as TabulatedBands,
    export_response_csv as export_response_csv,
)
from ._photon import (
    PLANCK_J_S as PLANCK_J_S,
    SPEED_OF_LIGHT_M_S as SPEED_OF_LIGHT_M_S,
    SensorParams as SensorParams,
    add_photon_noise as add_photon_noise,
    ground_track_speed_m_s as ground_track_speed_m_s,
    noise_electrons as noise_electrons,
    noise_equivalent_radiance as noise_equivalent_radiance,
    photon_weights as photon_weights,
    radiance_from_electrons as radiance_from_electrons,
    responsivity as responsivity,
    signal_electrons as signal_electrons,
    snr as snr,
)
from ._quantise import (
    dequantise as dequantise,
    quantise as quantise,
    quantise_ste as quantise_ste,
    radiance_step as radiance_step,
)
from ._slit import (
    band_average as band_average,
    band_integrate as band_integrate,
    crop_to_support as crop_to_support,
    slit_super_gaussian as slit_super_gaussian,
    super_gaussian_area_nm as super_gaussian_area_nm,
    super_gaussian_fraction_outside as super_gaussian_fraction_outside,
)
from .reference import (
    REFERENCE_SENSORS as REFERENCE_SENSORS,
    BandSetSource as BandSetSource,
    ReferenceSensor as ReferenceSensor,
    load_band_set as load_band_set,
    reference_sensor as reference_sensor,
    resolve_band_set as resolve_band_set,
)
