"""The lamp prior: measured (and derived) lamps with their LER, G and CCT,
their types and a class-balanced prior weight (`LampPrior`, `lamp_prior`)."""

import dataclasses

import numpy as np

from ..estimate import lamp_truth
from ..folds import class_balanced_weights
from ._variants import variant_base


@dataclasses.dataclass(frozen=True)
class LampPrior:
    """Training lamps of the prior: spectra per lumen (k, w) [W nm⁻¹ lm⁻¹],
    their types, photometric truth (k, 3) in `METRICS` order with validity, and
    log prior weights (class-balanced over level-2 classes)."""

    ids: tuple[str, ...]
    spectra: np.ndarray
    level1: tuple[str, ...]
    level2: tuple[str, ...]
    truth: np.ndarray
    valid: np.ndarray
    log_prior: np.ndarray


def lamp_prior(ids, spectra, level1, level2, wavelength_nm) -> LampPrior:
    """Build the prior from training lamps (level2 may repeat level1 for lamps
    without a level-2 class). Class-balanced over level-2 classes, each lamp
    the same within its class; a lamp's NIR variants (`nir_variants`) split
    its mass, so modelling the NIR's uncertainty does not reweigh classes."""
    spectra = np.asarray(spectra, float)
    truth, valid = lamp_truth(spectra, wavelength_nm)
    l2 = tuple(str(x) for x in level2)
    base = [variant_base(str(i)) for i in ids]
    groups = {}
    for b, c in zip(base, l2, strict=True):
        groups.setdefault(b, [0, c])[0] += 1
    keys = list(groups)
    gw = dict(
        zip(
            keys,
            class_balanced_weights(np.asarray([groups[k][1] for k in keys], object)),
            strict=True,
        )
    )
    w = np.array([gw[b] / groups[b][0] for b in base])
    return LampPrior(tuple(ids), spectra, tuple(level1), l2, truth, valid, np.log(w))
