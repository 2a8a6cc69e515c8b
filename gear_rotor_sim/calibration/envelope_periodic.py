"""Is the healthy model's response periodic at the bearing channels? The test that chooses the
envelope family's input (issue 11; docs/history/calibration_sessions.md Sec. 8.76).

The envelope family analyses the non-synchronous part of the bearing channels (every shaft's
synchronous average removed, ``features_orders.remove_synchronous``) where the healthy model is
periodic, and the whole signal on every channel where it is not (``Comparison._choose_envelope_input``):
content that is not periodic with a shaft (teeth separating, a quasi-periodic response) changes with
every gear or thermal parameter in a way superposed basis runs cannot follow.

The synchronous average keeps orders up to ``SYNCHRONOUS_TOP_FRACTION`` (0.45) of the sample rate
only. A mesh harmonic between 0.45 fs and the Nyquist frequency is periodic, but it stays in the
"non-synchronous" part, and measured on its whole RMS it read as non-periodic dynamics: on the FE paper
gearbox at 4819 rpm / 40 C (the 4th mesh harmonic at 9317 Hz, fs 20 kHz) the healthy model's
non-synchronous part is 1.4 % of the RMS at ``bearing2_fx``, 0.084 % below 0.45 fs; at 3231 rpm / 104 C
(the 6th harmonic at 9370 Hz) 1.3 % at ``bearing2_fy``, 0.14 % below. Each switched the envelope to
the whole signal on every channel, where it compared the mesh carriers' modulation (at 3231 rpm a
line at 2 f_gear - f_pinion = 9.9 Hz, 191 in the model for 0.06 measured at ``bearing2_fx``) and the
step grid's beat against the mesh at the shaft accelerometers (``node5_ax``: lines at k f_mesh +- 714 Hz
at 64 steps per mesh, 68.69 integration steps per mesh period with dt = 1 / (8 fs)) with the noise's
uncertainty: healthy lumped records scored 76-872 there, and by a factor 6-8 apart between noise seeds
(the band each channel took). So the share is taken of the part the synchronous average can separate:
the non-synchronous part below ``SYNCHRONOUS_TOP_FRACTION fs``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from gear_rotor_sim.calibration.features_orders import SYNCHRONOUS_TOP_FRACTION


def separable_part(x: np.ndarray, fs: float) -> np.ndarray:
    """``x`` without its content above ``SYNCHRONOUS_TOP_FRACTION fs`` (zero-phase, by FFT): the band
    in which the synchronous average tells periodic from non-periodic content.

    Parameters
    ----------
    x : numpy.ndarray
        One channel's samples (n,), at ``fs`` samples per second.
    fs : float
        Its sampling rate, Hz (the top frequency is ``SYNCHRONOUS_TOP_FRACTION fs``).
    """
    x = np.asarray(x, dtype=float)
    spec = np.fft.rfft(x)
    spec[np.fft.rfftfreq(x.size, 1.0 / fs) > SYNCHRONOUS_TOP_FRACTION * fs] = 0.0
    return np.fft.irfft(spec, x.size)


def non_synchronous_share(
    model: np.ndarray,
    measured: np.ndarray,
    fs: float,
    non_synchronous: Callable[[np.ndarray], np.ndarray],
) -> float | None:
    """RMS of the model's non-synchronous part below ``SYNCHRONOUS_TOP_FRACTION fs`` over the larger of
    the model's and the measured channel's fluctuation RMS (None where both are zero).

    The larger of the two: a channel whose model fluctuation is round-off (an axial bearing force of a
    spur gearbox above the reference temperature) has no dynamics to be periodic or not, and its
    round-off is invisible under the measured noise (``Comparison._choose_envelope_input``).

    Parameters
    ----------
    model, measured : numpy.ndarray
        The healthy model's and the record's channel (n,).
    fs : float
        Sample rate, Hz.
    non_synchronous : callable
        The envelope input's non-synchronous part of a signal (``Comparison._envelope_input``).
    """
    x = np.asarray(model, dtype=float)
    x = x - x.mean()
    sd = max(float(np.std(x)), float(np.std(measured)))
    if not sd > 0:
        return None
    return float(np.std(separable_part(non_synchronous(x), fs))) / sd
