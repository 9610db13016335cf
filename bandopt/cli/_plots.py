"""Figure helpers shared by the commands: colours that match a band's
wavelength, legends that stay off the data, and saving a finished figure."""

import numpy as np


NAMED_COLOURS = {
    "violet": (0.45, 0.0, 0.75),
    "blue": (0.0, 0.25, 0.9),
    "cyan": (0.0, 0.65, 0.75),
    "green": (0.0, 0.6, 0.0),
    "yellow": (0.85, 0.7, 0.0),
    "amber": (0.95, 0.55, 0.0),
    "orange": (1.0, 0.5, 0.0),
    "red": (0.85, 0.0, 0.0),
    "nir": (0.45, 0.1, 0.1),
    "pan": (0.0, 0.0, 0.0),
    "dnb": (0.0, 0.0, 0.0),
}
"""A band whose name says its colour is drawn in that colour."""


def band_colour(centre_nm: float, fwhm_nm: float, name: str = ""):
    """The display colour of a band: the colour its name says (`NAMED_COLOURS`,
    "red", "nir", "PAN", ...); otherwise the sRGB colour of its centre
    wavelength (CIE 1931 2° colour matching functions, colour-science), black
    for a band wider than 300 nm (panchromatic) and dark red to grey beyond
    700 nm (near infrared has no colour)."""
    import re
    import warnings

    words = re.split(r"[^a-z]+", name.lower())
    for word, rgb in NAMED_COLOURS.items():
        if word in words:
            return rgb
    if fwhm_nm > 300.0:
        return (0.0, 0.0, 0.0)
    if centre_nm > 700.0:
        t = min((centre_nm - 700.0) / 200.0, 1.0)
        return (0.5 * (1 - t) + 0.35 * t, 0.0 * (1 - t) + 0.35 * t, 0.35 * t)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour

        xyz = colour.wavelength_to_XYZ(max(float(centre_nm), 380.0))
        rgb = np.asarray(colour.XYZ_to_sRGB(xyz), float)
    rgb = np.clip(rgb, 0.0, None)
    rgb = rgb / max(float(rgb.max()), 1e-12)
    return tuple(float(v) * 0.9 for v in rgb)  # a touch darker: readable on white


def legend_outside(ax, **kw) -> None:
    """A legend to the right of the axes (never over the data)."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, **kw)


def save_figure(fig, path, dpi: int) -> None:
    """Lay `fig` out (`tight_layout`), write it to `path` at `dpi` and close
    it."""
    import matplotlib.pyplot as plt  # plotting only: start-up time

    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
