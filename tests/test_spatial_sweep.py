"""gsd_sweep and coarsest_gsd (library logic of experiments/spatial.py)."""

import numpy as np
import pytest

from bandopt.sensor import BandSet
from bandopt.spatial import (
    LampPlacement,
    Layout,
    coarsest_gsd,
    gsd_sweep,
    observe,
    phases,
    render,
)


def test_coarsest_gsd_rule():
    f1 = {20.0: 0.81, 1.0: 0.5, 5.0: 0.85, 2.0: 0.9, 10.0: 0.79}
    ans = coarsest_gsd(f1, 0.8)
    # fine GSDs can fail and F1 need not fall monotonically: all are listed
    assert ans.coarsest_gsd_m == 20.0 and ans.working_gsds_m == (2.0, 5.0, 20.0)
    assert list(ans.f1_by_gsd) == [1.0, 2.0, 5.0, 10.0, 20.0]
    assert ans.as_dict()["f1_by_gsd"]["10"] == 0.79
    none = coarsest_gsd({1.0: 0.1, 2.0: 0.2})
    assert none.coarsest_gsd_m is None and none.working_gsds_m == ()
    with pytest.raises(ValueError, match="f1_needed"):
        coarsest_gsd(f1, 1.5)


def test_gsd_sweep_is_observe_over_phases():
    """One bright lamp: found at 2 m and 10 m in every phase; the sweep's
    scores are those of `observe` with the stated seed rule."""
    bands = BandSet.from_edges([(500.0, 900.0)], names=["pan"])
    lay = Layout(
        "one",
        (LampPlacement(100.1, 0.3, 8.0, "lop-50", "cie_led_b3", 8000.0),),
        length_m=200.0,
        width_m=100.0,
    )
    scene = render(lay, bands, dx_m=1.0)
    sweep = gsd_sweep(scene, bands, (2.0, 10.0), n_phases=2, seed=4,
                      keep_observations=True)  # fmt: skip
    assert [s.gsd_m for s in sweep.scores] == [2.0, 10.0]
    for s in sweep.scores:
        assert s.n_phases == 2 and s.n_targets == 1
        assert s.mean_f1 == 1.0 and s.min_f1 == 1.0
        assert len(s.phase_rows()) == 2 and s.mean_row()["f1"] == 1.0
    assert coarsest_gsd(sweep).coarsest_gsd_m == 10.0
    ph = phases(scene, 10.0, 2, 4)
    direct = observe(scene, bands, 10.0, seed=4 + 1000 * 1 + 10, phase_px=ph[1])
    s10 = sweep.scores[1]
    assert s10.phase_px[1] == ph[1] and s10.f1[1] == direct.score.f1
    assert s10.n_detected[1] == direct.detections.xy_m.shape[0]
    first = observe(scene, bands, 10.0, seed=14)  # phase 0: no shift
    np.testing.assert_array_equal(sweep.first_phase[10.0].image, first.image)
    with pytest.raises(ValueError, match="positive"):
        gsd_sweep(scene, bands, (0.0,))
