"""bandopt: band-selection optimisation for night-time multispectral satellite sensors.

The physics is pure JAX functions on arrays (float32 and float64); optimisation,
tests and the command line run in float64 (`bandopt.configure()`).
"""

from ._config import configure


__all__ = ["__version__", "configure"]
__version__ = "0.1.0"
