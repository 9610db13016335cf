"""Mitsuba 3 handles scenes with buildings: shadows where geometry says (slow)."""

import numpy as np
import pytest

from bandopt.spatial import montecarlo as mc


pytestmark = pytest.mark.slow

KW = dict(intensity_cd=1000.0, height_m=8.0, reflectance=0.2, extent_m=40.0, pixels=40)


def _x(col):
    return col + 0.5 - 20.0  # pixel centre [m]; column 0 is -x


def test_building_casts_the_predicted_shadow():
    if not mc.available():
        pytest.skip("mitsuba (scalar_rgb) is not installed: pip install '.[render]'")
    # A 4 m high, 2 m deep wall 5-7 m east of an 8 m lamp: the ground from
    # x = 7 m to x = 7 h / (h - 4 m) = 14 m lies in its shadow near y = 0.
    img = mc.render_point_light(spp=64, buildings=[(5.0, -5.0, 7.0, 5.0, 4.0)], **KW)
    ana = mc.analytic_point_light(**KW)
    row = 20  # y = -0.5 m
    ratio = img[row] / ana[row]
    xs = np.array([_x(c) for c in range(40)])
    shadow = (xs > 7.5) & (xs < 13.5)
    lit = (xs < -1.0) | (xs > 14.5)
    assert np.all(ratio[shadow] < 0.01)
    # Elsewhere the Monte Carlo image matches the flat closed form within its noise.
    assert np.all(np.abs(ratio[lit] - 1) < 0.05)
    # The roof, 4 m closer to the lamp, is brighter than the ground below it would be.
    roof = (xs > 5.0) & (xs < 7.0)
    assert np.all(ratio[roof] > 1.1)


def test_bad_building_rejected():
    if not mc.available():
        pytest.skip("mitsuba is not installed")
    with pytest.raises(ValueError, match=r"buildings\[0\]"):
        mc.render_point_light(spp=1, buildings=[(5.0, 0.0, 4.0, 1.0, 3.0)], **KW)
