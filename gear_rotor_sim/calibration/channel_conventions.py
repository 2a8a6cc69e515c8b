"""Sensor conventions a sidecar can get wrong: a channel's sign, and a force sensor's sensitivity or axes;
and a channel's own slow gain (``gain_modulation.py``, divided out first: :func:`correct_gain_modulation`), a
drifting mean (``channel_drift.py``, :func:`correct_drift`), cross-talk into an axial force
(``channel_leak.py``, :func:`correct_leak`) and an axial force's zero (``axial_zero.py``).

Neither is a physical change of the machine, and neither is a nuisance the gain fit can absorb (the
sensor gain is bounded to [0.8, 1.25], ``ResidualSettings.gain_bounds``). Read against the healthy
(baseline-updated) model at the declared operating point, right after its first run
(``Calibrator.run``; docs/calibration.md Sec. 1, "Sensor conventions"):

- **Sign.** The weighted correlation of a measured channel's order features ``d`` (the complex
  coefficients of its synchronous averages, ``Comparison.d_order``) with the model's ``m``,

      rho = sum w Re(conj(m) d) / sqrt(sum w |m|^2 sum w |d|^2),   w = 1 / var(d),

  over every order of every shaft after the model's common time shift, is independent of the gain: 1
  for a channel equal to the model's up to a gain, -1 for the same with its sign reversed. On the
  independent records of the issue-11 table (docs/independent_data.md) every channel read between
  +0.28 and +0.99, a channel with its sign reversed -0.54 to -0.93. A channel with ``rho <=
  -FLIP_RHO``, while at least half of the other channels read ``rho >= FLIP_RHO`` (so the model and
  its time shift are right), is read with its sign reversed: negation is exact, so the diagnosis is
  the one of the correctly declared record, and an ``issues`` entry names the column.
- **A radial bearing force's mean.** It is the bearing's share of the mesh force (equilibrium:
  ``T / r_b`` shared by the lever rule), whatever the model's stiffness and damping, so ``measured
  mean / model mean`` is the sensor gain (``features_bearing.static_sensor_gains``). A ratio outside
  the gain range is reported naming the column: the two directions of one bearing exchanged when
  their crossed ratios are in the range, else the channel's sensitivity (or the declared output
  torque, when every radial channel reads the same ratio). Nothing is corrected here: read against the
  model at the measured torque where ``load_check.check_load`` (run first) found every radial channel
  off by one factor (the output torque, docs/calibration.md Sec. 2 "Load check"), so one channel off the
  others stays a sensor.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.axial_zero import find_axial_zero
from gear_rotor_sim.calibration.channel_drift import channel_drift
from gear_rotor_sim.calibration.channel_leak import leak_fix
from gear_rotor_sim.calibration.channel_skew import correct_skew
from gear_rotor_sim.calibration.force_coupling import leave_out_unmeasured_means
from gear_rotor_sim.calibration.gain_modulation import gain_modulation_fix
from gear_rotor_sim.calibration.load_check import check_load, radial_channels

#: quantities whose mean is an offset, not a signal (no carrier of a gain modulation)
DYNAMIC_ONLY = ("acceleration", "housing_acceleration", "velocity")
#: ``rho <= -FLIP_RHO`` reads as a reversed sign; the other channels must read ``rho >= FLIP_RHO``
FLIP_RHO = 0.3
#: summed squared signal-to-noise ratio of the order features that makes a channel's reading (as the
#: gain fit's threshold, ``Comparison.fit_gains``)
MIN_SNR2 = 100.0


def order_correlation(
    d_order: Sequence[Sequence[np.ndarray]],
    v_order: Sequence[Sequence[np.ndarray]],
    m_order: Sequence[Sequence[np.ndarray]],
) -> np.ndarray:
    """Weighted correlation ``rho`` of each measured channel with the model's same channel.

    Parameters
    ----------
    d_order, v_order : sequence of sequence of numpy.ndarray
        Measured order coefficients ``[channel][shaft]`` (complex) and their noise variances.
    m_order : sequence of sequence of numpy.ndarray
        Model order coefficients ``[channel][shaft]``, time-shifted as scored.

    Returns
    -------
    numpy.ndarray
        ``(nc,)`` correlations in [-1, 1] (module docstring); NaN where the model's or the measured
        features do not stand out of the noise (summed squared SNR below :data:`MIN_SNR2`).
    """
    rho = np.full(len(d_order), np.nan)
    for c, (ds, vs, ms) in enumerate(zip(d_order, v_order, m_order, strict=True)):
        dd = mm = md = 0.0
        n = 0
        for d, v, m in zip(ds, vs, ms, strict=True):
            w = 1.0 / np.where(np.asarray(v) > 0, v, np.inf)
            dd += float(np.sum(w * np.abs(d) ** 2))
            mm += float(np.sum(w * np.abs(m) ** 2))
            md += float(np.sum(w * np.real(np.conj(m) * d)))
            n += int(np.count_nonzero(w > 0))
        # both sides must stand out of the noise (a channel of pure noise reads sum w |d|^2 ~ n)
        if mm >= MIN_SNR2 and dd - n >= MIN_SNR2 and np.isfinite(mm * dd):
            rho[c] = md / np.sqrt(mm * dd)
    return rho


def reversed_channels(rho: np.ndarray) -> list[int]:
    """Channels whose sign is reversed: ``rho <= -FLIP_RHO`` while at least half of the other
    channels with a reading have ``rho >= FLIP_RHO``."""
    r = np.asarray(rho, dtype=float)
    out = []
    for k in np.flatnonzero(r <= -FLIP_RHO):
        others = np.delete(r, k)
        others = others[np.isfinite(others)]
        if others.size and np.count_nonzero(others >= FLIP_RHO) >= 0.5 * others.size:
            out.append(int(k))
    return out


@dataclass(frozen=True)
class SignFix:
    """Channels read with the sign reversed and the ``issues`` entries saying so."""

    channels: tuple[int, ...]
    issues: tuple[str, ...]

    def apply(self, data: np.ndarray) -> np.ndarray:
        """The corrected ``(n, nc)`` data (a new array; negation is exact)."""
        out = np.array(data, dtype=float, copy=True)
        out[:, list(self.channels)] *= -1.0
        return out


def sign_fix(rho: np.ndarray, columns: Sequence[str]) -> SignFix:
    """The :class:`SignFix` of :func:`reversed_channels` with one ``issues`` entry per channel."""
    ks = reversed_channels(rho)
    return SignFix(
        tuple(ks),
        tuple(
            f"column {columns[k]!r}: its sign is opposite to the model's (order-feature correlation "
            f"{rho[k]:+.2f}, the other channels {np.nanmin(np.delete(rho, k)):+.2f} to "
            f"{np.nanmax(np.delete(rho, k)):+.2f}): read with the sign reversed; check the sensor's "
            "mounting direction or the sidecar"
            for k in ks
        ),
    )


def radial_mean_issues(
    measured_mean: np.ndarray,
    measured_var: np.ndarray,
    model_mean: np.ndarray,
    channels: Sequence[Any],
    bounds: tuple[float, float],
) -> list[str]:
    """``issues`` entries for radial bearing-force channels whose mean is not the model's.

    Parameters
    ----------
    measured_mean, measured_var : numpy.ndarray
        ``(nc,)`` channel means and their noise variances (``Comparison.d_static``, ``v_static``).
    model_mean : numpy.ndarray
        ``(nc,)`` channel means of the healthy model.
    channels : sequence of ChannelSpec
        ``column``, ``quantity``, ``bearing``, ``direction`` of each channel.
    bounds : tuple of float
        The sensor-gain range.

    Returns
    -------
    list of str
        One entry per channel whose ratio ``measured / model`` is outside ``bounds`` (module docstring).
    """
    d, m = np.asarray(measured_mean, float), np.asarray(model_mean, float)
    radial, _ = radial_channels(d, measured_var, m, channels)
    ratio = {k: d[k] / m[k] for k in radial}
    lo, hi = bounds
    bad = [k for k in radial if not lo <= ratio[k] <= hi]
    out = []
    for k in bad:
        c = channels[k]
        mate = next((j for j in radial if j != k and channels[j].bearing == c.bearing), None)
        what = (
            f"column {c.column!r}: measured mean {d[k]:.4g} N, model {m[k]:.4g} N (ratio {ratio[k]:+.3g}, "
            f"outside the sensor-gain range {lo:g}-{hi:g}); a radial bearing load is set by equilibrium, "
            "so "
        )
        if mate is not None and lo <= d[k] / m[mate] <= hi and lo <= d[mate] / m[k] <= hi:
            what += f"it and {channels[mate].column!r} look exchanged (crossed ratios in the range)"
        elif ratio[k] < 0:
            what += "its sign looks reversed"
        elif len(radial) > 1 and all(abs(ratio[j] / ratio[k] - 1.0) < 0.05 for j in radial):
            what += "every radial channel agrees: the declared output torque is not the machine's"
        else:
            what += "the sensor's sensitivity in the sidecar looks wrong"
        out.append(what + "; its order gain stays bounded, its envelope gain is not taken from the mean")
    return out


def correct_gain_modulation(cal: Any) -> None:
    """Divide out a slow gain that one channel carries alone (``gain_modulation.py``) before the setup.

    Reads modulations up to half the slowest shaft's rate; a corrected record gets its ``issues`` entries
    (kept by a later sign correction) and a new comparison. A record without one is left untouched.
    """
    f_slow = _slowest_rate_hz(cal)
    chans = cal.m.channels
    static = [c.quantity not in DYNAMIC_ONLY for c in chans]
    fix = gain_modulation_fix(cal.m.data, [c.column for c in chans], cal.m.sample_rate_hz, f_slow, static)
    _correct_before_setup(cal, fix)


def correct_drift(cal: Any) -> None:
    """Remove the linear trend of a channel whose mean drifts over the record (``channel_drift.py``) before
    the setup; a record without one is left untouched."""
    f_slow = _slowest_rate_hz(cal)
    chans = cal.m.channels
    cols, units = [c.column for c in chans], [c.si_unit for c in chans]
    static = [c.quantity not in DYNAMIC_ONLY for c in chans]
    fix = channel_drift(cal.m.data, cols, units, cal.m.sample_rate_hz, f_slow, static)
    _correct_before_setup(cal, fix)


def correct_leak(cal: Any) -> None:
    """Subtract a constant share of another force channel from an axial force channel (cross-talk,
    ``channel_leak.py``) before the setup; a record without one is left untouched."""
    chans = cal.m.channels
    fix = leak_fix(
        cal.m.data,
        [c.column for c in chans],
        [c.quantity for c in chans],
        [c.direction for c in chans],
        cal.m.sample_rate_hz,
    )
    _correct_before_setup(cal, fix)


def _slowest_rate_hz(cal: Any) -> float:
    """The slowest shaft's rate (Hz) at the measurement's speed."""
    from gear_rotor_sim.system import shaft_rates_hz

    return min(shaft_rates_hz(cal.runner.cfg, cal.m.operating_point.speed_rpm))


def _correct_before_setup(cal: Any, fix: Any) -> None:
    """A correction of the measurement before the setup (``fix.channels``, ``fix.issues``,
    ``fix.apply(data)``): the data, their ``issues`` (kept by a later sign correction) and a new comparison.
    Nothing for a fix without channels."""
    from gear_rotor_sim.calibration.residual import Comparison

    if not fix.channels:
        return
    cal.log("; ".join(fix.issues))
    cal.m.data = fix.apply(cal.m.data)
    cal.m.issues.extend(fix.issues)
    cal._issues_at_init = [*cal._issues_at_init, *fix.issues]
    cal.cmp = Comparison(cal.m, cal.runner, cal.settings, cal._env_max)


def _set_up_again(cal: Any, data: np.ndarray, issues: Sequence[str], n_notes: int) -> np.ndarray:
    """Corrected ``data`` and their ``issues`` entries into the measurement, the comparison and the healthy
    run set up again from the start (the model runs come from the runner's cache); the healthy outputs."""
    from gear_rotor_sim.calibration.residual import Comparison

    cal.log("; ".join(issues))
    cal.m.data = data
    cal._issues_at_init = [*cal._issues_at_init, *issues]
    cal.m.issues[:] = list(cal._issues_at_init)
    del cal.notes[n_notes:]  # the first setup's notes (the step count) come again
    cal.runner.steps_per_mesh = cal._steps_at_init
    cal.step_choice = None
    cal.cmp = Comparison(cal.m, cal.runner, cal.settings, cal._env_max)
    return cal._setup()


def check_conventions(cal: Any) -> np.ndarray:
    """The calibrator's setup (``_setup``, the healthy model's first run) and the checks on it
    (``Calibrator.run``).

    Reads the sign of every channel against the healthy model (:func:`sign_fix`); if one is reversed,
    the measurement is corrected, its ``issues`` get the entry, and the comparison and the healthy run
    are set up again from the start (the model runs come from the runner's cache), so the diagnosis
    is the one of the correctly signed record (before the setup: a channel's own slow gain divided out,
    :func:`correct_gain_modulation`, a drifting mean's trend removed, :func:`correct_drift`, and
    cross-talk into an axial force subtracted, :func:`correct_leak`). Then an
    axial bearing force's zero offset that no claimable
    temperature explains is subtracted the same way (``axial_zero.find_axial_zero``), the load is checked
    (``load_check.check_load``) and the radial bearing-force means (:func:`radial_mean_issues`). A record
    whose channels all read right is left untouched.

    Parameters
    ----------
    cal : Calibrator
        Not yet set up; it holds ``_issues_at_init``, ``_steps_at_init`` and ``_env_max`` from its
        construction.

    Returns
    -------
    numpy.ndarray
        The healthy model's outputs (of the new setup if the data were corrected).
    """
    n_notes = len(cal.notes)
    correct_gain_modulation(cal)  # a channel's own slow gain, divided out (gain_modulation.py)
    correct_drift(cal)  # a channel's mean drifting over the record, its trend removed (channel_drift.py)
    correct_leak(cal)  # cross-talk into an axial force, subtracted (channel_leak.py)
    base_out = cal._setup()
    cmp = cal.cmp
    if "order" in cmp.families and cmp.shafts:
        feats = cal._features(cal.base_raw)
        shifted = cmp.apply_shift(feats, cmp.best_shift(feats))
        columns = [c.column for c in cal.m.channels]
        fix = sign_fix(order_correlation(cmp.d_order, cmp.v_order, shifted.order), columns)
        if fix.channels:
            base_out = _set_up_again(cal, fix.apply(cal.m.data), fix.issues, n_notes)
    base_out = correct_skew(cal, base_out, n_notes)  # a channel delayed by the acquisition (channel_skew.py)
    leave_out_unmeasured_means(cal, base_out)  # force sensors without a mean: AC-coupled (force_coupling.py)
    zeros = find_axial_zero(cal)  # an axial force's zero offset (axial_zero.py)
    if zeros:
        data = np.array(cal.m.data, dtype=float, copy=True)
        for z in zeros:
            data[:, z.channel] -= z.offset_n
        base_out = _set_up_again(cal, data, tuple(z.issue() for z in zeros), n_notes)
    base_out = check_load(cal, base_out, n_notes)  # the output torque (load_check.py)
    cmp = cal.cmp
    if "static" in cmp.families:
        for issue in radial_mean_issues(
            cmp.d_static,
            np.where(cmp.static_mask, cmp.v_static, np.inf),
            base_out.mean(axis=0),
            cal.m.channels,
            cal.settings.gain_bounds,
        ):
            if issue not in cal.m.issues:
                cal.m.issues.append(issue)
    return base_out
