"""Refinement of an accepted candidate on full simulations: the main parameter's parabola steps, the
damaged tooth and its neighbours, a bearing defect's shaft-path share, a tooth's path and scatter
nuisances and their notes. A mixin of :class:`~gear_rotor_sim.calibration.fit.Calibrator` (moved
from ``fit.py`` in session 16, unchanged).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from gear_rotor_sim.calibration.candidates_bearing import fit_shaft_path_share, share_note
from gear_rotor_sim.calibration.candidates_misalignment import (
    fit_contact_width,
)
from gear_rotor_sim.calibration.candidates_tooth import (
    ratio_depth_applies,
    ratio_depth_in_contact,
    refine_depth_by_ratios,
)
from gear_rotor_sim.calibration.candidates_tooth_dte import (
    dte_depth_applies,
    refine_depth_by_dte,
    take_dte_depth,
)
from gear_rotor_sim.calibration.candidates_tooth_index import (
    decisive,
    index_note,
    low_order_index_applies,
    teeth_to_compare,
)
from gear_rotor_sim.calibration.candidates_tooth_path import (
    low_order_mesh_chi2,
    low_order_shaft,
)
from gear_rotor_sim.calibration.candidates_wear_contact import (
    wear_depth_from_mean_in_round,
)
from gear_rotor_sim.calibration.envelope_scatter import scatter_applies
from gear_rotor_sim.calibration.fault_path import (
    channels_chi2,
    mesh_channels,
    with_path,
)
from gear_rotor_sim.calibration.fit_types import (
    CandidateFit,
)
from gear_rotor_sim.calibration.residual import (
    ModelFeatures,
    Score,
)
from gear_rotor_sim.calibration.tooth_band_shape import band_shape_note, shape_tooth
from gear_rotor_sim.faults import (
    BearingDefect,
    Effect,
    GearEccentricity,
    GearMisalignment,
    MassUnbalance,
    ShaftCrack,
    ShaftMisalignment,
    TemperatureOffset,
    ToothDamage,
    ToothWear,
)


class Refinement:
    """Refinement and verification on full runs (mixin of ``Calibrator``)."""

    def _bounds(self, e: Effect) -> tuple[float, float]:
        """Effective bounds of the main parameter (a temperature offset stays in the material range)."""
        spec = e.specs[0]
        if isinstance(e, TemperatureOffset):
            mat = next(iter(self.runner.cfg.materials.values()))
            t = self.m.operating_point.temperature_c
            return (
                max(spec.lower, float(np.min(mat.temperatures_c)) - t),
                min(spec.upper, float(np.max(mat.temperatures_c)) - t),
            )
        return spec.lower, spec.upper

    def _bearing_path_share(self, ver: CandidateFit, accepted: list[Effect]) -> CandidateFit:
        """The verified bearing defect ``ver`` with the share of its impact's modelled shaft path fitted
        as a nuisance (``candidates_bearing.py``); ``ver`` itself where the share does not beat the full
        path by ``ln N``, first on the superposed responses and then on a full simulation."""
        sp = fit_shaft_path_share(self, ver.effect, accepted, self.fit.bearing_slip_fit)
        if not sp.taken:
            return ver
        raw = self._raw((*accepted, sp.effect))
        f = self._full_features(raw)
        score = self.cmp.score(f)
        if ver.score.balanced_chi2 - score.balanced_chi2 <= math.log(max(self.n_total, 2)):
            return ver
        self.notes.append(share_note(sp))
        return dataclasses.replace(ver, effect=sp.effect, raw=raw, score=score, feats=f)

    def _refine(self, fit: CandidateFit, accepted: list[Effect]) -> CandidateFit:
        """Refine the main scalar parameter with full simulations (parabola through three runs).

        Linear effects (amplitude/phase, bearing impulse force) are exact by superposition and only
        verified; wear (backlash: nonlinear once contact is lost), temperature, stiffness and tooth
        damage are refined. Returns the best verified fit (``raw`` from a full simulation).
        """
        e = fit.effect
        # a shaft crack: its loss is read on the low orders (candidates_crack.py, LOW_ORDER_LOSS) and its
        # load's growth with the loss is analytic; the full runs' chi^2 would mix its dynamic share's
        # model-form rest back into it (Sec. 8.64), so it is verified only
        if isinstance(e, GearEccentricity | MassUnbalance | ShaftMisalignment | BearingDefect | ShaftCrack):
            raw = self._raw((*accepted, e))
            f = self._full_features(raw)
            ver = dataclasses.replace(fit, raw=raw, score=self.cmp.score(f), feats=f)
            if isinstance(e, BearingDefect) and self.fit.bearing_shaft_path:
                ver = self._bearing_path_share(ver, accepted)
            return ver
        if isinstance(e, ToothWear) and self.fit.wear_mean_in_round:
            # without a reference: the depth from the DTE mean where it reads one (candidates_wear_contact.py)
            at_mean = wear_depth_from_mean_in_round(self, fit, accepted)
            if at_mean is not None:
                return at_mean
        if isinstance(e, ToothDamage) and not (
            self._path_mask(e) is not None and len(self.runner.cfg.meshes) == 1
        ):
            # on a single mesh the shifted signature is exact (whole hunting periods), so the check on
            # full runs only repeats the search at one depth; where the teeth separate that depth's
            # DTE comb prefers a neighbour of the tooth the two-depth search found (8000 rpm record,
            # pinion tooth 7 at depth 0.435: tooth 6 by 3 % of the DTE's chi^2; fault_path.py)
            e = self._verify_tooth(e, accepted)
        main = e.specs[0]
        lower, upper = self._bounds(e)
        x0 = float(e.parameters()[main.name])
        span = upper - lower
        if isinstance(e, TemperatureOffset):
            h = 0.04 * span
        else:
            h = 0.04 * max(abs(x0), 0.1 * span)
        pts: list[tuple[float, float, np.ndarray]] = []

        def run(x: float) -> None:
            x = float(np.clip(x, lower, upper))
            if any(abs(x - p[0]) < 1e-9 for p in pts):
                return
            raw = self._raw((*accepted, e.with_parameters(**{main.name: x})))
            pts.append((x, self._param_chi2(self._full_features(raw, e), e), raw))

        run(x0)
        if isinstance(e, TemperatureOffset) and self.fit.refine_steps > 0:
            # the grid interpolant is coarse in temperature: bounded Brent on full simulations
            def obj(x: float) -> float:
                run(x)
                return min(p[1] for p in pts if abs(p[0] - float(np.clip(x, lower, upper))) < 1e-9)

            a, b = max(lower, x0 - 0.15 * span), min(upper, x0 + 0.15 * span)
            minimize_scalar(obj, bounds=(a, b), method="bounded", options={"xatol": 0.5, "maxiter": 8})
        elif self.fit.refine_steps > 0:
            run(x0 + h)
            x1 = pts[-1][0]
            if len(pts) == 2 and pts[1][1] > pts[0][1]:
                run(x0 - h)
            else:
                run(x1 + h)
            # successive parabolas through the three best runs (at most ``refine_steps`` more runs)
            for _ in range(self.fit.refine_steps):
                best3 = sorted(pts, key=lambda t: t[1])[:3]
                xs = np.array([p[0] for p in best3])
                vs = np.array([p[1] for p in best3])
                if len(best3) < 3 or np.ptp(xs) <= 0:
                    break
                xb0 = float(xs[0])
                c2 = np.polyfit(xs - xb0, vs, 2)
                if c2[0] <= 0:
                    # no curvature: step downhill from the best run
                    xq = xb0 + (2 * h if c2[1] < 0 else -2 * h)
                else:
                    xq = xb0 + float(np.clip(-c2[1] / (2 * c2[0]), -4 * h, 4 * h))
                n_before = len(pts)
                run(xq)
                if len(pts) == n_before or abs(xq - xb0) < 1e-3 * max(h, 1e-12):
                    break
        xb, _, rb = min(pts, key=lambda t: t[1])
        eff = e.with_parameters(**{main.name: xb})
        if isinstance(eff, ToothDamage):
            fb = self._tooth_features(rb, eff, accepted)
        else:
            fb = self._full_features(rb, eff)
            self._path_note(eff, f"{main.name} {xb:.3g}")
        # in contact with a DTE channel the depth is read from the DTE's low sideband families,
        # transfer-free and below the carriers' dynamics, at the mesh scale the ratio depth's step takes
        # (candidates_tooth_dte.py, Sec. 8.25)
        by_dte = isinstance(eff, ToothDamage) and dte_depth_applies(self)
        if isinstance(eff, ToothDamage) and ratio_depth_applies(self):
            # without a reference the mesh stiffness scale is not identified: the depth is read from
            # the scale-free sideband energy ratios of the named tooth (candidates_tooth.py)
            rd = refine_depth_by_ratios(self, eff, accepted)
            if rd is not None:
                pre = (*([rd.mesh_set] if rd.mesh_set is not None else []), *accepted)
                fr = self._tooth_features(rd.raw, rd.effect, pre)
                score = self.cmp.score(fr)
                chi_abs = self.cmp.score(fb).balanced_chi2
                # the ratio depth with the mesh scale it implies must explain the whole record better
                # than the absolute depth at the current scale (BIC, one parameter more)
                penalty = math.log(self.n_total) if rd.mesh_set is not None else 0.0
                # where the teeth separate a mesh scale moves the whole rattle response: the tooth must
                # explain the record beyond the healthy model at that scale (the temperature record at
                # 8000 rpm took a pinion tooth of depth 0.144 with a mesh x1.62 that carried the gain)
                own = (
                    self._gain_beyond_baseline(pre, score, fit.k)
                    if rd.mesh_set is not None and not ratio_depth_in_contact(self)
                    else None
                )
                if own is not None:
                    self.notes.append(
                        f"{rd.effect.label} at the ratio depth {rd.effect.depth:.3g}: beyond the healthy "
                        f"model at the mesh scale x{rd.mesh_set.stiffness_scale:.3g} it explains "
                        f"{own[1]:.2f} of the excess (dBIC {own[0]:.4g})"
                    )
                if (
                    score.balanced_chi2 + penalty < chi_abs
                    and own is not None
                    and not (own[0] > self.fit.bic_threshold and own[1] >= self.fit.min_explained)
                ):
                    self.notes.append(
                        f"{eff.label}: the ratio depth {rd.effect.depth:.3g} is not used: the mesh scale "
                        "fitted with it, not the tooth, carries the improvement"
                    )
                elif score.balanced_chi2 + penalty < chi_abs:
                    unc = {**fit.uncertainty, "depth": rd.sigma}
                    at_ratio = dataclasses.replace(
                        fit,
                        effect=rd.effect,
                        raw=rd.raw,
                        score=score,
                        uncertainty=unc,
                        feats=fr,
                        baseline_set=rd.mesh_set,
                    )
                    dd = refine_depth_by_dte(self, eff, accepted, rd.mesh_set) if by_dte else None
                    if dd is not None:
                        # verified in its place where the DTE depth is not confirmed
                        return take_dte_depth(self, fit, dd, accepted, at_ratio)
                    self._tooth_notes(rd.effect, f"depth {rd.effect.depth:.3g} (sideband energy ratios)")
                    return at_ratio
                else:
                    self.notes.append(
                        f"{eff.label}: the ratio depth {rd.effect.depth:.3g} is not used: with the mesh "
                        f"scale it implies the record is explained worse (chi2 {score.balanced_chi2:.4g}) "
                        f"than at the absolute depth {eff.depth:.3g} (chi2 {chi_abs:.4g})"
                    )
                # the path factors and scatter of the absolute depth again
                fb = self._tooth_features(rb, eff, accepted)
        if by_dte:
            dd = refine_depth_by_dte(self, eff, accepted)
            if dd is not None:
                at_abs = dataclasses.replace(fit, effect=eff, raw=rb, score=self.cmp.score(fb), feats=fb)
                return take_dte_depth(self, fit, dd, accepted, at_abs)
        if isinstance(eff, ToothDamage):
            self._tooth_notes(eff, f"{main.name} {xb:.3g}")
        ver = dataclasses.replace(fit, effect=eff, raw=rb, score=self.cmp.score(fb), feats=fb)
        if isinstance(eff, GearMisalignment) and self.fit.misalignment_axial and self._path_mask(eff) is None:
            # in contact: the tilted contact's width a nuisance, the angle held (candidates_misalignment.py)
            return fit_contact_width(self, ver, accepted)
        return ver

    def _verify_tooth(self, e: ToothDamage, accepted: list[Effect]) -> ToothDamage:
        """The tooth and its two neighbours compared on full simulations at the fitted depth.

        The tooth search shifts the tooth-1 signature by whole mesh periods, which is exact only for
        features that follow a time shift of the damaged wheel's own periodic signal. On a
        multi-stage train the other meshes' modulation of the damaged tooth's response does not
        shift with it, and the envelope of the non-synchronous part (every shaft's synchronous
        average removed) mixes the shafts: on a two-stage record with tooth 5 of mesh 2's gear
        damaged the search put the tooth one off (6). Two more full runs settle it.
        """
        cfg = self.runner.cfg
        mesh = cfg.meshes[e.mesh - 1]
        z = int(mesh.pinion_teeth if e.wheel == "pinion" else mesh.gear_teeth)
        teeth = dict.fromkeys((e.tooth - 1 + k) % z + 1 for k in (0, -1, 1))
        at_mesh = mesh_channels(self.cmp.names) if self._path_mask(e) is not None else None
        if at_mesh is not None and not at_mesh.any():
            at_mesh = None
        # in contact, opt-in: by the DTE's low orders of the wheel (candidates_tooth_path.py, Sec. 8.35)
        low = low_order_shaft(self, e) if at_mesh is None else None
        # in contact with a DTE, where the search's two rankings disagree decisively: the whole record's
        # tooth, the DTE's and the latter's neighbours, by the low orders (candidates_tooth_index.py)
        ranks = self._low_order_index.get(e.label) if at_mesh is None else None
        if ranks is not None and ranks.whole_tooth == e.tooth and decisive(ranks, self.fit.bic_threshold):
            low = low_order_index_applies(self, e)
            if low is not None:
                teeth = teeth_to_compare(ranks, z)
                self.notes.append(index_note(e.label, ranks))
        scored = []
        for t in teeth:
            cand = dataclasses.replace(e, tooth=t)
            raw = self._raw((*accepted, cand))
            f = self._full_features(raw, cand)
            # where the teeth separate the tooth comes from the channels at the mesh (fault_path.py)
            if low is not None:
                v = low_order_mesh_chi2(self, f, low)
            elif at_mesh is not None:
                v = channels_chi2(self.cmp, f, at_mesh)
            else:
                v = self.cmp.score(f).balanced_chi2
            scored.append((v, t, cand))
        best = min(scored, key=lambda x: x[0])
        if best[1] != e.tooth:
            self.notes.append(
                f"{e.label}: tooth {e.tooth} of the shifted-signature search replaced by tooth {best[1]} "
                f"on full simulations (chi2 {scored[0][0]:.4g} -> {best[0]:.4g})"
            )
        return best[2]

    def _gain_beyond_baseline(self, pre: Sequence[Effect], score: Score, k: int) -> tuple[float, float]:
        """Delta BIC and share of the excess that a candidate scored ``score`` on the machine with ``pre``
        (a baseline set fitted with it and the accepted effects) explains beyond that machine's healthy
        run: what the candidate itself explains, not the baseline set that came with it."""
        h = self.cmp.score(self._full_features(self._raw(tuple(pre))))
        gain = h.balanced_chi2 - score.balanced_chi2
        return gain - k * math.log(self.n_total), gain / max(h.balanced_chi2 - self.n_total, 1e-12)

    def _path_note(self, e: Effect, at: str) -> None:
        """Note the fitted transfer factors of ``e``'s path to the bearing channels (fault_path.py)."""
        mask = self._path_mask(e)
        if mask is None:
            return
        factors = ", ".join(
            f"{n} {'/'.join(f'{v:.2g}' for v in np.atleast_1d(a))}"
            for n, a, m in zip(self.cmp.names, self._path_a, mask, strict=True)
            if m
        )
        if np.ndim(self._path_a) == 2:
            factors += "; per band: low orders / each mesh harmonic's sidebands"
        self.notes.append(
            f"{e.label} at {at}: its response at these channels taken as the model's times a fitted "
            f"transfer factor ({factors}; fault_path.py): its parameters are set by the other channels"
        )

    def _tooth_notes(self, e: ToothDamage, at: str) -> None:
        """Notes on the nuisance factors of the last :meth:`_tooth_features` (path, scatter, shape)."""
        self._path_note(e, at)
        if (note := band_shape_note(e.label, at, getattr(self, "_band_shape", None))) is not None:
            self.notes.append(note)
        if self._n_scatter:
            self.notes.append(
                f"{e.label} at {at}: the revolution-to-revolution scatter of its response in the "
                "non-synchronous envelope, factor "
                + ", ".join(
                    f"{n} {v:.3g}" for n, v in zip(self.cmp.names, self._scatter_sigma, strict=True) if v > 0
                )
                + " of the model's response (envelope_scatter.py)"
            )

    def _tooth_features(self, raw: np.ndarray, e: ToothDamage, pre: Sequence[Effect]) -> ModelFeatures:
        """Features of a damaged tooth's full run ``raw`` on the machine with ``pre`` (the accepted
        effects, and a baseline set fitted with the tooth): where the teeth separate its response at the
        bearing channels enters with fitted path factors (``fault_path.py``) and its scatter in the
        non-synchronous envelope with fitted factors (``envelope_scatter.py``), both against that
        machine's own healthy run; elsewhere the plain full-run features."""
        f = self._full_features(raw)
        mask = self._path_mask(e)
        if mask is not None:
            f, self._path_a = with_path(
                self.cmp, self._full_features(self._raw(tuple(pre))), f, mask, self._banded(e)
            )
        self._n_scatter = 0
        if self.rattle_rules and scatter_applies(self.cmp, self.base_contact_loss):
            f, self._n_scatter = self._tooth_scatter(f, raw - self._raw(tuple(pre)))
        # in contact: the higher mesh harmonics' sidebands a shape nuisance (tooth_band_shape.py, Sec. 8.63)
        return shape_tooth(self, f, e, pre) if mask is None else f
