"""Sphinx configuration: user guide, tutorial and the API reference generated
from the docstrings (autodoc + napoleon). Builds offline: no intersphinx, no
remote theme or fonts (the built-in alabaster theme)."""

import os
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("JAX_PLATFORMS", "cpu")
os.environ.setdefault("MPLBACKEND", "Agg")

project = "bandopt"
author = "bandopt developers"
copyright = "bandopt developers"
release = "0.1.0"

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
]
autodoc_default_options = {
    "members": True,
    "undoc-members": False,
    "show-inheritance": False,
    "member-order": "bysource",
}
autodoc_typehints = "description"
autodoc_mock_imports = ["mitsuba", "Py6S"]
napoleon_google_docstring = True
napoleon_numpy_docstring = False
html_theme = "alabaster"
html_theme_options = {"description": "Band selection for night-time sensors"}
exclude_patterns = ["_build"]
suppress_warnings = ["autodoc.import_object"]
# the docstrings use single backticks for names (`wavelength_nm`): show them as code
default_role = "code"
# docstrings write |Duv|, |y|, |error| (absolute values), which reST reads as
# substitutions
rst_prolog = "".join(
    f".. |{name}| replace:: abs({name})\n" for name in ("Duv", "y", "error")
)
