"""Checks of a candidate's own signature and consistency: a damaged tooth's order comb, a bearing
defect's envelope lines and their prominence, parameters at a bound, the static content. A mixin
of :class:`~gear_rotor_sim.calibration.fit.Calibrator` (moved from ``fit.py`` in session 16,
unchanged).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from gear_rotor_sim.calibration.candidates_wear import periodic_signature_present, wear_static_inconsistency
from gear_rotor_sim.calibration.comb_families import comb_gain_by_family, narrow_comb_reason
from gear_rotor_sim.calibration.fault_path import (
    mesh_comb_gain,
    mesh_comb_gain_by_family,
)
from gear_rotor_sim.calibration.features_bearing import modulation_sidebands_hz
from gear_rotor_sim.calibration.features_envelope_noise import envelope_excess_share
from gear_rotor_sim.calibration.fit_types import (
    CandidateFit,
)
from gear_rotor_sim.calibration.residual import (
    Score,
)
from gear_rotor_sim.faults import (
    BearingDefect,
    Effect,
    GearMisalignment,
    TemperatureOffset,
    ToothDamage,
    ToothWear,
)


class Verification:
    """Signature and consistency checks of the calibrator (mixin of ``Calibrator``)."""

    def _tooth_comb_check(self, fit: CandidateFit, cur: Score) -> bool:
        """A damaged tooth must improve the order comb of its own wheel's shaft significantly and
        more than that of the mating wheel (the comb tells the wheel; a tooth candidate that gains
        on the envelope or on the other shaft explains something else)."""
        e = fit.effect
        if fit.feats is None or "order" not in self.cmp.families or len(self.cmp.shafts) < 2:
            return True
        cfg = self.runner.cfg
        mesh = cfg.meshes[e.mesh - 1]
        node0 = cfg.gear(mesh.pinion if e.wheel == "pinion" else mesh.gear).node0
        shaft_name = cfg.shafts[cfg.shaft_of_node(node0)].name
        names = [sh.name for sh in self.cmp.shafts]
        if shaft_name not in names:
            return True
        own = names.index(shaft_name)
        before = self.cmp.comb_chi2(self._cur_feat, cur)
        gain = before - self.cmp.comb_chi2(fit.feats, fit.score)
        ok = gain[own] > self.fit.bic_threshold + math.log(self.n_total)
        # the mating wheel's tooth candidate of this round: the true wheel explains its own comb and
        # what leaks into the other shaft's synchronous average; the wrong one cannot do both
        rival = next(
            (
                f
                for f in getattr(self, "_round_fits", [])
                if isinstance(f.effect, ToothDamage)
                and f.effect.mesh == e.mesh
                and f.effect.wheel != e.wheel
                and f.feats is not None
            ),
            None,
        )
        rival_gain = (
            float(np.sum(before - self.cmp.comb_chi2(rival.feats, rival.score)))
            if rival is not None
            else -np.inf
        )
        if ok and float(np.sum(gain)) < rival_gain:
            ok = False
        if ok and self._path_mask(e) is not None:
            # where its path to the other channels is fitted, the tooth is named by the channels at the
            # mesh; it must be seen there too (fault_path.mesh_comb_gain)
            g_mesh = mesh_comb_gain(self.cmp, self._cur_feat, fit.feats, own)
            if math.isfinite(g_mesh) and g_mesh <= self.fit.bic_threshold + math.log(self.n_total):
                self.notes.append(
                    f"{e.label}: not claimed, the comb of its wheel's shaft at the channels at the mesh "
                    f"(DTE) gains {g_mesh:.3g} in chi2: its gain elsewhere ({gain[own]:.3g}) is model-form "
                    "content of channels whose path is fitted or uncertain, not a damaged tooth"
                )
                ok = False
        if ok:
            # a damaged tooth raises the whole comb; one sideband family alone is a response component
            # at one frequency (e.g. a rattle subharmonic locked to a shaft order): comb_families.py;
            # where the teeth separate rattle components lock onto several shaft orders at once, so the
            # fundamental family must gain with the others (docs/history/calibration_sessions.md Sec. 8.16)
            fams = comb_gain_by_family(self.cmp, (self._cur_feat, cur), (fit.feats, fit.score), own)
            thr = self.fit.bic_threshold + math.log(self.n_total)
            at_rattle = bool(getattr(self, "_at_rattle", False))
            by_family = {j: round(v) for j, v in fams.items()}
            self.log(f"  {e.label}: comb gain by sideband family {by_family}")
            why = narrow_comb_reason(
                fams, thr, self.fit.min_family_share, self.fit.min_comb_families, at_rattle
            )
            if not why and self._path_mask(e) is not None:
                # where its path is fitted the tooth is named at the mesh, and seen there as a tooth:
                # a broad comb with its fundamental, not the gain of two rattle components
                # (fault_path.mesh_comb_gain_by_family; docs/history/calibration_sessions.md Sec. 8.21)
                mfams = mesh_comb_gain_by_family(self.cmp, self._cur_feat, fit.feats, own)
                self.log(f"  {e.label}: at the mesh (DTE) {dict((j, round(v)) for j, v in mfams.items())}")
                why = narrow_comb_reason(
                    mfams, thr, self.fit.min_family_share, self.fit.min_comb_families, at_rattle
                )
                if why:
                    why = "at the channels at the mesh (DTE), " + why
            if why:
                self.notes.append(f"{e.label}: not claimed, {why} (comb_families.py)")
                ok = False
        # share of the comb's own excess it explains (its relative signature), used next to the
        # share of the whole excess: model-form misfit of the carriers must not mask a comb that
        # the tooth explains
        excess = float(np.sum(before)) - self.cmp.comb_count()
        fit.comb_explained = float(np.sum(gain)) / excess if excess > 0 else 0.0
        if not ok:
            self.notes.append(
                f"{e.label}: not claimed, comb gain on its wheel's shaft {gain[own]:.3g}, on all shafts "
                f"{float(np.sum(gain)):.3g} (the other wheel's tooth: {rival_gain:.3g})"
            )
        return bool(ok)

    def _signature_present(self, fit: CandidateFit, cur: Score) -> bool:
        """Bearing defects must improve their own characteristic envelope lines significantly; a damaged
        tooth its own wheel's order comb."""
        e = fit.effect
        if isinstance(e, ToothWear | GearMisalignment):
            # mesh-periodic effects: evidence on the orders and channel means (candidates_wear.py)
            key = ("periodic", e.label, id(cur))
            if key not in self._sig_checked:
                self._sig_checked[key] = periodic_signature_present(self, fit, cur)
            return self._sig_checked[key]
        if isinstance(e, ToothDamage):
            key = ("tooth", e.label, id(cur))
            if key not in self._sig_checked:
                self._sig_checked[key] = self._tooth_comb_check(fit, cur)
            return self._sig_checked[key]
        if not isinstance(e, BearingDefect) or "envelope" not in self.cmp.families:
            return True
        key = ("signature", e.label, id(cur))
        if key in self._sig_checked:
            return self._sig_checked[key]
        self._sig_checked[key] = ok = self._signature_check(e, fit, cur)
        return ok

    def _signature_check(self, e: BearingDefect, fit: CandidateFit, cur: Score) -> bool:
        from gear_rotor_sim.system import shaft_speed_ratios

        cfg = self.runner.cfg
        node0 = cfg.bearings[e.bearing - 1].node0
        ratio = abs(float(shaft_speed_ratios(cfg)[cfg.shaft_of_node(node0)]))
        mask = self.cmp.line_mask(e.key_frequencies_hz(ratio * self.m.operating_point.speed_rpm / 60.0))
        gain = sum(
            float(np.sum(a[mask] - b[mask]))
            for a, b in zip(cur.envelope_r2, fit.score.envelope_r2, strict=True)
        )
        if gain <= self.fit.bic_threshold + math.log(self.n_total):
            return False
        ref = 0.1 * e.specs[0].upper
        model = self._cur_feat.combo(self._signature(e.with_parameters(force_n=ref)), e.force_n / ref)
        predicted = [self.cmp.envelope_model(model, c) for c in range(self.cmp.nc)]
        shaft_hz = ratio * self.m.operating_point.speed_rpm / 60.0
        prominence = self._line_prominence(
            e.key_frequencies_hz(shaft_hz), predicted, modulation_sidebands_hz(e, shaft_hz)
        )
        if prominence < self.fit.line_prominence:
            self.notes.append(
                f"{e.label}: its lines are present but weak (peak {prominence:.2f} x the local envelope "
                f"floor < {self.fit.line_prominence:g}): below the detection threshold, not claimed"
            )
            return False
        fit.comb_explained = envelope_excess_share(cur, fit.score)
        return True

    def _line_prominence(
        self, freqs: Sequence[float], predicted: list[np.ndarray], sidebands: Sequence[float] = ()
    ) -> float:
        """Largest ratio of a measured envelope line to its local floor, over lines and channels.

        The floor is the median of the measured bins within +-25 % of the line frequency where the
        fitted candidate itself predicts no line (its sidebands and shaft-rate lines excluded), the
        line's own +-3 % excluded. Where fewer than 3 such bins are left (an inner race's shaft-rate
        sidebands with a broad transfer), the floor is taken at the half of the bins (at least 3)
        where it predicts the least, no longer at all the bins: with the sidebands
        in the floor the BPFI line of the independent 3000 rpm inner-race record read 1.5-2.9 x the
        floor against the held 2000 rpm baseline and 6.5 x without it (same measured spectrum, only
        the predicted sidebands' level decided which bins were the floor). The bins of the defect's own
        modulation sidebands (``sidebands``: offsets from the kinematics,
        ``features_bearing.modulation_sidebands_hz``) are left out first where at least 3 others
        remain, whatever the candidate predicts there (docs/history/calibration_sessions.md Sec. 8.13).
        """
        f = self.cmp.env_f
        best = 0.0
        for fk in freqs:
            own = self.cmp.line_mask([fk])
            near = (np.abs(f - fk) <= 0.25 * fk) & (np.abs(f - fk) > 0.03 * fk) & ~own
            if not own.any():
                continue
            # the defect's own modulation sidebands (kinematic, features_bearing) are not its floor
            side = self.cmp.line_mask([fk + d for d in sidebands])
            if np.count_nonzero(near & ~side) >= 3:
                near &= ~side
            for d, pm, fl in zip(self.cmp.d_env, predicted, self.cmp.env_floor, strict=True):
                if not fl > 0:  # channel left out of the envelope features
                    continue
                neigh = near & (pm < 0.5 * fl)
                idx = np.flatnonzero(near)
                if neigh.sum() < 3 and idx.size >= 3:
                    # the half of the bins (at least 3) where the candidate predicts the least
                    neigh = np.zeros_like(near)
                    neigh[idx[np.argsort(pm[idx], kind="stable")[: max(3, (idx.size + 1) // 2)]]] = True
                if neigh.sum() < 3:
                    continue
                floor = float(np.median(d[neigh]))
                if floor > 0:
                    best = max(best, float(np.max(d[own])) / floor)
        return best

    def _at_bound(self, e: Effect) -> list[str]:
        """Fitted parameters at (within 1 % of the range of) a bound that limits them."""
        out = []
        for i, spec in enumerate(e.specs):
            if spec.role not in ("amplitude", "scalar"):
                continue
            lo, hi = self._bounds(e) if i == 0 else (spec.lower, spec.upper)
            v = float(getattr(e, spec.name))
            tol = 0.01 * (hi - lo)
            if v >= hi - tol or (spec.role == "scalar" and v <= lo + tol):
                out.append(spec.name)
        return out

    def _consistency(self, ver: CandidateFit, cur: Score) -> str:
        """Why an otherwise accepted candidate is physically inconsistent ('' if consistent).

        The static family (channel means) must not get worse beyond its own uncertainty: a
        temperature offset must agree with the mean axial bearing force and DTE where observed.
        """
        wear_why = wear_static_inconsistency(ver, cur)
        if wear_why:
            return wear_why
        if "static" not in ver.score.chi2 or "static" not in cur.chi2:
            if isinstance(ver.effect, TemperatureOffset):
                self.notes.append(
                    "temperature_offset: no static channel (bearing force, DTE) observed; judged on the "
                    "dynamic features only"
                )
            return ""
        before, after = cur.chi2["static"], ver.score.chi2["static"]
        n_static = max(ver.score.n["static"], 1)
        if after > before + 9.0 * n_static:
            worst = max(
                ver.score.per_channel.get("static", {}).items(), key=lambda kv: kv[1], default=("", 0)
            )
            return (
                f"it contradicts the static content (channel means): chi2 {before:.3g} -> {after:.3g}, "
                f"worst {worst[0]} at {worst[1]:.3g} sigma"
            )
        if isinstance(ver.effect, TemperatureOffset) and ver.score.static_r.size:
            r = np.abs(ver.score.static_r)
            if float(np.max(r)) > 5.0:
                return (
                    f"the static channel means disagree with the fitted temperature (largest residual "
                    f"{float(np.max(r)):.3g} sigma)"
                )
        return ""
