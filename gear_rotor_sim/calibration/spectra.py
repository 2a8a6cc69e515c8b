"""The spectra of the analytic signals of a feature set, kept for shifting it by many delays.

A damaged tooth's index (``fit_candidates._fit_tooth``) and a crack mouth's phase (``candidates_crack.py``)
are read by delaying one signature by whole mesh periods: ``Comparison.shifted`` multiplies each analytic
signal's FFT by ``exp(-2 pi i f dt)`` and transforms back, for every tooth or phase of the grid. The FFT of
the undelayed signal is the same for every delay; it is computed once per array here and reused, which
leaves every shifted signal as it was to the bit (docs/history/calibration_sessions.md Sec. 8.70).

The arrays are held by reference with their spectra and recognised by identity: feature arrays are
never changed in place (``ModelFeatures`` builds new arrays), and the spectrum and frequencies are returned
read-only.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence

import numpy as np

#: arrays whose spectra are kept (the signatures of one round's tooth and crack grids: 6 channels x 6)
_MAX = 96
_SPECTRA: OrderedDict[int, tuple[np.ndarray, float, np.ndarray, np.ndarray]] = OrderedDict()


def analytic_spectra(analytic: Sequence[np.ndarray], fs: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(np.fft.fft(a), np.fft.fftfreq(a.size, 1 / fs))`` of each array of ``analytic``, from the store
    where the same array object was transformed before at the same rate.

    Parameters
    ----------
    analytic : sequence of numpy.ndarray
        Analytic band signals of a feature set (complex, 1-D).
    fs : float
        Sample rate, Hz.

    Returns
    -------
    list of (numpy.ndarray, numpy.ndarray)
        The spectrum and the frequencies (Hz) of each array, read-only.
    """
    out = []
    for a in analytic:
        hit = _SPECTRA.get(id(a))
        if hit is not None and hit[0] is a and hit[1] == fs:
            _SPECTRA.move_to_end(id(a))
            out.append((hit[2], hit[3]))
            continue
        spec = np.fft.fft(a)
        f = np.fft.fftfreq(a.size, 1.0 / fs)
        spec.flags.writeable = False
        f.flags.writeable = False
        _SPECTRA[id(a)] = (a, float(fs), spec, f)
        if len(_SPECTRA) > _MAX:
            _SPECTRA.popitem(last=False)
        out.append((spec, f))
    return out
