"""Candidate fitting on the features (step 3 of ``fit.py``'s procedure): amplitude and phase from two
basis runs, a scalar amplitude, grid scalars with interpolated signatures, the stiffness and
damping scales of a baseline set and a damaged tooth's depth and index. A mixin of
:class:`~gear_rotor_sim.calibration.fit.Calibrator` (moved from ``fit.py`` in session 16, unchanged).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from gear_rotor_sim.calibration.candidates_crack import fit_shaft_crack
from gear_rotor_sim.calibration.candidates_misalignment import (
    fit_gear_misalignment,
)
from gear_rotor_sim.calibration.candidates_tooth_index import low_order_index_applies, rank_low_orders
from gear_rotor_sim.calibration.candidates_tooth_path import low_order_mesh_chi2
from gear_rotor_sim.calibration.envelope_scatter import scatter_applies, with_scatter
from gear_rotor_sim.calibration.fault_path import (
    channels_chi2,
    mesh_channels,
    path_factors,
    scale_channels,
)
from gear_rotor_sim.calibration.fit_types import (
    CandidateFit,
)
from gear_rotor_sim.calibration.residual import (
    ModelFeatures,
)
from gear_rotor_sim.faults import (
    BearingDefect,
    BearingStiffnessDamping,
    Effect,
    GearEccentricity,
    GearMisalignment,
    MassUnbalance,
    MeshStiffnessDamping,
    ShaftCrack,
    ShaftMisalignment,
    TemperatureOffset,
    ToothDamage,
    ToothWear,
)


class CandidateFitting:
    """Fits of the candidate effects (mixin of ``Calibrator``)."""

    def _signature(self, effect: Effect) -> ModelFeatures:
        """Features of the response change of ``effect`` alone relative to the healthy model."""
        key = repr(effect)
        hit = self._sig_cache.get(key)
        if hit is None:
            hit = self._features(self._raw((effect,)) - self.base_raw)
            self._sig_cache[key] = hit
        return hit

    @staticmethod
    def _is_zero(f: ModelFeatures) -> bool:
        return not any(np.any(x) for xs in f.order for x in xs) and not any(np.any(x) for x in f.analytic)

    def _curvature_sigma(
        self, obj: Callable[[float], float], x: float, f0: float, h: float, k: int, lower: float = -np.inf
    ) -> float:
        """Parameter standard deviation from the chi^2 curvature, scaled by the reduced chi^2."""
        xm = x - h if x - h >= lower else x + 2 * h
        pts = np.array([xm, x, x + h])
        vals = np.array([obj(xm), f0, obj(x + h)])
        coef = np.polyfit(pts - x, vals, 2)
        curv = 2 * coef[0]
        red = max(f0 / max(self.n_total - k, 1), 1.0)
        return float(math.sqrt(2.0 * red / curv)) if curv > 0 else float("inf")

    def _fit_phase_amplitude(
        self,
        e: Effect,
        cur: ModelFeatures,
        ref: float | None = None,
        select: list[list[np.ndarray]] | None = None,
    ) -> CandidateFit | None:
        """Amplitude and phase from two basis runs at amplitude ``ref`` (default a tenth of the bound).

        ``select[c][s]`` (optional): the order features of channel ``c`` on shaft ``s`` that the least
        squares read (a misaligned wheel's axial line, ``candidates_misalignment.axial_low_orders``); the
        candidate is scored on every feature as always."""
        amp, ph = e.specs[0], e.specs[1]
        ref = 0.1 * amp.upper if ref is None else ref
        f0 = self._signature(e.with_parameters(**{amp.name: ref, ph.name: 0.0})).scaled(1.0 / ref)
        f1 = self._signature(e.with_parameters(**{amp.name: ref, ph.name: 0.5 * math.pi})).scaled(1.0 / ref)
        if self._is_zero(f0) and self._is_zero(f1):
            return None
        if "order" not in self.cmp.families:
            return self._fit_scalar_amplitude(
                e.with_parameters(**{ph.name: 0.0}), cur, f0, amp.name, amp.upper
            )
        tau = self.cmp.best_shift(cur)
        cur, f0, f1 = (self.cmp.apply_shift(x, tau) for x in (cur, f0, f1))
        g = self.cmp.fit_gains(cur)
        c = np.zeros(2)
        cov = np.eye(2)
        for _ in range(3):
            A = np.zeros((2, 2))
            rhs = np.zeros(2)
            for ci in range(self.cmp.nc):
                for s in range(len(self.cmp.shafts)):
                    gc = self.cmp.order_gain(g, ci, s)
                    model = gc * (cur.order[ci][s] + c[0] * f0.order[ci][s] + c[1] * f1.order[ci][s])
                    w = 2.0 / self.cmp.order_sigma2(ci, s, model)
                    if select is not None:
                        w = np.where(select[ci][s], w, 0.0)
                    r = self.cmp.d_order[ci][s] - gc * cur.order[ci][s]
                    cols = [gc * f0.order[ci][s], gc * f1.order[ci][s]]
                    for i in range(2):
                        rhs[i] += float(np.sum(w * np.real(np.conj(cols[i]) * r)))
                        for j in range(2):
                            A[i, j] += float(np.sum(w * np.real(np.conj(cols[i]) * cols[j])))
            if not np.all(np.isfinite(A)) or np.linalg.det(A) <= 0:
                return None
            c = np.linalg.solve(A, rhs)
            cov = np.linalg.inv(A)
            g = self.cmp.fit_gains(cur.combo(f0, c[0]).combo(f1, c[1]))
        a = float(np.hypot(*c))
        if a > amp.upper:
            c *= amp.upper / a
            a = amp.upper
        phase = float(math.atan2(c[1], c[0]))
        feats = cur.combo(f0, c[0]).combo(f1, c[1])
        score = self.cmp.score(feats, tau=0.0)
        score_free = self.cmp.score(self.cmp.apply_shift(feats, -tau))
        if score_free.balanced_chi2 < score.balanced_chi2:
            score = score_free
        red = max(score.balanced_chi2 / max(self.n_total - 2, 1), 1.0)
        jac = np.array([c[0], c[1]]) / max(a, 1e-300)
        sa = float(math.sqrt(max(jac @ cov @ jac, 0.0) * red))
        jp = np.array([-c[1], c[0]]) / max(a * a, 1e-300)
        sp = float(math.sqrt(max(jp @ cov @ jp, 0.0) * red))
        eff = e.with_parameters(**{amp.name: a, ph.name: phase})
        return CandidateFit(eff, score, None, 2, {amp.name: sa, ph.name: sp})

    def _fit_scalar_amplitude(
        self, e: Effect, cur: ModelFeatures, basis: ModelFeatures | None, name: str, upper: float
    ) -> CandidateFit | None:
        if basis is None:
            ref = 0.1 * upper
            basis = self._signature(e.with_parameters(**{name: ref})).scaled(1.0 / ref)
        if self._is_zero(basis):
            return None

        def obj(a: float) -> float:
            return self._chi2(cur.combo(basis, a))

        grid = np.concatenate([[0.0], upper * np.geomspace(1e-3, 1.0, 16)])
        vals = np.array([obj(a) for a in grid])
        i = int(np.argmin(vals))
        lo = grid[max(i - 1, 0)]
        hi = grid[min(i + 1, grid.size - 1)]
        a, val = float(grid[i]), float(vals[i])
        if hi > lo:
            res = minimize_scalar(
                obj, bounds=(lo, hi), method="bounded", options={"xatol": 1e-4 * max(a, 1e-3 * upper)}
            )
            if res.fun < val:
                a, val = float(res.x), float(res.fun)
        sig = self._curvature_sigma(obj, a, val, 0.02 * max(a, 1e-3 * upper), 1, 0.0)
        return CandidateFit(
            e.with_parameters(**{name: a}), self.cmp.score(cur.combo(basis, a)), None, 1, {name: sig}
        )

    def _interp_model(
        self,
        make: Callable[[float], Effect],
        grid: Sequence[float],
        neutral: float | None,
        cur: ModelFeatures,
    ) -> Callable[[float], ModelFeatures]:
        """Features at parameter p by piecewise-linear interpolation of grid signatures."""
        pts = sorted({float(p) for p in grid})
        zero = cur.scaled(0.0)
        sigs = {p: (zero if neutral is not None and p == neutral else self._signature(make(p))) for p in pts}

        def model(p: float) -> ModelFeatures:
            p = float(np.clip(p, pts[0], pts[-1]))
            j = min(max(int(np.searchsorted(pts, p)), 1), len(pts) - 1)
            a, b = pts[j - 1], pts[j]
            w = (p - a) / (b - a) if b > a else 0.0
            return cur.combo(sigs[a], 1.0 - w).combo(sigs[b], w)

        return model

    def _fit_grid_scalar(
        self,
        e: Effect,
        name: str,
        grid: Sequence[float],
        neutral: float,
        cur: ModelFeatures,
        bounds: tuple[float, float],
    ) -> CandidateFit | None:
        def make(p: float) -> Effect:
            return e.with_parameters(**{name: p})

        model = self._interp_model(make, [*grid, neutral], neutral, cur)
        lo, hi = max(bounds[0], min([*grid, neutral])), min(bounds[1], max([*grid, neutral]))
        fine = np.linspace(lo, hi, 49)
        vals = np.array([self._chi2(model(p)) for p in fine])
        i = int(np.argmin(vals))
        p = float(fine[i])
        if 0 < i < fine.size - 1:
            res = minimize_scalar(
                lambda x: self._chi2(model(x)), bounds=(fine[i - 1], fine[i + 1]), method="bounded"
            )
            if res.fun < vals[i]:
                p = float(res.x)
        val = self._chi2(model(p))
        sig = self._curvature_sigma(lambda x: self._chi2(model(x)), p, val, (hi - lo) * 0.01, 1, lo)
        return CandidateFit(make(p), self.cmp.score(model(p)), None, 1, {name: sig})

    def _fit_stiffness_damping(
        self, e: MeshStiffnessDamping | BearingStiffnessDamping, cur: ModelFeatures
    ) -> CandidateFit | None:
        """Stiffness scale on a grid, then the damping scale at the fitted stiffness (baseline sets)."""
        k_lo, k_hi = e.specs[0].lower, e.specs[0].upper
        grid = [0.45, 0.7, 1.4] if isinstance(e, MeshStiffnessDamping) else [0.5, 0.75, 1.5, 2.2]
        fit = self._fit_grid_scalar(e, "stiffness_scale", grid, 1.0, cur, (k_lo, k_hi))
        if fit is None:
            return None
        ks = fit.effect.parameters()["stiffness_scale"]
        base = dataclasses.replace(e, stiffness_scale=round(ks, 3), damping_scale=1.0)
        fit2 = self._fit_grid_scalar(
            base, "damping_scale", [0.6, 1.7], 1.0, self._grid_point(base, cur), (0.3, 3.0)
        )
        if fit2 is not None and fit2.score.balanced_chi2 < fit.score.balanced_chi2:
            unc = {"stiffness_scale": fit.uncertainty["stiffness_scale"], **fit2.uncertainty}
            return dataclasses.replace(fit2, k=2, uncertainty=unc)
        unc = {**fit.uncertainty, "damping_scale": float("nan")}
        return dataclasses.replace(fit, k=2, uncertainty=unc)

    def _grid_point(self, e: Effect, cur: ModelFeatures) -> ModelFeatures:
        """Current model plus the signature of ``e`` at its present parameters (one cached run)."""
        return cur.combo(self._signature(e), 1.0)

    def _fit_tooth(self, e: ToothDamage, cur: ModelFeatures) -> CandidateFit | None:
        """Depth and tooth of a damaged tooth on ``e.wheel``: the tooth-1 signature shifted by whole
        mesh periods gives every tooth of that wheel (its shaft's order comb and the sidebands at
        +-k f_shaft around the mesh orders tell the wheel: each wheel is a separate candidate)."""
        cfg = self.runner.cfg
        mesh = cfg.meshes[e.mesh - 1]
        z = mesh.pinion_teeth if e.wheel == "pinion" else mesh.gear_teeth
        fm = mesh.pinion_teeth * self.m.operating_point.speed_rpm / 60.0
        if e.mesh != 1:
            from gear_rotor_sim.system import shaft_speed_ratios

            ratios = np.abs(shaft_speed_ratios(cfg))
            pin_shaft = cfg.shaft_of_node(cfg.gear(mesh.pinion).node0)
            fm *= float(ratios[pin_shaft])
        depths = [0.2, 0.45, 0.8]
        sigs = {0.0: cur.scaled(0.0)}
        for d in depths:
            sigs[d] = self._signature(dataclasses.replace(e, tooth=1, depth=d))
        shifted: dict[tuple[float, int], ModelFeatures] = {}
        mask = self._path_mask(e)

        def sig(d: float, i: int) -> ModelFeatures:
            xs = sorted(sigs)
            j = min(max(int(np.searchsorted(xs, d)), 1), len(xs) - 1)
            a, b = xs[j - 1], xs[j]
            w = float(np.clip((d - a) / (b - a), 0, 1))
            out = cur.scaled(0.0)
            for p, wt in ((a, 1.0 - w), (b, w)):
                if wt == 0.0:
                    continue
                key = (p, i)
                if key not in shifted:
                    shifted[key] = self.cmp.shifted(sigs[p], i / fm, analytic=not self.cmp.env_non_sync)
                out = out.combo(shifted[key], wt)
            if mask is not None:
                bands = self._banded(e)
                out = scale_channels(out, path_factors(self.cmp, cur, out, mask, bands=bands), self.cmp)
            return out

        # tooth index: best over two depths (at one fixed depth the envelope penalty of an overshoot
        # can favour a neighbouring tooth)
        best = (np.inf, 0)
        at_mesh = mesh_channels(self.cmp.names) if mask is not None else None
        if at_mesh is not None and not at_mesh.any():
            at_mesh = None

        def index_chi2(f: ModelFeatures) -> float:
            # where the teeth separate the tooth comes from the channels at the mesh (fault_path.py)
            return self._chi2(f) if at_mesh is None else channels_chi2(self.cmp, f, at_mesh)

        # in contact with a DTE: every tooth ranked by the low orders at the mesh too, on the same shifted
        # signatures (candidates_tooth_index.py); the refinement compares the teeth where it decides
        low_shaft = low_order_index_applies(self, e) if mask is None else None
        whole_v, low_v = np.full(z, np.inf), np.full(z, np.inf)
        for i in range(z):
            feats_i = [cur.combo(sig(d, i), 1.0) for d in (0.2, 0.45)]
            v = min(index_chi2(f) for f in feats_i)
            whole_v[i] = v
            if low_shaft is not None:
                low_v[i] = min(low_order_mesh_chi2(self, f, low_shaft) for f in feats_i)
            if v < best[0]:
                best = (v, i)
        i_best = best[1]
        self._low_order_index.pop(e.label, None)
        if low_shaft is not None:
            self._low_order_index[e.label] = rank_low_orders(
                low_v, whole_v, low_order_mesh_chi2(self, cur, low_shaft)
            )

        def obj(d: float) -> float:
            return self._param_chi2(cur.combo(sig(d, i_best), 1.0), e)

        grid = np.linspace(0.0, 0.9, 19)
        vals = np.array([obj(d) for d in grid])
        k = int(np.argmin(vals))
        res = minimize_scalar(
            obj,
            bounds=(grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]),
            method="bounded",
            options={"xatol": 0.002},
        )
        d_best, val = (
            (float(res.x), float(res.fun)) if res.fun < vals[k] else (float(grid[k]), float(vals[k]))
        )
        sd = self._curvature_sigma(obj, d_best, val, 0.02, 2, 0.0)
        eff = dataclasses.replace(e, tooth=i_best + 1, depth=d_best)
        feats = cur.combo(sig(d_best, i_best), 1.0)
        feats, n_scatter = self._tooth_scatter(feats, self._raw((eff,)) - self.base_raw)
        return CandidateFit(
            eff, self.cmp.score(feats), None, 2 + n_scatter, {"depth": sd, "tooth": 0.0}, feats=feats
        )

    def _tooth_scatter(self, feats: ModelFeatures, change_raw: np.ndarray) -> tuple[ModelFeatures, int]:
        """Where the teeth separate: the revolution-to-revolution scatter of the damaged tooth's response
        ``change_raw`` (raw channels) in the non-synchronous envelope, one fitted factor per envelope
        channel (``envelope_scatter.py``). Returns the features and the number of factors fitted."""
        if not (self.rattle_rules and scatter_applies(self.cmp, self.base_contact_loss)):
            return feats, 0
        change = self.runner.outputs(change_raw)
        out, sigma = with_scatter(self.cmp, feats, change)
        self._scatter_sigma = sigma
        return out, int(np.count_nonzero(sigma))

    def _fit_candidate(self, e: Effect, cur: ModelFeatures) -> CandidateFit | None:
        op = self.m.operating_point
        if isinstance(e, GearEccentricity | MassUnbalance | ShaftMisalignment):
            return self._fit_phase_amplitude(e, cur)
        if isinstance(e, ToothWear):
            # nonlinear: a larger backlash lets the teeth separate, and the response to a separation is
            # not periodic (non-synchronous content the envelope family sees): full simulations on a
            # geometric grid (x2.5) instead of one linear basis run
            up = e.specs[0].upper
            grid = [g for g in (4e-6, 10e-6, 25e-6, 60e-6) if g < up]
            return self._fit_grid_scalar(e, "wear_depth_m", grid, 0.0, cur, (0.0, up))
        if isinstance(e, GearMisalignment):
            # linear axial part for the phase, full simulations for the angle (candidates_misalignment.py)
            return fit_gear_misalignment(self, e, cur)
        if isinstance(e, BearingDefect):
            return self._fit_scalar_amplitude(e, cur, None, "force_n", e.specs[0].upper)
        if isinstance(e, TemperatureOffset):
            mat = next(iter(self.runner.cfg.materials.values()))
            tmin, tmax = float(np.min(mat.temperatures_c)), float(np.max(mat.temperatures_c))
            lo, hi = (
                max(e.specs[0].lower, tmin - op.temperature_c),
                min(e.specs[0].upper, tmax - op.temperature_c),
            )
            if hi - lo < 1.0:
                return None
            grid = [float(g) for g in np.linspace(lo, hi, 5) if abs(g) > 1e-9]
            return self._fit_grid_scalar(e, "offset_c", grid, 0.0, cur, (lo, hi))
        if isinstance(e, MeshStiffnessDamping | BearingStiffnessDamping):
            return self._fit_stiffness_damping(e, cur)
        if isinstance(e, ToothDamage):
            return self._fit_tooth(e, cur)
        if isinstance(e, ShaftCrack):
            return fit_shaft_crack(self, e, cur)  # phase by mesh-period shifts (candidates_crack.py)
        return None
