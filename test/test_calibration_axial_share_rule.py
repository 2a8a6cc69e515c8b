"""The significance condition of a misalignment's axial share (docs/history/calibration_sessions.md
Sec. 8.38).

``candidates_misalignment.axial_share`` counts the share of the axial bearing forces' order excess that a
candidate explains only where the axial gain itself passes ``bic_threshold + k ln N``: a share of an
excess at the noise level is no evidence of a tilt. The slow records of
``test_calibration_misalignment_axial.py`` show the outcome (tilted gear: share >= 0.9; healthy record:
0); here the rule itself is pinned on given excesses, so that dropping or inverting the condition fails.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration import candidates_misalignment as cm

N_TOTAL = 20000
K = 2
BIC = 10.0
THRESHOLD = BIC + K * math.log(N_TOTAL)  # 29.8


def _share(
    monkeypatch: pytest.MonkeyPatch, before: float, after: float, significant: bool, k: int = K
) -> float:
    """``axial_share`` with the axial excess before / after the candidate given."""
    excess = {"cur": before, "cand": after}
    monkeypatch.setattr(cm, "channels_excess", lambda cmp, feats, mask: excess[feats])
    cal = SimpleNamespace(
        cmp=SimpleNamespace(names=["dte", "bearing2_fx", "bearing2_fz"]),
        fit=SimpleNamespace(bic_threshold=BIC),
        n_total=N_TOTAL,
    )
    return cm.axial_share(cal, "cur", "cand", k, significant=significant)


@pytest.mark.parametrize(
    ("before", "after", "significant", "expected"),
    [
        # a gain above the threshold counts, as a share of the excess before
        (200.0, 200.0 - 1.5 * THRESHOLD, True, 1.5 * THRESHOLD / 200.0),
        # the same share of a small excess (gain below the threshold): not counted
        (40.0, 40.0 - 0.9 * THRESHOLD, True, 0.0),
        # without the condition (session 14's rule where the teeth separate) the share alone
        (40.0, 40.0 - 0.9 * THRESHOLD, False, 0.9 * THRESHOLD / 40.0),
        # no excess to explain: no share, whatever the candidate
        (-3.0, -50.0, False, 0.0),
    ],
)
def test_axial_share_counts_only_a_significant_axial_gain(
    monkeypatch: pytest.MonkeyPatch, before: float, after: float, significant: bool, expected: float
) -> None:
    got = _share(monkeypatch, before, after, significant)
    assert np.isclose(got, expected, rtol=1e-12, atol=0.0), (got, expected)


def test_axial_share_threshold_grows_with_parameter_count_and_record_length(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # a gain just above bic_threshold + k ln N for k = 2 is counted ...
    gain = THRESHOLD * 1.01
    assert _share(monkeypatch, 100.0, 100.0 - gain, True) > 0.0
    # ... but not for a candidate with more parameters (k = 4 raises the bar by 2 ln N)
    assert _share(monkeypatch, 100.0, 100.0 - gain, True, k=K + 2) == 0.0
