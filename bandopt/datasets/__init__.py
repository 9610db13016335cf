"""Real measured data with units and citations: lamps, surfaces, atmospheres, Moon.

Every dataset cites a key in `references.bib` beside this file.
"""
