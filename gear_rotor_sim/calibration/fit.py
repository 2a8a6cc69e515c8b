"""Tracing the residual to effects: fit each candidate, rank, add the best, stop at the noise level.

Procedure (``docs/calibration.md``):

1. Healthy model at the declared operating point; nuisances fitted (per-channel gain, time shift,
   envelope band/housing frequency). Error ``E0`` (normalised RMS residual, 1 = noise level).
2. If the model already fits (``E <= stop_error``), report no effect.
3. Each candidate effect's parameters are fitted on the feature residual, the candidate's response
   being the current model plus its signature relative to the healthy model (one simulation per
   basis or grid point, cached):

   * amplitude + phase (eccentricity, unbalance, misalignment): two basis runs (phase 0 and
     90 deg); weighted linear least squares for the cos/sin coefficients (exact for a linear
     time-varying response);
   * amplitude only (wear, bearing defects): one basis run; bounded scalar minimisation (a coarse
     logarithmic grid, then Brent) because the envelope features are not linear in the amplitude;
   * nonlinear scalars (temperature offset, mesh stiffness then damping scale, tooth-damage depth):
     a coarse grid over the bounds, responses interpolated between grid points, minimum of the
     interpolant; the damaged tooth index is searched exhaustively by shifting the damage
     signature by whole mesh periods.

4. Candidates are ranked by ``Delta BIC = chi2_current - chi2_candidate - k ln N`` (Schwarz 1978;
   ``k`` fitted parameters, ``N`` features; family-balanced chi^2). The best is accepted only if
   ``Delta BIC > bic_threshold`` and it explains at least ``min_explained`` of the excess residual
   (``chi2 - N``); its parameters are then refined with real simulations (secant steps) and the
   acceptance re-checked on a full simulation of the updated model; an effect refused there hands the
   round to the next candidate (``search_rounds.py``). Repeat until the error is at the
   noise level, nothing qualifies, or ``max_effects`` are in.

Baseline and consistency (issue 11, ``docs/calibration.md`` Sec. 8): the baseline parameter sets
(mesh and bearing stiffness/damping scales) compete with the effects in every round but update the
machine (``baseline_updates``) instead of being reported; with a reference record they are fitted
there and held. A temperature offset is first screened on the static content (channel means). A
candidate at a parameter bound or contradicting the static content is refused (``not_claimed``);
a damaged tooth must improve its own wheel's order comb.

Confidence of an accepted effect: ``P(effect) * P(best vs runner-up)``, both BIC posterior
probabilities ``1 / (1 + exp(-Delta/2))`` (Kass & Raftery 1995), so an effect that barely beats an
alternative explanation is reported with a low confidence. Parameter uncertainty: from the
curvature of chi^2 (scalar fits) or the normal matrix (linear fits), scaled by the reduced chi^2.

Modules (split in session 16, docs/history/calibration_sessions.md Sec. 8.40): this one keeps the constructor
and the search loop (:meth:`Calibrator.run`); the settings and results are in ``fit_types.py``;
the calibrator's other methods are mixins by concern: ``fit_model.py`` (model runs and features),
``fit_screens.py`` (screens before the rounds, the baseline stage), ``fit_candidates.py`` (step 3),
``fit_verify.py`` (a candidate's own signature, consistency), ``fit_refine.py`` (refinement on full
simulations); ``synthetic.py`` makes the self-test's records. The names are importable from here as before.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.baseline_bounds import baseline_bound_notes
from gear_rotor_sim.calibration.candidates_tooth_path import (
    contact_tooth_path,
)
from gear_rotor_sim.calibration.channel_conventions import check_conventions
from gear_rotor_sim.calibration.claim_check import apply_claim_checks
from gear_rotor_sim.calibration.confirm_updated import stalled_round_step
from gear_rotor_sim.calibration.contact_mesh import contact_mesh_screen
from gear_rotor_sim.calibration.dte_zero import dte_zero_issues
from gear_rotor_sim.calibration.features_bearing import impulse_note
from gear_rotor_sim.calibration.features_rattle import apply_rattle_uncertainty
from gear_rotor_sim.calibration.fit_candidates import CandidateFitting
from gear_rotor_sim.calibration.fit_model import EXACT_ORDERS_MAX_CONTACT_LOSS, ModelAccess
from gear_rotor_sim.calibration.fit_refine import Refinement
from gear_rotor_sim.calibration.fit_screens import Screening
from gear_rotor_sim.calibration.fit_types import (
    CalibrationResult,
    CandidateFit,
    FitSettings,
    FoundEffect,
    _logistic,
    _screen_gain,
    _screened,
    model_residual_spectra,
    reported_parameters,
)
from gear_rotor_sim.calibration.fit_verify import Verification
from gear_rotor_sim.calibration.line_removal import remove_unlocked_lines
from gear_rotor_sim.calibration.load_check import torque_entry
from gear_rotor_sim.calibration.mains_check import mains_issues
from gear_rotor_sim.calibration.mains_repair import copy_measurement, rerun_without_pickup
from gear_rotor_sim.calibration.measurement import Measurement
from gear_rotor_sim.calibration.model_steps import StepChoice
from gear_rotor_sim.calibration.model_window import model_window_samples
from gear_rotor_sim.calibration.pitch_baseline import pitch_round
from gear_rotor_sim.calibration.reference_point import rerun_off_point
from gear_rotor_sim.calibration.residual import (
    REFERENCE_STEPS_PER_MESH,
    Comparison,
    HousingSensor,
    ModelFeatures,
    ModelRunner,
    ResidualSettings,
    Score,
    housing_source,
    time_and_spectrum_errors,
)
from gear_rotor_sim.calibration.residual_trace import trace_residual
from gear_rotor_sim.calibration.search_rounds import examine_round
from gear_rotor_sim.calibration.speed_check import check_operating_speed, correction_errors, speed_entry
from gear_rotor_sim.calibration.synthetic import synthetic_measurement
from gear_rotor_sim.faults import (
    BASELINE_TYPES,
    BEARING_6206,
    BearingDefect,
    BearingGeometry,
    Effect,
    ToothWear,
    baseline_candidates,
    candidate_effects,
    effect_name,
)

#: the names other modules, tests and benchmarks import from here (moved in session 16)
__all__ = [
    "EXACT_ORDERS_MAX_CONTACT_LOSS",
    "CalibrationResult",
    "Calibrator",
    "CandidateFit",
    "FitSettings",
    "FoundEffect",
    "_logistic",
    "_screen_gain",
    "_screened",
    "calibrate",
    "model_residual_spectra",
    "reported_parameters",
    "synthetic_measurement",
]


class Calibrator(ModelAccess, Screening, CandidateFitting, Verification, Refinement):
    """Runs the procedure of the module docstring on one measurement.

    Parameters
    ----------
    measurement : Measurement
    cfg : RigConfig
        Model of the machine (default ``load_config(measurement.gearbox)`` with the measurement's
        ``bearing_type`` on every bearing when it names one).
    candidates : list of Effect, optional
        Default :func:`candidate_effects` for the rig, bearing defects at the observed bearings.
    settings, fit_settings : ResidualSettings, FitSettings
    sensors : dict, optional
        ``channel -> HousingSensor`` for housing-acceleration channels (frequency refined from the
        measured impulsive band).
    bearing_geometry : BearingGeometry
        Geometry for the bearing-defect candidates.
    log : callable, optional
        Progress messages.
    baseline : list of Effect, optional
        Baseline parameter sets fixed from a healthy reference record (``--baseline``); default:
        fitted on this record, competing with the effects.
    baseline_source : str, optional
        Reported ``baseline.source`` (the reference file).
    carrier_tolerance : float, optional
        Model-form tolerance of the mesh carriers from the reference record.
    baseline_sets : list of Effect, optional
        Baseline sets offered (default :func:`baseline_candidates` of the rig).
    model_window : bool
        Simulate whole hunting periods of the mesh instead of the record length
        (:func:`~gear_rotor_sim.calibration.model_window.model_window_samples`; default True).
    baseline_reference : dict, optional
        Summary of the reference record the held baseline comes from (reported as
        ``baseline.reference``; :meth:`calibration.baseline.ReferenceBaseline.calibrator_kwargs`).
    rattle_rules : bool
        Where the healthy model's teeth separate, add the baseline-ensemble variance to the order
        features and leave out a locked rattle component (``features_rattle.py``; default True).
    steps_per_mesh : int, optional
        Integration steps per mesh period of every model run. Default: chosen from the healthy
        model's convergence at the record's operating point (``model_steps.py``; from 32, from 64
        against a held ``baseline``), reported as ``model_steps`` in the result.
    speed_check : bool
        Read the input speed from the record's mesh lines and calibrate at it where it disagrees with
        the declared one (``speed_check.py``; default True; rigs without a mesh are not checked).
    load_check : bool
        Read the output torque from the radial bearing-force means and calibrate at it where it
        disagrees with the declared one (``load_check.py``; default True).
    """

    def __init__(
        self,
        measurement: Measurement,
        cfg: Any = None,
        candidates: Sequence[Effect] | None = None,
        settings: ResidualSettings | None = None,
        fit_settings: FitSettings | None = None,
        sensors: dict[str, HousingSensor] | None = None,
        bearing_geometry: BearingGeometry = BEARING_6206,
        warmup_s: float = 0.15,
        steps_per_mesh: int | None = None,
        log: Callable[[str], None] | None = None,
        baseline: Sequence[Effect] | None = None,
        baseline_source: str | None = None,
        carrier_tolerance: float | None = None,
        baseline_sets: Sequence[Effect] | None = None,
        model_window: bool = True,
        baseline_reference: dict[str, Any] | None = None,
        rattle_rules: bool = True,
        reference_numerics: bool | None = None,
        speed_check: bool = True,
        load_check: bool = True,
    ) -> None:
        # the arguments as given, the record copied: diagnosed again without mains pickup (mains_repair.py)
        self._init_args = {k: v for k, v in locals().items() if k not in ("self", "__class__")}
        self._init_args["measurement"] = copy_measurement(measurement)
        if cfg is None:
            from gear_rotor_sim.config import load_config

            cfg = load_config(measurement.gearbox)
            if measurement.bearing_type:
                cfg = cfg.with_bearing_type(measurement.bearing_type)
        # the declared speed against the record's mesh lines; the measured one where they disagree
        # (speed_check.py, docs/calibration.md Sec. 2 "Speed check")
        self.speed = None
        if speed_check:
            measurement, self.speed = check_operating_speed(measurement, cfg)
        self.m = measurement
        self.load_check = load_check
        self.torque_correction = None  # set by channel_conventions.check_conventions (load_check.py)
        self.rattle_rules = rattle_rules
        #: the exact order integral, the velocity derivative and the envelope-band fallback where the
        #: healthy model stays in contact (Sec. 8.18): for a held reference baseline and its fit
        self.reference_numerics = baseline is not None if reference_numerics is None else reference_numerics
        self.settings = settings or ResidualSettings()
        #: the step count is chosen from the healthy model's convergence unless given (model_steps.py)
        self.auto_steps = steps_per_mesh is None
        self.step_choice: StepChoice | None = None
        if baseline is not None:
            # against a held reference: located mesh events (REFERENCE_STEPS_PER_MESH) and the band
            # of a channel without an envelope line from its bearing's most prominent channel (Sec. 8.18)
            if steps_per_mesh is None:
                steps_per_mesh = REFERENCE_STEPS_PER_MESH
            if not self.settings.envelope_band_fallback:
                self.settings = dataclasses.replace(self.settings, envelope_band_fallback=True)
        if steps_per_mesh is None:
            steps_per_mesh = 32
        self.fit = fit_settings or FitSettings()
        self.log = log or (lambda s: None)
        self.runner = ModelRunner(
            cfg,
            measurement.operating_point,
            measurement.sample_rate_hz,
            measurement.n_samples,
            measurement.t0,
            measurement.model_channels,
            warmup_s,
            steps_per_mesh,
            dict(sensors or {}),
            n_model=model_window_samples(
                cfg, measurement.operating_point.speed_rpm, measurement.sample_rate_hz, measurement.n_samples
            )
            if model_window
            else 0,
        )
        self.runner.accel_from_velocity = self.reference_numerics
        if self.reference_numerics and self.settings.reference_exact_map:
            # no period error at the mesh-coupled modes (ResidualSettings.reference_exact_map, Sec. 8.21)
            self.runner.exact_modal_map = True
        cfg = self.runner.cfg
        _check_channels(measurement, cfg)
        observed = sorted(
            {int(c.split("_")[0][7:]) for c in measurement.model_channels if c.startswith("bearing")}
        )
        if candidates is None:
            candidates = candidate_effects(cfg, bearing_geometry, bearings=tuple(observed) or None)
        self.candidates = list(candidates)
        env_max = self._envelope_max(cfg, bearing_geometry)
        # what a sign correction sets up again (channel_conventions.check_conventions)
        self._issues_at_init = list(measurement.issues)
        self._steps_at_init, self._env_max = steps_per_mesh, env_max
        self.cmp = Comparison(measurement, self.runner, self.settings, env_max)
        self.notes: list[str] = []
        #: what the rattle wear rule read, claimed or not (``candidates_wear_rattle``); None if not run
        self.rattle_wear_reading: dict[str, Any] | None = None
        #: a damaged tooth's path in contact (opt-in ``tooth_path_in_contact``); set by ``run``
        self._tooth_path: np.ndarray | None = None
        #: per tooth candidate label: the search's whole-record and DTE low-order rankings
        #: (``candidates_tooth_index.py``; set by ``_fit_tooth`` in contact with a DTE)
        self._low_order_index: dict[str, Any] = {}
        #: baseline parameter sets in force (fixed when given, else fitted on this record first)
        self.baseline: list[Effect] = list(baseline or [])
        self.fit_baseline = baseline is None
        self.baseline_source = baseline_source or ("measurement" if baseline is None else "given")
        self.fixed_carrier_tolerance = carrier_tolerance
        self.baseline_reference = dict(baseline_reference or {})
        #: baseline parameter sets offered (default: the library's for the rig)
        self.baseline_sets = list(baseline_candidates(cfg) if baseline_sets is None else baseline_sets)
        #: effects found before the baseline stage (temperature from the static content)
        self.pre_effects: list[Effect] = []

    def _bearing_shaft_rad_s(self, e: BearingDefect) -> float:
        """Speed (rad/s) of the shaft that carries bearing ``e.bearing``."""
        from gear_rotor_sim.system import shaft_speed_ratios

        cfg = self.runner.cfg
        s = cfg.shaft_of_node(cfg.bearings[e.bearing - 1].node0)
        ratio = abs(float(shaft_speed_ratios(cfg)[s]))
        return ratio * self.m.operating_point.speed_rpm * math.pi / 30.0

    def run(self) -> CalibrationResult:
        self._feat_correction: ModelFeatures | None = None
        remove_unlocked_lines(self)  # mains off the orders, a neighbouring machine's tones (line_removal.py)
        base_out = check_conventions(self)  # _setup and the sensor conventions
        speed_errors = correction_errors(self)  # None unless the speed was corrected (speed_check.py)
        self._prepare_comparison()
        score0 = self.cmp.score(self._features(self.base_raw))
        self.n_total = score0.n_total
        self.log(f"nominal model: error {score0.error:.3g}")
        # a held reference whose machine scores this point worse than the nominal one: set aside
        # (reference_point.py)
        again = rerun_off_point(self, score0)
        if again is not None:
            return again
        screened = self._static_screen(score0)
        score_b = score0
        if screened is not None:
            score_b = self._adopt_pre_effect(screened.effect)[2]
        # a reference run (no effects wanted) fits the baseline sets alone; otherwise they compete
        # with the effects below, so that a fault is not absorbed into the baseline
        baseline_only = self.fit.max_effects == 0 and self.fit_baseline
        baseline_updates = self._fit_baseline_stage(score_b) if baseline_only else []
        if not self.fit_baseline:
            baseline_updates = [
                FoundEffect(
                    effect_name(e), e.label, e.parameters(), {}, 1.0, *(4 * [float("nan")]), e, "baseline"
                )
                for e in self.baseline
            ]
        if self.fit_baseline and not baseline_only:
            # the model's teeth separate where the record's DTE mean says contact (contact_mesh.py)
            baseline_updates += contact_mesh_screen(self, score_b)
        cur_raw = self.base_raw
        cur_feat = self._features(cur_raw)
        cur_score = self.cmp.score(cur_feat)
        # model-form floor of the mesh carriers: from the reference record, else re-estimated after
        # each baseline update (never below the settings' tolerance, at most 50 %)
        ctol = self.settings.tolerance
        if self.fixed_carrier_tolerance is not None:
            ctol = self.fixed_carrier_tolerance
        elif baseline_only:
            ctol = self._carrier_floor(cur_feat, cur_score)
        self.cmp.set_carrier_tolerance(ctol)
        cur_score = self.cmp.score(cur_feat)

        if "order" in self.cmp.families and self.settings.fit_gain:
            baseline_updates.append(self._sensor_entry(cur_score))
        model_form: dict[str, Any] = {
            "carrier_tolerance": float(ctol),
            "error_after_baseline": float(cur_score.error),
            "source": "reference record" if self.fixed_carrier_tolerance is not None else "this record",
        }
        self.log(f"baseline-updated model: error {cur_score.error:.3g} (carrier tolerance {ctol:.3g})")
        # with a reference's mesh stiffness held, the DTE mean gives the wear (candidates_wear_reference.py)
        wear = self._wear_screen(cur_score)
        if wear is not None:
            cur_raw, cur_feat, cur_score = self._adopt_pre_effect(wear.effect)
        accepted: list[Effect] = list(self.pre_effects)
        found: list[FoundEffect] = [f for f in (screened, wear) if f is not None]
        if found:
            found[-1].error_after = float(cur_score.error)
        not_claimed: list[FoundEffect] = []
        rejected_labels: set[str] = set()
        rounds: list[list[dict[str, Any]]] = []
        N = cur_score.n_total
        conclusion = ""
        n_rounds = 0
        baseline_round = False
        while len(accepted) < self.fit.max_effects and n_rounds < self.fit.max_effects + 2:
            n_rounds += 1
            if cur_score.error <= self.fit.stop_error:
                conclusion = (
                    "the (baseline-updated) healthy model fits to within the noise level: no effect claimed"
                    if not accepted
                    else "the remaining residual is at the noise level"
                )
                # the stop ends the search for effects; the baseline sets get one round on the model
                # with the effects found (and the transfer slopes are re-fitted if one is updated)
                if baseline_round or not self._baseline_after_stop(found):
                    break
                baseline_round = True
            self._cur_feat = cur_feat
            fits: list[CandidateFit] = []
            table: list[dict[str, Any]] = []
            used = {a_.label for a_ in (*accepted, *self.baseline)} | rejected_labels
            pool = [] if baseline_round else list(self.candidates)
            if self.fit_baseline:
                pool += self.baseline_sets
            for e in pool:
                if e.label in used or not e.applicable(self.runner.cfg):
                    continue
                try:
                    f = self._fit_candidate(e, cur_feat)
                except (ValueError, RuntimeError) as exc:
                    self.notes.append(f"{e.label}: not fitted ({exc})")
                    continue
                if f is None:
                    table.append(
                        {
                            "name": effect_name(e),
                            "label": e.label,
                            "note": "no signature in the measured features",
                        }
                    )
                    continue
                f.delta_bic = cur_score.balanced_chi2 - f.score.balanced_chi2 - f.k * math.log(N)
                excess = max(cur_score.balanced_chi2 - N, 1e-12)
                f.explained = (cur_score.balanced_chi2 - f.score.balanced_chi2) / excess
                fits.append(f)
                table.append(
                    {
                        "name": f.name,
                        "label": f.effect.label,
                        "parameters": f.effect.parameters(),
                        "delta_bic": f.delta_bic,
                        "explained_fraction": f.explained,
                        "error": f.score.error,
                    }
                )
                self.log(
                    f"  {f.effect.label}: dBIC {f.delta_bic:.4g}, explained {f.explained:.2f}, "
                    f"error {f.score.error:.3g}"
                )
            table.sort(key=lambda r: -r.get("delta_bic", -np.inf))
            rounds.append(table)
            fits.sort(key=lambda f: -f.delta_bic)
            self._round_fits = fits
            admissible = [f for f in fits if self._signature_present(f, cur_score)]
            # the best candidates are examined in turn (search_rounds.py, Sec. 8.28): one refused after
            # its verification hands the round to the next and no longer competes as the runner-up;
            # one whose own signature is absent (a tooth comb in one sideband family, bearing lines
            # below the threshold) does not take a place
            chosen = examine_round(
                self,
                fits,
                admissible,
                cur_score,
                N,
                accepted[len(self.pre_effects) :],
                not_claimed,
                rejected_labels,
            )
            if chosen is None:
                # nothing passes on the not yet updated model: the baseline is updated on Delta BIC
                # alone and the search goes on against it (confirm_updated.py, Sec. 8.31)
                chosen = stalled_round_step(
                    self, fits, cur_score, N, accepted[len(self.pre_effects) :], baseline_round
                )
            if chosen is None:
                conclusion = (
                    "no effect claimed: no candidate explains the residual beyond noise and the parsimony "
                    "penalty with its own signature and consistently with the static content"
                    if not accepted
                    else "no further effect explains the remaining residual"
                )
                if not accepted:
                    conclusion += (
                        f"; the remaining error {cur_score.error:.3g} is not explained by the library"
                    )
                break
            ver, runner_up = chosen
            p_model = _logistic(ver.delta_bic / 2)
            p_sep = _logistic((ver.delta_bic - runner_up) / 2) if np.isfinite(runner_up) else 1.0
            if isinstance(ver.effect, BASELINE_TYPES):
                # a baseline update: the machine's nominal values change, nothing is diagnosed
                baseline_updates.append(
                    FoundEffect(
                        ver.name,
                        ver.effect.label,
                        ver.effect.parameters(),
                        ver.uncertainty,
                        float(p_model),
                        float(ver.delta_bic),
                        float(ver.explained),
                        cur_score.error,
                        ver.score.error,
                        ver.effect,
                        "baseline",
                    )
                )
                self.log(
                    f"baseline {ver.effect.label} {ver.effect.parameters()}: error -> {ver.score.error:.3g}"
                )
                self._join_baseline(ver.effect)
                cur_raw = ver.raw
                cur_feat = self._accept_features(ver)
                self._refit_transfer(cur_feat)
                self._update_carrier_tolerance(cur_feat)
                cur_score = self.cmp.score(cur_feat)
                N = cur_score.n_total
                if len(accepted) == len(self.pre_effects) and not any(
                    isinstance(a_, ToothWear) for a_ in accepted
                ):
                    # without a reference: the DTE mean on the updated machine (candidates_wear_contact.py)
                    wear = self._wear_after_baseline_update(cur_score)
                    if wear is not None:
                        accepted.append(wear.effect)
                        cur_raw, cur_feat, cur_score = self._adopt_pre_effect(wear.effect)
                        wear.error_after = float(cur_score.error)
                        found.append(wear)
                continue
            found.append(
                FoundEffect(
                    ver.name,
                    ver.effect.label,
                    reported_parameters(ver.effect),
                    ver.uncertainty,
                    float(p_model * p_sep),
                    float(ver.delta_bic),
                    float(ver.explained),
                    cur_score.error,
                    ver.score.error,
                    ver.effect,
                )
            )
            self.log(
                f"accepted {ver.effect.label} {ver.effect.parameters()}: error {cur_score.error:.3g} -> "
                f"{ver.score.error:.3g}"
            )
            if isinstance(ver.effect, BearingDefect):
                self.notes.append(impulse_note(ver.effect, self._bearing_shaft_rad_s(ver.effect)))
            accepted.append(ver.effect)
            cur_raw = ver.raw
            cur_feat = self._accept_features(ver)
            if ver.baseline_set is not None:
                # fitted with the effect (candidates_tooth.py): the machine's nominal value changes
                b = ver.baseline_set
                baseline_updates.append(
                    FoundEffect(
                        effect_name(b),
                        b.label,
                        b.parameters(),
                        {},
                        float(p_model),
                        float(ver.delta_bic),
                        float(ver.explained),
                        cur_score.error,
                        ver.score.error,
                        b,
                        "baseline",
                    )
                )
                self.log(f"baseline {b.label} {b.parameters()} with {ver.effect.label}")
                self._join_baseline(b)
                self._refit_transfer(cur_feat)
                self._update_carrier_tolerance(cur_feat)
            cur_score = self.cmp.score(cur_feat)
        else:
            conclusion = f"stopped after {self.fit.max_effects} effects"
        # the wheels' pitch deviations on the model with the effects found, as a baseline (pitch_baseline.py)
        cur_raw, cur_feat, cur_score = pitch_round(
            self, accepted, baseline_updates, cur_raw, cur_feat, cur_score
        )
        model_after = self.runner.outputs(cur_raw)
        model_form["error_after_effects"] = float(cur_score.error)
        model_form["carrier_tolerance"] = float(getattr(self.cmp, "carrier_tolerance", ctol))
        if "order" in self.cmp.families and self.settings.fit_gain:
            baseline_updates = [b for b in baseline_updates if b.name != "sensor_transfer"]
            baseline_updates.append(self._sensor_entry(cur_score))
        if speed_errors is not None:
            baseline_updates.insert(0, speed_entry(self.speed, *speed_errors))
        if self.torque_correction is not None:
            baseline_updates.insert(0, torque_entry(self.torque_correction))
        result = CalibrationResult(
            self.m,
            found,
            score0,
            cur_score,
            rounds,
            conclusion,
            self._plain(base_out, score0),
            self._plain(model_after, cur_score),
            base_out,
            model_after,
            self.cmp,
            self.notes,
            self.runner.n_runs,
            baseline_updates,
            self.baseline_source,
            not_claimed,
            model_form,
            self.baseline_reference,
            self.step_choice.as_dict() if self.step_choice is not None else {},
        )
        # where the final residual is (residual_trace.py): reads the state, changes nothing above
        result.residual_trace = trace_residual(
            self, cur_feat, cur_score, rounds, [f.label for f in found], model_after, score0.error
        )
        # mains lines off the orders, or on one and unexplained (mains_check.py): issues only
        self.m.issues.extend(mains_issues(self, result.residual_trace, model_after))
        # a wear read from the DTE mean: a DTE zero offset reads the same (dte_zero.py): issues only
        self.m.issues.extend(dte_zero_issues(self, found))
        # a claim that leaves content the model lacks in its own signature is not confident (claim_check.py)
        apply_claim_checks(result, self.runner.cfg)
        # baseline parameters at the bounds of their plausible range: named (baseline_bounds.py)
        result.notes.extend(
            baseline_bound_notes(
                baseline_updates, self.settings.gain_bounds, self.settings.transfer_slope_bounds
            )
        )
        # mains pickup on a shaft order on one or two channels: diagnosed again without it (mains_repair.py)
        return rerun_without_pickup(self, result, cur_feat, cur_score)

    def _prepare_comparison(self) -> None:
        """After the setup: the rattle rules' order uncertainties where the healthy model's teeth separate,
        a damaged tooth's path in contact, and the transfer slopes fitted on the healthy (baseline) model
        and held (``benchmarks/crack_baseline_trace.py`` brings a calibrator to its first round so)."""
        self._at_rattle = False
        if self.rattle_rules:
            # where the teeth separate: honest order uncertainties (features_rattle.py)
            self._at_rattle = apply_rattle_uncertainty(
                self.cmp,
                self._features(self.base_raw),
                lambda e: self._features(self._raw((e,))),
                self.base_contact_loss,
                self.m.issues,
            )
        if self._at_rattle:
            # a worn machine stays on the healthy machine's rattle branch (candidates_wear_rattle.py)
            self.runner.grown_effects = (ToothWear,)
        self._tooth_path = None if self._at_rattle else contact_tooth_path(self)
        self._refit_transfer(self._features(self.base_raw))

    def _plain(self, model: np.ndarray, score: Score) -> dict[str, dict[str, float]]:
        fs = self.m.sample_rate_hz
        lag = int(0.5 * fs / self.cmp.mesh_hz) if self.cmp.mesh_hz else int(0.002 * fs)
        return {
            c: time_and_spectrum_errors(self.m.data[: model.shape[0], i], model[:, i], fs, max(lag, 1))
            for i, c in enumerate(self.cmp.names)
        }


def _check_channels(measurement: Measurement, cfg: Any) -> None:
    """Every measured channel must be an output of the rig's model (e.g. ``mesh: 2`` needs a second
    mesh): MeasurementError naming the file, the column and what the rig offers."""
    from gear_rotor_sim.calibration.measurement import MeasurementError
    from gear_rotor_sim.calibration.residual import cached_system
    from gear_rotor_sim.simulator import Simulator

    names = {n for n, _ in Simulator.available_channels(cfg, cached_system)}
    for c in measurement.channels:
        model = housing_source(c.model_channel) or c.model_channel
        if model not in names:
            raise MeasurementError(
                f"{measurement.source}: column {c.column!r} ({c.model_channel}) is not an output of "
                f"gearbox {measurement.gearbox!r}: it has {len(cfg.meshes)} mesh(es) (mesh: 1.."
                f"{len(cfg.meshes)}), {len(cfg.bearings)} bearings and {cfg.n_nodes} nodes"
            )


def calibrate(measurement: Measurement, cfg: Any = None, **kw: Any) -> CalibrationResult:
    """Convenience wrapper: ``Calibrator(measurement, cfg, **kw).run()``."""
    return Calibrator(measurement, cfg, **kw).run()
