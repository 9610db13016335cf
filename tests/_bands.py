"""The small test band set shared by the inversion and classification tests:
five super-Gaussian bands across the visible and near infrared on the 1 nm
library grid."""

import numpy as np

from bandopt.sensor import BandSet


GRID = np.arange(380.0, 901.0)
"""The library grid, 380-900 nm in 1 nm steps. [nm]"""
FIVE = BandSet.from_physical(
    np.array([450.0, 530.0, 600.0, 680.0, 820.0]),
    np.array([60.0, 60.0, 50.0, 60.0, 80.0]),
    6.0,
    name="t",
)
"""Five bands (centre, FWHM [nm]; super-Gaussian order 6)."""
