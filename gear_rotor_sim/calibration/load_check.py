"""The declared output torque checked against the record's radial bearing-force means, the model run at
the measured torque where they disagree (issue 11: effects nobody declared; docs/calibration.md Sec. 2
"Load check").

Physics. Averaged over whole hunting periods the gear's angular acceleration is zero, so the mean mesh
force along the line of action is ``W = T / r_b2`` (torque equilibrium of the gear), whatever the mesh
stiffness, damping, backlash or tooth separation. The shafts' mean bearing reactions are ``W`` shared by
the lever rule (static equilibrium of each shaft), with no other radial static load in the model (no
gravity; the thermal load is axial). So every radial bearing-force channel's mean is proportional to the
output torque, and ``r_k = measured mean_k / model mean_k`` at the declared torque reads

    r_k = g_k T_true / T_declared,

with ``g_k`` the channel's sensor gain. A wrong torque scales every radial channel alike; a sensor's gain
error moves one channel (and turns the measured mean force's direction, which the load does not).

Estimate (:func:`estimate_load`): each ``r_k`` with variance ``s_k^2 = v_k / m_k^2 + (GAIN_SD r_k)^2``
(the mean's noise, from the scatter of per-revolution means, and a sensor gain known to ``GAIN_SD``, one
sigma); their inverse-variance mean ``L``, its sigma ``1 / sqrt(sum 1/s_k^2)`` scaled by the Birge ratio
``sqrt(chi2 / (n - 1))`` where the channels scatter more than that, and the consistency
``chi2 = sum (r_k - L)^2 / s_k^2``. The measured torque is ``L T_declared``.

Decision (:attr:`LoadEstimate.fires`): at least ``MIN_CHANNELS`` radial channels, consistent
(``chi2`` below the ``1 - P_CONSISTENT`` quantile of chi^2 with ``n - 1`` degrees of freedom: one channel
off is a sensor, named by ``channel_conventions.radial_mean_issues``), ``|L - 1| > K_SIGMA sigma``
(beyond the noise and the gain spread) and ``L`` within ``PLAUSIBLE``. Then (:func:`correct_load`) the
measurement's operating point gets the measured torque, the healthy model is set up again at it, an
``issues`` entry names ``operating_point.output_torque_nm`` (declared, measured, sigma), a note gives the
cross-checks (the healthy model's error and the DTE mean at both torques), and ``Calibrator.run`` reports
an ``operating_torque`` entry in ``baseline_updates`` (:func:`torque_entry`). A record whose channels
read the declared load is left untouched (no issue, no note, no entry; the same report).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

#: one-sigma relative gain error of a force sensor (a calibrated load cell: a few %)
GAIN_SD = 0.03
#: the load must differ from the declared one by this many sigma (noise and gain spread)
K_SIGMA = 3.0
#: the channels are consistent unless chi^2 exceeds its 1 - P_CONSISTENT quantile (3 sigma two-sided)
P_CONSISTENT = 0.0027
#: radial channels needed: with one, a sensor's gain and the load cannot be told apart
MIN_CHANNELS = 2
#: load ratios read as a torque error; beyond them the record is left at the declared torque (issue only)
PLAUSIBLE = (0.2, 5.0)
#: a radial mean must stand this many noise deviations out, in the record and in the model (as
#: ``features_bearing.static_sensor_gains``'s ``min_snr``; also ``channel_conventions.radial_mean_issues``)
MIN_SNR = 30.0


@dataclass(frozen=True)
class LoadEstimate:
    """The output torque read from the radial bearing-force means (module docstring).

    Attributes
    ----------
    declared_nm : float
        The torque the model ran at (the sidecar's ``output_torque_nm``, else the rig's load).
    columns : tuple of str
        The radial bearing-force channels used.
    ratios, sigmas : tuple of float
        ``r_k`` and ``s_k`` of each.
    ratio, sigma : float
        ``L`` and its sigma.
    chi2 : float
        Consistency of the channels about ``L``.
    declared_in_sidecar : bool
        Whether the sidecar gave ``output_torque_nm``.
    """

    declared_nm: float
    columns: tuple[str, ...]
    ratios: tuple[float, ...]
    sigmas: tuple[float, ...]
    ratio: float
    sigma: float
    chi2: float
    declared_in_sidecar: bool = True

    @property
    def n(self) -> int:
        return len(self.ratios)

    @property
    def consistent(self) -> bool:
        """The channels agree on one load within their gain spread."""
        if self.n < 2:
            return False
        return bool(self.chi2 <= stats.chi2.isf(P_CONSISTENT, self.n - 1))

    @property
    def z(self) -> float:
        """``(L - 1) / sigma``."""
        return (self.ratio - 1.0) / self.sigma if self.sigma > 0 else math.inf

    @property
    def fires(self) -> bool:
        """Whether the model is to run at the measured torque."""
        lo, hi = PLAUSIBLE
        return self.n >= MIN_CHANNELS and self.consistent and abs(self.z) > K_SIGMA and lo <= self.ratio <= hi

    @property
    def measured_nm(self) -> float:
        return self.ratio * self.declared_nm

    @property
    def sigma_nm(self) -> float:
        return self.sigma * self.declared_nm

    def describe(self) -> str:
        """One line naming the declared and measured torques."""
        src = "declared" if self.declared_in_sidecar else "not declared; the rig's"
        return (
            f"operating_point.output_torque_nm: {src} {self.declared_nm:.4g} N m, the radial bearing-force "
            f"means give {self.measured_nm:.4g} +- {self.sigma_nm:.2g} N m ({100 * (self.ratio - 1):+.3g} %; "
            f"{', '.join(f'{c} x{r:.3f}' for c, r in zip(self.columns, self.ratios, strict=True))} of the "
            "model's mean)"
        )


def radial_channels(
    measured_mean: np.ndarray, measured_var: np.ndarray, model_mean: np.ndarray, channels: Sequence[Any]
) -> tuple[list[int], np.ndarray]:
    """The radial bearing-force channels whose mean stands ``MIN_SNR`` noise deviations out in the record
    and in the model, and every channel's noise deviation of its mean (inf where the variance is not a
    number >= 0); shared with ``channel_conventions.radial_mean_issues``."""
    d, m = np.asarray(measured_mean, float), np.asarray(model_mean, float)
    v = np.asarray(measured_var, float)
    sd = np.sqrt(np.where(np.isfinite(v) & (v >= 0), v, np.inf))
    ks = [
        k
        for k, c in enumerate(channels)
        if c.quantity == "bearing_force"
        and c.direction in ("x", "y")
        and np.isfinite(m[k])
        and abs(m[k]) > MIN_SNR * sd[k]
        and abs(d[k]) > MIN_SNR * sd[k]
    ]
    return ks, sd


def estimate_load(
    measured_mean: np.ndarray,
    measured_var: np.ndarray,
    model_mean: np.ndarray,
    channels: Sequence[Any],
    declared_nm: float,
    declared_in_sidecar: bool = True,
) -> LoadEstimate | None:
    """The load ratio of the radial bearing-force channels (module docstring).

    Parameters
    ----------
    measured_mean, measured_var : numpy.ndarray
        ``(nc,)`` channel means and their noise variances (``Comparison.d_static``, ``v_static``; inf
        where a channel has no static feature).
    model_mean : numpy.ndarray
        ``(nc,)`` channel means of the healthy model at ``declared_nm``.
    channels : sequence of ChannelSpec
        ``column``, ``quantity``, ``direction`` of each channel.
    declared_nm : float
        The torque of the model run.
    declared_in_sidecar : bool
        Whether the sidecar gave it (reported).

    Returns
    -------
    LoadEstimate or None
        None where no radial channel's mean stands ``MIN_SNR`` noise deviations out in the record and in
        the model, or where a ratio is not positive (a reversed sign or exchanged axes: a sensor).
    """
    d, m = np.asarray(measured_mean, float), np.asarray(model_mean, float)
    ks, sd = radial_channels(d, measured_var, m, channels)
    if not ks:
        return None
    r = d[ks] / m[ks]
    if np.any(r <= 0):
        return None
    s = np.sqrt(sd[ks] ** 2 / m[ks] ** 2 + (GAIN_SD * r) ** 2)
    w = 1.0 / s**2
    ratio = float(np.sum(w * r) / np.sum(w))
    sigma = float(1.0 / np.sqrt(np.sum(w)))
    chi2 = float(np.sum(w * (r - ratio) ** 2))
    if len(ks) > 1:
        sigma *= max(1.0, math.sqrt(chi2 / (len(ks) - 1)))
    return LoadEstimate(
        float(declared_nm),
        tuple(str(channels[k].column) for k in ks),
        tuple(float(x) for x in r),
        tuple(float(x) for x in s),
        ratio,
        sigma,
        chi2,
        declared_in_sidecar,
    )


@dataclass
class LoadCorrection:
    """What :func:`correct_load` did: the estimate, the healthy model's error at the declared and at the
    measured torque (scored alike: transfer slopes fitted, before the static screen and the rattle
    rules), and the DTE means (m) of the record and of the model at both torques (NaN without a DTE)."""

    estimate: LoadEstimate
    error_declared: float
    error_measured: float
    dte_mean: tuple[float, float, float] = (math.nan, math.nan, math.nan)

    def note(self) -> str:
        rec, at_decl, at_meas = self.dte_mean
        dte = (
            ""
            if not math.isfinite(rec)
            else f"; DTE mean {rec * 1e6:.4g} um, the model's {at_decl * 1e6:.4g} um at the declared and "
            f"{at_meas * 1e6:.4g} um at the measured torque (it also holds the mesh stiffness and any wear)"
        )
        return (
            f"operating_torque: {self.estimate.describe()}; the healthy model's error "
            f"{self.error_declared:.4g} at the declared torque, {self.error_measured:.4g} at the measured "
            f"torque (an operating-point correction, not an effect){dte}"
        )


def load_estimate(cal: Any, base_out: np.ndarray) -> LoadEstimate | None:
    """:func:`estimate_load` on a set-up calibrator ``cal`` and its healthy model outputs ``base_out``;
    None for a rig without a load or without the static family."""
    cmp = cal.cmp
    load = getattr(cal.runner.cfg, "load", None)
    if load is None or "static" not in cmp.families:
        return None
    return estimate_load(
        cmp.d_static,
        np.where(cmp.static_mask, cmp.v_static, np.inf),
        base_out.mean(axis=0),
        cal.m.channels,
        float(load.torque_nm),
        cal.m.operating_point.output_torque_nm is not None,
    )


def _dte_mean(cal: Any, base_out: np.ndarray) -> tuple[float, float]:
    """(record, model) mean of the first DTE channel; NaNs without one."""
    names = list(cal.cmp.names)
    if "dte" not in names:
        return math.nan, math.nan
    k = names.index("dte")
    return float(cal.cmp.d_static[k]), float(base_out[:, k].mean())


def correct_load(cal: Any, est: LoadEstimate, base_out: np.ndarray, n_notes: int) -> np.ndarray:
    """Set ``cal`` up again at the measured torque (``cal.torque_correction`` gets the
    :class:`LoadCorrection`).

    Parameters
    ----------
    cal : Calibrator
        Set up at the declared torque (``_setup`` done, ``base_out`` its healthy outputs).
    est : LoadEstimate
        With :attr:`LoadEstimate.fires`.
    base_out : numpy.ndarray
        The healthy model's outputs at the declared torque.
    n_notes : int
        ``len(cal.notes)`` before the first setup: the setup's notes (the step count) come again.

    Returns
    -------
    numpy.ndarray
        The healthy model's outputs at the measured torque.
    """
    from gear_rotor_sim.calibration.residual import Comparison
    from gear_rotor_sim.calibration.speed_check import _nominal_error

    error_declared = _nominal_error(cal)
    dte_rec, dte_decl = _dte_mean(cal, base_out)
    issue = est.describe() + "; the model runs at the measured torque"
    cal.log(issue)
    op = dataclasses.replace(cal.m.operating_point, output_torque_nm=float(est.measured_nm))
    cal.m = dataclasses.replace(cal.m, operating_point=op, issues=[*cal.m.issues, issue])
    del cal.notes[n_notes:]
    cal.step_choice = None
    cal.runner = dataclasses.replace(
        cal.runner,
        operating_point=op,
        steps_per_mesh=cal._steps_at_init,
        # as Calibrator.__init__ sets them (the first setup may have switched them off where the teeth
        # separate at the declared load)
        accel_from_velocity=cal.reference_numerics,
        exact_modal_map=True if cal.reference_numerics and cal.settings.reference_exact_map else None,
    )
    cal.cmp = Comparison(cal.m, cal.runner, cal.settings, cal._env_max)
    base_out = cal._setup()
    error_measured = _nominal_error(cal)
    dte = (dte_rec, dte_decl, _dte_mean(cal, base_out)[1])
    cal.torque_correction = LoadCorrection(est, error_declared, error_measured, dte)
    cal.notes.append(cal.torque_correction.note())
    cal.log(cal.notes[-1])
    return base_out


def check_load(cal: Any, base_out: np.ndarray, n_notes: int) -> np.ndarray:
    """The load check of a set-up calibrator (``channel_conventions.check_conventions``): the healthy
    outputs at the measured torque where the check fires (:func:`correct_load`), else ``base_out``
    unchanged. ``cal.torque_correction`` is the correction or None. Then the fluctuating-load check
    (``load_fluctuation.check_load_fluctuation``: where the radial means are modulated alike, the load's
    sidebands removed and the setup redone; ``cal.load_fluctuation``)."""
    from gear_rotor_sim.calibration.load_fluctuation import check_load_fluctuation

    cal.torque_correction = None
    cal.load_fluctuation = None
    if not getattr(cal, "load_check", True):
        return base_out
    est = load_estimate(cal, base_out)
    if est is not None and est.fires:
        base_out = correct_load(cal, est, base_out, n_notes)
    return check_load_fluctuation(cal, base_out)


def torque_entry(corr: LoadCorrection) -> Any:
    """The ``operating_torque`` entry of ``baseline_updates`` (an operating-point correction, never an
    effect): measured and declared torque, sigma, the healthy model's error at the declared
    (``error_before``) and at the measured torque (``error_after``)."""
    from gear_rotor_sim.calibration.fit_types import FoundEffect

    e = corr.estimate
    return FoundEffect(
        name="operating_torque",
        label="operating_torque",
        parameters={"output_torque_nm": e.measured_nm, "declared_output_torque_nm": e.declared_nm},
        uncertainty={"output_torque_nm": e.sigma_nm},
        confidence=1.0,
        delta_bic=math.nan,
        explained_fraction=math.nan,
        error_before=float(corr.error_declared),
        error_after=float(corr.error_measured),
        effect=None,
        status="baseline",
    )
