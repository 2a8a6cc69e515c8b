"""Force sensors that hold no mean: AC coupling (issue 11, an effect nobody declared; docs/calibration.md Sec.
1, "Sensor conventions and faults nobody declared"; history Sec. 8.62).

A piezoelectric force sensor and its charge amplifier are a first-order high-pass (the charge leaks through
the feedback resistor: ``f_c = 1 / (2 pi R C)``, 0.1-1 Hz, longer for "quasi-static" settings). Under a load
held since long before the record its output holds **no mean**. The static features (Sec. 8.2) assume
DC-coupled forces: a radial bearing reaction's mean is an equilibrium load (the lever-rule share of the mesh
force ``T / r_b``, whatever the stiffness, ``load_check.py``), the axial one the model's thermometer (the
thermal load ``k_s a dT L / (1 + 2 k_s / k_b)``, Sec. 8.3). An AC-coupled force channel read as DC-coupled
puts the whole static load into the residual at the noise of a mean (sigma of a few newtons against a load
of 10^3 N).

Rule (after the healthy model's first run, ``channel_conventions.check_conventions``): the radial
bearing-force channels whose model mean stands :data:`MIN_SNR` noise deviations of the measured mean out
(the loads that identify a sensor gain, ``features_bearing.static_sensor_gains``) all read a mean within
``max(NO_MEAN_SIGMA sigma, NO_MEAN_FRACTION |model|)`` of zero. No loaded gearbox does that: a sensor's gain
of zero is not a sensor, and a torque of zero is refused by the load check's range (``0.2 <= L <= 5``). The
force sensors then hold no mean: every bearing-force channel's mean is left out of the static features (the
axial sensor of a bearing is of the radial ones' kind: its mean, zero or not, is not read as a temperature),
and ``issues`` names the columns, the means and what is lost: the temperature is read from the other
channels' means (the DTE) and the dynamic features only, the output torque is not checked. A single radial
channel reading zero while another reads its load is a sensor fault of that channel
(``channel_conventions.radial_mean_issues``), not this rule."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.features_bearing import RADIAL_DIRECTIONS

#: a radial model mean this many noise deviations out is a load the record must show (as static_sensor_gains)
MIN_SNR = 30.0
#: a measured mean within this many noise deviations of zero, or this fraction of the model's, is no mean
NO_MEAN_SIGMA = 5.0
NO_MEAN_FRACTION = 0.02


def means_not_measured(
    measured_mean: np.ndarray, measured_var: np.ndarray, model_mean: np.ndarray, channels: Sequence[Any]
) -> list[int]:
    """The bearing-force channels whose means the sensors do not hold (module docstring); empty if the rule
    does not fire.

    Parameters
    ----------
    measured_mean, measured_var : numpy.ndarray
        ``(nc,)`` channel means of the record and their noise variances (``Comparison.d_static``,
        ``v_static``; inf where a channel has no static feature).
    model_mean : numpy.ndarray
        ``(nc,)`` channel means of the healthy model.
    channels : sequence of ChannelSpec
        ``quantity`` and ``direction`` of each channel.
    """
    d, m = np.asarray(measured_mean, float), np.asarray(model_mean, float)
    v = np.asarray(measured_var, float)
    sd = np.sqrt(np.where(np.isfinite(v) & (v >= 0), v, np.inf))
    forces = [k for k, c in enumerate(channels) if c.quantity == "bearing_force" and np.isfinite(sd[k])]
    loaded = [k for k in forces if channels[k].direction in RADIAL_DIRECTIONS and abs(m[k]) > MIN_SNR * sd[k]]
    if not loaded:
        return []
    if any(abs(d[k]) > max(NO_MEAN_SIGMA * sd[k], NO_MEAN_FRACTION * abs(m[k])) for k in loaded):
        return []
    return forces


def leave_out_unmeasured_means(cal: Any, base_out: np.ndarray) -> list[int]:
    """Apply :func:`means_not_measured` to a set-up calibrator: the channels' means left out of the static
    family (``cmp.static_mask``; the family dropped if none is left), the radial channels' envelope gains,
    which their mean ratios gave, set to their declared sensitivity (1), and one ``issues`` entry. Returns the
    channels (empty: nothing changed)."""
    cmp = cal.cmp
    if "static" not in cmp.families:
        return []
    model_mean = base_out.mean(axis=0)
    chans = cal.m.channels
    ks = means_not_measured(cmp.d_static, np.where(cmp.static_mask, cmp.v_static, np.inf), model_mean, chans)
    if not ks:
        return []
    cmp.static_mask[ks] = False
    if not cmp.static_mask.any():
        cmp.families = tuple(f for f in cmp.families if f != "static")
    cmp._set_envelope_gains(base_out)
    # the envelope gain a radial channel took from its mean ratio: its declared sensitivity instead (the order
    # gain holds the mesh carriers' model-form misfit: 0.8, its bound, on the independent records, which read
    # an outer race 1.25 x high)
    radial = [k for k in ks if chans[k].direction in RADIAL_DIRECTIONS]
    cmp.envelope_gains[radial] = 1.0
    means = ", ".join(f"{chans[k].column} {cmp.d_static[k]:.3g} N (model {model_mean[k]:.4g} N)" for k in ks)
    issue = (
        f"bearing-force channels hold no mean: {means}; a loaded gearbox's radial bearing reactions "
        "cannot average zero, so the force sensors are AC-coupled (piezoelectric with a charge amplifier, "
        "or a high-pass in the acquisition): their means are not measured and are left out of the static "
        "features (their envelope gain is their declared sensitivity); the temperature is read from the "
        "other channels' means and the dynamic features only, and the output torque is not checked"
    )
    cal.log(issue)
    if issue not in cal.m.issues:
        cal.m.issues.append(issue)
    return ks
