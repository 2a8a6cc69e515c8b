"""The rattle-amplitude wear trigger's model-form uncertainty (candidates_wear_rattle.py,
docs/history/calibration_sessions.md Sec. 8.20): the trigger compares amplitudes, so its uncertainty is
the spread of the amplitude over the baseline ensemble, not that of the complex coefficient (which also counts
the phase)."""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.calibration.candidates_wear_rattle import amplitude_spread


def test_a_phase_change_alone_has_no_amplitude_spread() -> None:
    """Members that only rotate the coefficient: the complex spread is |c| sqrt(2 - 2 cos phi), the
    amplitude spread zero."""
    c = 44.5e-6 * np.exp(0.3j)
    phis = np.array([-0.4, -0.1, 0.2, 0.5])
    members = c * np.exp(1j * phis)
    complex_rms = float(np.sqrt(np.mean(np.abs(members - c) ** 2)))
    assert complex_rms == pytest.approx(abs(c) * float(np.sqrt(np.mean(2 - 2 * np.cos(phis)))), rel=1e-12)
    assert amplitude_spread(abs(c), np.abs(members)) <= 1e-12 * abs(c)


def test_amplitude_spread_is_the_rms_deviation_of_the_amplitudes() -> None:
    """Members at +-10 % and +-5 % of the nominal amplitude: rms deviation sqrt((0.01 + 0.0025) / 2)."""
    a = 44.5e-6
    got = amplitude_spread(a, [1.1 * a, 0.9 * a, 1.05 * a, 0.95 * a])
    assert got == pytest.approx(a * np.sqrt((0.01 + 0.0025) / 2), rel=1e-12)
    assert amplitude_spread(a, []) == 0.0
