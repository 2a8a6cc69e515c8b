"""Detection threshold of a bearing-defect line (``Calibrator._line_prominence``) on constructed spectra.

Independent truth: a measured envelope spectrum built by hand with a unit noise floor, a defect line
6x above it and modulation sidebands at 3x in most of the neighbouring bins. The line's prominence
over the noise floor is 6; the sidebands are the candidate's own prediction and must not be taken
as the floor (issue 11: the BPFI line of an independent inner-race record read 1.5-2.9x against a
held baseline, 6.5x without it, only because the predicted sidebands' level decided which bins were
the floor).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.residual import Comparison

LINE_HZ = 271.6


def _spectra(sideband_share: float) -> tuple[SimpleNamespace, np.ndarray]:
    f = np.arange(5.0, 600.0, 2.0)
    near = (np.abs(f - LINE_HZ) <= 0.25 * LINE_HZ) & (np.abs(f - LINE_HZ) > 0.03 * LINE_HZ)
    idx = np.flatnonzero(near)
    side = idx[: round(sideband_share * idx.size)]
    measured = np.ones_like(f)
    measured[side] = 3.0
    own = np.abs(f - LINE_HZ) <= max(1.5 * 2.0, 0.0075 * LINE_HZ)
    measured[own] = 6.0
    # the candidate predicts its sidebands strongly and a weaker skirt in every other near bin
    predicted = np.zeros_like(f)
    predicted[near] = 0.6
    predicted[side] = 3.0
    predicted[own] = 6.0
    cmp = SimpleNamespace(env_f=f, d_env=[measured], env_floor=[1.0])
    cmp.line_mask = lambda freqs, rel_width=0.0075: Comparison.line_mask(cmp, freqs, rel_width)
    return SimpleNamespace(cmp=cmp), predicted


@pytest.mark.parametrize("share", [0.3, 0.6])
def test_predicted_sidebands_are_not_the_floor(share: float) -> None:
    cal, predicted = _spectra(share)
    prominence = Calibrator._line_prominence(cal, [LINE_HZ], [predicted])
    assert prominence == pytest.approx(6.0, rel=1e-12)


def test_a_line_at_the_floor_is_not_prominent() -> None:
    cal, predicted = _spectra(0.6)
    cal.cmp.d_env[0][np.abs(cal.cmp.env_f - LINE_HZ) <= 3.0] = 1.0
    assert Calibrator._line_prominence(cal, [LINE_HZ], [predicted]) == pytest.approx(1.0, rel=1e-12)
