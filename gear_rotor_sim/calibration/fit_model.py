"""The calibrator's model: its runs with the baseline and the accepted effects, their features
(a fitted path or correction where ``fault_path.py`` applies) and the healthy run it starts from
(``_setup``, the step count of ``model_steps.py``). A mixin of
:class:`~gear_rotor_sim.calibration.fit.Calibrator` (moved from ``fit.py`` in session 16, unchanged).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.candidates_misalignment import (
    axial_chi2,
    misalignment_path,
)
from gear_rotor_sim.calibration.fault_path import (
    channels_chi2,
    with_path,
)
from gear_rotor_sim.calibration.fit_types import (
    CandidateFit,
)
from gear_rotor_sim.calibration.model_steps import StepChoice, converged_steps_per_mesh, recorded_steps
from gear_rotor_sim.calibration.residual import (
    HousingSensor,
    ModelFeatures,
    housing_source,
)
from gear_rotor_sim.faults import (
    BearingGeometry,
    Effect,
    GearMisalignment,
    ToothDamage,
)

#: largest contact-loss fraction of the healthy model run for the exact order features, the
#: accelerations from the velocities and the envelope-band fallback (docs/history/calibration_sessions.md
#: Sec. 8.18): measured where the teeth stay in contact; where they separate (8000 rpm) the first two raised
#: the healthy record's floor against the 2000 rpm reference (2.24 -> 3.26 -> 4.04) under the rattle rules
#: of features_rattle.py, which were built on the resampled features and direct accelerations
EXACT_ORDERS_MAX_CONTACT_LOSS = 0.01


class ModelAccess:
    """Model runs and features of the calibrator (mixin of ``Calibrator``)."""

    def _envelope_max(self, cfg: Any, geom: BearingGeometry) -> float:
        if self.settings.envelope_max_hz is not None:
            return self.settings.envelope_max_hz
        from gear_rotor_sim.system import shaft_rates_hz

        f = max(shaft_rates_hz(cfg, self.m.operating_point.speed_rpm))
        return 2.2 * geom.multiples()["bpfi"] * f

    def _features(self, raw: np.ndarray) -> ModelFeatures:
        return self.cmp.features(self.runner.outputs(raw))

    def _chi2(self, feats: ModelFeatures) -> float:
        return self.cmp.score(feats).balanced_chi2

    def _path_mask(self, e: Effect | None) -> np.ndarray | None:
        """Channels whose transfer of ``e``'s signature is a fitted nuisance where the teeth separate
        (``fault_path.py``): the radial bearing channels for a damaged tooth, every channel but the axial
        forces for a misaligned wheel (``candidates_misalignment.py``); None otherwise. Also against a
        held reference baseline (docs/history/calibration_sessions.md Sec. 8.17: a tooth must then gain at
        the mesh)."""
        mask = getattr(self.cmp, "fault_path", None)
        if mask is None:
            # in contact: a damaged tooth's path only (candidates_tooth_path.py, Sec. 8.35)
            return self._tooth_path if isinstance(e, ToothDamage) else None
        if isinstance(e, GearMisalignment):
            return misalignment_path(self.cmp.names)
        return mask if isinstance(e, ToothDamage) else None

    def _full_features(self, raw: np.ndarray, e: Effect | None = None) -> ModelFeatures:
        """Features of a full run plus the correction left by an accepted effect whose bearing-channel
        part was transferred by fitted factors; for ``e`` such an effect, its own change from the
        current model transferred likewise (``fault_path.py``)."""
        f = self._features(raw)
        corr = getattr(self, "_feat_correction", None)
        if corr is not None:
            f = f.combo(corr, 1.0)
        mask = self._path_mask(e)
        if mask is not None:
            f, self._path_a = with_path(self.cmp, self._cur_feat, f, mask, self._banded(e))
        return f

    def _banded(self, e: Effect | None) -> bool:
        """Whether ``e``'s path factors are fitted per band (a damaged tooth with
        ``FitSettings.tooth_path_bands``; ``fault_path.path_factors``)."""
        return isinstance(e, ToothDamage) and self.fit.tooth_path_bands

    def _param_chi2(self, feats: ModelFeatures, e: Effect) -> float:
        """Objective of a candidate's main parameter: the balanced chi^2, or where ``e``'s path to some
        channels is a fitted transfer (``fault_path.py``) the order chi^2 of the other channels only
        (the channels at the mesh, the axial forces): a fitted path corrects amplitude and phase, not
        the shape of the model's response over the comb, which on the independent 8000 rpm record
        against the 2000 rpm reference pulled a pinion tooth's depth to 0.13 for 0.4 (the bearing
        forces' comb misfit 5.2e3 at depth 0.1, 5.3e4 at 0.3-0.5 with the factor fitted)."""
        if isinstance(e, GearMisalignment) and self.fit.misalignment_axial:
            return axial_chi2(self, feats)
        mask = self._path_mask(e)
        if mask is None:
            return self._chi2(feats)
        return channels_chi2(self.cmp, feats, ~mask)

    def _raw(self, effects: Sequence[Effect]) -> np.ndarray:
        """Raw model channels of the baseline-updated machine (at the screened temperature) with
        ``effects``."""
        return self.runner.force_signals((*self.baseline, *self.pre_effects, *effects))

    def _join_baseline(self, effect: Effect) -> None:
        """Make ``effect`` part of the machine's baseline: the signature caches dropped, the base run
        redone with it."""
        self.baseline.append(effect)
        self._sig_cache.clear()
        self._sig_checked.clear()
        self.base_raw = self._raw(())

    def _setup(self) -> np.ndarray:
        """Healthy nominal model run; envelope bands and housing-sensor frequencies. Model outputs."""
        self._sig_cache: dict[str, ModelFeatures] = {}
        self._sig_checked: dict[tuple, bool] = {}
        self.base_raw = self._raw(())
        self.base_contact_loss = float(self.runner.last_contact_loss)
        if not (self.reference_numerics and self.base_contact_loss <= EXACT_ORDERS_MAX_CONTACT_LOSS):
            # where the teeth separate the order features stay those of the linear resampling and
            # the accelerations the simulator's own (docs/history/calibration_sessions.md Sec. 8.18)
            self.cmp.set_exact_orders(False)
            self.cmp.band_fallback = False
            if self.runner.accel_from_velocity or self.runner.exact_modal_map is not None:
                self.runner.accel_from_velocity = False
                self.runner.exact_modal_map = None
                self.base_raw = self._raw(())
        at_bearing = [c for c, n in enumerate(self.cmp.names) if n.startswith("bearing")]
        own = recorded_steps(self.m) if self.auto_steps else None
        if own is not None:
            self._take_recorded_steps(own)
        elif self.auto_steps and self.cmp.mesh_hz and self.cmp.shafts and at_bearing:
            self._choose_steps(at_bearing)
        base_out = self.runner.outputs(self.base_raw)
        self.cmp.set_baseline(base_out)
        if self.runner.sensors is not None and any(housing_source(c) for c in self.runner.channels):
            for c, band in zip(self.runner.channels, self.cmp.bands, strict=False):
                if housing_source(c):
                    old = self.runner.sensors.get(c, HousingSensor())
                    fn = float(math.sqrt(band[0] * band[1]))
                    self.runner.sensors[c] = dataclasses.replace(old, frequency_hz=fn)
                    self.notes.append(
                        f"{c}: housing resonance set to {fn:.0f} Hz (centre of the most impulsive band "
                        f"{band[0]:.0f}-{band[1]:.0f} Hz)"
                    )
            base_out = self.runner.outputs(self.base_raw)
        return base_out

    def _take_recorded_steps(self, n: int) -> None:
        """The model runs at the step count the record was simulated with (``model_steps.recorded_steps``,
        docs/history/calibration_sessions.md Sec. 8.76), reported in ``model_steps`` and ``notes``."""
        self.step_choice = StepChoice(n, True, [], from_record=True)
        if self.runner.steps_per_mesh != n:
            self.runner.steps_per_mesh = n
            self.base_raw = self._raw(())
            self.base_contact_loss = float(self.runner.last_contact_loss)
        msg = (
            f"model steps per mesh period: {n}, the record's own (its metadata names the simulator that "
            "made it; its non-synchronous part is that simulator's numerical residue, not noise)"
        )
        self.notes.append(msg)
        self.log(msg)

    def _choose_steps(self, channels: list[int]) -> None:
        """Steps per mesh period of every model run from the healthy model's own convergence at this
        operating point (``model_steps.py``, docs/history/calibration_sessions.md Sec. 8.24), from the count
        set at construction (32; 64 against a held reference), judged at ``channels`` (those measured at a
        bearing: the envelope family's inputs). A record without such a channel keeps the count."""

        def run(n: int) -> np.ndarray:
            self.runner.steps_per_mesh = n
            return self.runner.outputs(self._raw(()))

        choice = converged_steps_per_mesh(
            run,
            self.m.data,
            channels,
            self.cmp.names,
            self.m.sample_rate_hz,
            [sh.ratio * self.cmp.speed_hz for sh in self.cmp.shafts],
            start=self.runner.steps_per_mesh,
        )
        self.step_choice = choice
        self.runner.steps_per_mesh = choice.steps_per_mesh
        self.base_raw = self._raw(())
        self.base_contact_loss = float(self.runner.last_contact_loss)
        last = choice.checks[-1] if choice.checks else {}
        msg = (
            f"model steps per mesh period: {choice.steps_per_mesh} (healthy model's non-synchronous part "
            f"against {last.get('finer')} steps: worst {last.get('worst_ratio', 0.0):.3g} x the noise at "
            f"{last.get('worst_channel')}"
            + ("" if choice.converged else "; not converged at the finest count tried")
            + ")"
        )
        self.notes.append(msg)
        self.log(msg)

    def _refit_transfer(self, feats: ModelFeatures) -> None:
        """Fit the transfer slopes on the current healthy/baseline model, then hold them."""
        self.cmp.fix_transfer(None)
        self.cmp.fix_transfer(self.cmp.score(feats).slopes)

    def _accept_features(self, ver: CandidateFit) -> ModelFeatures:
        """Features of the model with an accepted candidate (its verified full run, with a bearing-channel
        transfer where ``fault_path.py`` applies); keeps the correction for later full runs."""
        feats = ver.feats if ver.feats is not None else self._full_features(ver.raw)
        self._feat_correction = feats.combo(self._features(ver.raw), -1.0)
        return feats
