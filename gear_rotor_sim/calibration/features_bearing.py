"""Sensor gains of the bearing-force channels from their static content, for the envelope features.

The envelope family compares ``g^4 S_model`` with the measured squared-envelope spectrum
(``residual.Comparison.envelope_expected``), so a fitted bearing-defect force scales as ``1 / g``.
The gain ``g`` fitted on the order features sits where the mesh carriers put it: on records of a
structurally different model the carriers' model-form misfit drove every gain to its 0.8 bound
(the sensors' true gains were 0.97-1.03) and every envelope-based force came out ``1 / 0.8 = 1.25``
times too large (docs/history/calibration_sessions.md Sec. 8.7).

The gain of a sensor is one number per channel, and a DC-coupled force sensor under a bearing
measures it directly: the radial static load of a bearing follows from equilibrium alone (the mesh
force ``T / r_b`` along the line of action, shared by the shaft's bearings by the lever rule), so
``measured mean / model mean`` is the sensor gain whatever the model's stiffness, damping or
resonances. On the independent records it reads the generator's gains to 0.1 % (e.g. 0.9959 /
1.0048 for true 0.9949 / 1.0038).

Assumes: the declared output torque is the machine's (the radial mean is proportional to it); the
sensor is DC-coupled without offset (the issue-6 contract's bearing forces); the channel's radial
static load stands well out of its own noise. Where any of these is not given (accelerometers,
axial forces, whose mean is the thermal load of an uncertain expansion model, a rig without a radial
static load) the order features' gain is kept.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from gear_rotor_sim.faults.bearing import BearingDefect

#: directions of a bearing force whose mean is an equilibrium (radial) load
RADIAL_DIRECTIONS = ("x", "y")


def static_sensor_gains(
    measured_mean: np.ndarray,
    measured_var: np.ndarray,
    model_mean: np.ndarray,
    quantities: Sequence[str],
    directions: Sequence[str | None],
    bounds: tuple[float, float],
    min_snr: float = 30.0,
) -> np.ndarray:
    """Per-channel sensor gain ``measured mean / model mean`` of the radial bearing-force channels.

    Parameters
    ----------
    measured_mean, measured_var : numpy.ndarray
        (nc,) channel means of the record and their noise variance (scatter of per-revolution means).
    model_mean : numpy.ndarray
        (nc,) channel means of the healthy (baseline) model at the declared operating point.
    quantities, directions : sequence of str
        Measured quantity and direction of each channel (``ChannelSpec``).
    bounds : tuple of float
        Range a real sensor's gain may take (``ResidualSettings.gain_bounds``); a ratio outside it
        says the model's static load is not the machine's, and the channel keeps its order gain.
    min_snr : float
        The model mean must exceed ``min_snr`` times the measured mean's noise standard deviation
        (a gain known to about 3 %; at the paper gearbox's 3000 rpm contact point the radial means
        of bearing 2 stand 10^3-10^4 standard deviations out).

    Returns
    -------
    numpy.ndarray
        (nc,) gains; NaN where the channel does not identify its gain.
    """
    d = np.asarray(measured_mean, dtype=float)
    v = np.asarray(measured_var, dtype=float)
    m = np.asarray(model_mean, dtype=float)
    out = np.full(d.shape, np.nan)
    for c in range(d.size):
        if quantities[c] != "bearing_force" or directions[c] not in RADIAL_DIRECTIONS:
            continue
        sd = float(np.sqrt(v[c])) if np.isfinite(v[c]) and v[c] >= 0 else float("inf")
        if not (np.isfinite(m[c]) and abs(m[c]) > min_snr * sd and abs(d[c]) > min_snr * sd):
            continue
        g = d[c] / m[c]
        if bounds[0] <= g <= bounds[1]:
            out[c] = g
    return out


def impulse_note(effect: BearingDefect, shaft_rad_s: float) -> str:
    """The quantity a bearing-defect fit identifies, for the report's notes: the impulse of one
    impact and what the fitted peak force means (``BearingDefect.impulse``)."""
    tau = effect.impact_duration(shaft_rad_s)
    how = (
        f"the fixed pulse of {tau * 1e3:.3g} ms"
        if effect.pulse_s is not None
        else f"{tau * 1e3:.3g} ms, the transit of the nominal {effect.spall_width_m * 1e3:.3g} mm spall"
    )
    return (
        f"{effect.label}: impulse per full-load impact {effect.impulse(shaft_rad_s):.3g} N s "
        f"(2 F tau / pi, tau = {how}): the envelope identifies the impulse; force_n = "
        f"{effect.force_n:.4g} N is its peak force over that duration (a spall of width w: "
        f"force_n x {effect.spall_width_m * 1e3:.3g} mm / w)"
    )


def modulation_sidebands_hz(effect: BearingDefect, shaft_hz: float, orders: int = 3) -> list[float]:
    """Offsets (Hz) of a defect's modulation sidebands around each of its envelope lines.

    An inner-race defect turns with the shaft through the load zone (sidebands at ``+-j f_shaft``), a
    ball with the cage (``+-j f_cage``, FTF); an outer-race defect is fixed (none). These bins hold the
    defect's own content, never the noise floor its line is judged against: with them in the floor the
    BPFI line of the independent 3000 rpm inner-race record was refused at 2.90 and 3.46 x the floor
    (threshold 4); on the same spectrum, measured by hand, the line stands 4.1-4.5 x above the
    bins between the sidebands (docs/history/calibration_sessions.md Sec. 8.13).
    """
    if effect.kind == "outer":
        return []
    rate = shaft_hz if effect.kind == "inner" else effect.geometry.multiples()["ftf"] * shaft_hz
    return [s * j * rate for j in range(1, orders + 1) for s in (-1.0, 1.0)]


#: Fine rate of the direct impact path as a multiple of the output rate (160 kHz at 20 kHz: six fine
#: samples across the 38 us impact at 8000 rpm) and midpoints averaged within each fine interval.
DIRECT_PATH_RATE_FACTOR = 8
DIRECT_PATH_MIDPOINTS = 4


def anti_aliased_impacts(
    force_at: Callable[[np.ndarray], np.ndarray],
    first_index: int,
    n: int,
    sample_rate_hz: float,
    factor: int = DIRECT_PATH_RATE_FACTOR,
    midpoints: int = DIRECT_PATH_MIDPOINTS,
) -> np.ndarray:
    """Samples ``first_index .. first_index + n - 1`` of an impact force through the simulator's own
    anti-aliasing decimation, (n, k) for a force ``force_at(t) -> (len(t), k)``.

    The force is averaged over each interval of a grid ``factor`` times finer than the output
    (``midpoints`` points per interval, so an impact shorter than a fine step keeps its impulse) and
    decimated through the linear-phase Kaiser FIR of the simulator's output stream
    (``solver.decimate.design_taps``: flat to 0.4 fs, stop from 0.5 fs), centred on each output
    sample. The rest of the model's stream (the shaft's answer to the impact, every other channel)
    passes that filter; a measurement chain low-passes before sampling the same way
    (docs/history/calibration_sessions.md Sec. 8.30). The plain average over the output interval that this
    replaces is a ``sinc`` low-pass, 0.96 of the passband at 3 kHz and 0.82 at 6.7 kHz for 20 kHz sampling.
    """
    from gear_rotor_sim.solver.decimate import design_taps, filter_delay, fir_decimate

    k = int(factor)
    delay = filter_delay(k)
    j = np.arange(int(first_index) * k - delay, (int(first_index) + n - 1) * k + delay + 1)
    sub = (np.arange(midpoints) + 0.5) / midpoints - 0.5
    t = ((j[:, None] + sub[None, :]) / (k * sample_rate_hz)).ravel()
    f = np.asarray(force_at(t), dtype=float)
    fine = f.reshape(j.size, midpoints, -1).mean(axis=1)
    return fir_decimate(fine, design_taps(k), 2 * delay, k, n)
