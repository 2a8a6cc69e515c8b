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
   acceptance re-checked on a full simulation of the updated model. Repeat until the error is at the
   noise level, nothing qualifies, or ``max_effects`` are in.

Confidence of an accepted effect: ``P(effect) * P(best vs runner-up)``, both BIC posterior
probabilities ``1 / (1 + exp(-Delta/2))`` (Kass & Raftery 1995), so an effect that barely beats an
alternative explanation is reported with a low confidence. Parameter uncertainty: from the
curvature of chi^2 (scalar fits) or the normal matrix (linear fits), scaled by the reduced chi^2.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from gear_rotor_sim.calibration.measurement import Measurement
from gear_rotor_sim.calibration.residual import (
    Comparison,
    HousingSensor,
    ModelFeatures,
    ModelRunner,
    ResidualSettings,
    Score,
    housing_source,
    residual_spectrum,
    time_and_spectrum_errors,
)
from gear_rotor_sim.faults import (
    BEARING_6206,
    BearingDefect,
    BearingGeometry,
    Effect,
    GearEccentricity,
    MassUnbalance,
    MeshStiffnessDamping,
    ShaftMisalignment,
    TemperatureOffset,
    ToothDamage,
    ToothWear,
    candidate_effects,
    effect_name,
)


@dataclass
class FitSettings:
    """Stopping and acceptance rule."""

    stop_error: float = 1.3
    bic_threshold: float = 10.0
    min_explained: float = 0.25
    max_effects: int = 3
    refine_steps: int = 2
    line_prominence: float = 4.0  # bearing defects: a characteristic envelope line >= 6 dB above the floor


@dataclass
class CandidateFit:
    """A candidate with fitted parameters and its goodness of fit."""

    effect: Effect
    score: Score
    raw: np.ndarray | None
    k: int
    uncertainty: dict[str, float]
    delta_bic: float = 0.0
    explained: float = 0.0

    @property
    def name(self) -> str:
        return effect_name(self.effect)


@dataclass
class FoundEffect:
    """An accepted effect as reported."""

    name: str
    label: str
    parameters: dict[str, float]
    uncertainty: dict[str, float]
    confidence: float
    delta_bic: float
    explained_fraction: float
    error_before: float
    error_after: float
    effect: Effect

    def as_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "label": self.label,
            "parameters": self.parameters,
            "uncertainty": self.uncertainty,
            "confidence": self.confidence,
            "delta_bic": self.delta_bic,
            "explained_fraction": self.explained_fraction,
            "error_before": self.error_before,
            "error_after": self.error_after,
        }


@dataclass
class CalibrationResult:
    """Everything the report needs."""

    measurement: Measurement
    effects: list[FoundEffect]
    score_before: Score
    score_after: Score
    rounds: list[list[dict[str, Any]]]
    conclusion: str
    plain_before: dict[str, dict[str, float]]
    plain_after: dict[str, dict[str, float]]
    model_before: np.ndarray
    model_after: np.ndarray
    comparison: Comparison
    notes: list[str] = field(default_factory=list)
    n_simulations: int = 0

    @property
    def error_before(self) -> float:
        return self.score_before.error

    @property
    def error_after(self) -> float:
        return self.score_after.error

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the ``--json`` object)."""

        def per_channel(score: Score, plain: dict[str, dict[str, float]]) -> dict[str, dict[str, float]]:
            out: dict[str, dict[str, float]] = {}
            for fam, d in score.per_channel.items():
                for ch, v in d.items():
                    out.setdefault(ch, {})[f"{fam}_normalised"] = v
            for fam, d in score.relative.items():
                for ch, v in d.items():
                    out.setdefault(ch, {})[f"{fam}_relative"] = v
            for ch, d in plain.items():
                out.setdefault(ch, {}).update(d)
            return out

        return {
            "measurement": self.measurement.source,
            "operating_point": dataclasses.asdict(self.measurement.operating_point),
            "main_metric": "family-balanced normalised RMS residual (1 = noise level)",
            "effects": [e.as_dict() for e in self.effects],
            "error_before": self.error_before,
            "error_after": self.error_after,
            "error_before_by_family": {
                f: math.sqrt(self.score_before.chi2[f] / self.score_before.n[f])
                for f in self.score_before.chi2
            },
            "error_after_by_family": {
                f: math.sqrt(self.score_after.chi2[f] / self.score_after.n[f]) for f in self.score_after.chi2
            },
            "per_channel_before": per_channel(self.score_before, self.plain_before),
            "per_channel_after": per_channel(self.score_after, self.plain_after),
            "gains_after": {
                c: float(g) for c, g in zip(self.comparison.names, self.score_after.gains, strict=True)
            },
            "time_shift_s_before": self.score_before.tau,
            "time_shift_s_after": self.score_after.tau,
            "envelope_bands_hz": {
                c: list(b) for c, b in zip(self.comparison.names, self.comparison.bands, strict=False)
            },
            "conclusion": self.conclusion,
            "candidates_by_round": self.rounds,
            "issues": self.measurement.issues,
            "notes": self.notes,
            "n_simulations": self.n_simulations,
        }


class Calibrator:
    """Runs the procedure of the module docstring on one measurement.

    Parameters
    ----------
    measurement : Measurement
    cfg : RigConfig
        Model of the machine (default ``load_config(measurement.gearbox)``).
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
        steps_per_mesh: int = 32,
        log: Callable[[str], None] | None = None,
    ) -> None:
        if cfg is None:
            from gear_rotor_sim.config import load_config

            cfg = load_config(measurement.gearbox)
        self.m = measurement
        self.settings = settings or ResidualSettings()
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
        )
        cfg = self.runner.cfg
        observed = sorted(
            {int(c.split("_")[0][7:]) for c in measurement.model_channels if c.startswith("bearing")}
        )
        if candidates is None:
            candidates = candidate_effects(cfg, bearing_geometry, bearings=tuple(observed) or None)
        self.candidates = list(candidates)
        env_max = self._envelope_max(cfg, bearing_geometry)
        self.cmp = Comparison(measurement, self.runner, self.settings, env_max)
        self.notes: list[str] = []

    # ------------------------------------------------------------------------------- helpers
    def _envelope_max(self, cfg: Any, geom: BearingGeometry) -> float:
        if self.settings.envelope_max_hz is not None:
            return self.settings.envelope_max_hz
        from gear_rotor_sim.system import shaft_speed_ratios

        f = float(np.max(np.abs(shaft_speed_ratios(cfg)))) * self.m.operating_point.speed_rpm / 60.0
        return 2.2 * geom.multiples()["bpfi"] * f

    def _features(self, raw: np.ndarray) -> ModelFeatures:
        return self.cmp.features(self.runner.outputs(raw))

    def _chi2(self, feats: ModelFeatures) -> float:
        return self.cmp.score(feats).balanced_chi2

    def _raw(self, effects: Sequence[Effect]) -> np.ndarray:
        return self.runner.force_signals(tuple(effects))

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

    # ---------------------------------------------------------------------------- candidates
    def _fit_phase_amplitude(self, e: Effect, cur: ModelFeatures) -> CandidateFit | None:
        amp, ph = e.specs[0], e.specs[1]
        ref = 0.1 * amp.upper
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
                    model = g[ci] * (cur.order[ci][s] + c[0] * f0.order[ci][s] + c[1] * f1.order[ci][s])
                    w = 2.0 / self.cmp.order_sigma2(ci, s, model)
                    r = self.cmp.d_order[ci][s] - g[ci] * cur.order[ci][s]
                    cols = [g[ci] * f0.order[ci][s], g[ci] * f1.order[ci][s]]
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

    def _fit_stiffness_damping(self, e: MeshStiffnessDamping, cur: ModelFeatures) -> CandidateFit | None:
        fit = self._fit_grid_scalar(e, "stiffness_scale", [0.45, 0.7, 1.4], 1.0, cur, (0.3, 2.0))
        if fit is None:
            return None
        ks = fit.effect.parameters()["stiffness_scale"]
        base = MeshStiffnessDamping(stiffness_scale=round(ks, 3))
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

    def _fit_tooth(self, cur: ModelFeatures) -> CandidateFit | None:
        cfg = self.runner.cfg
        z = cfg.meshes[0].pinion_teeth
        fm = z * self.m.operating_point.speed_rpm / 60.0
        depths = [0.2, 0.45, 0.8]
        sigs = {0.0: cur.scaled(0.0)}
        for d in depths:
            sigs[d] = self._signature(ToothDamage(tooth=1, depth=d))
        shifted: dict[tuple[float, int], ModelFeatures] = {}

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
                    shifted[key] = self.cmp.shifted(sigs[p], i / fm)
                out = out.combo(shifted[key], wt)
            return out

        best = (np.inf, 0)
        for i in range(z):
            v = self._chi2(cur.combo(sig(0.45, i), 1.0))
            if v < best[0]:
                best = (v, i)
        i_best = best[1]

        def obj(d: float) -> float:
            return self._chi2(cur.combo(sig(d, i_best), 1.0))

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
        eff = ToothDamage(tooth=i_best + 1, depth=d_best)
        return CandidateFit(
            eff, self.cmp.score(cur.combo(sig(d_best, i_best), 1.0)), None, 2, {"depth": sd, "tooth": 0.0}
        )

    def _fit_candidate(self, e: Effect, cur: ModelFeatures) -> CandidateFit | None:
        op = self.m.operating_point
        if isinstance(e, GearEccentricity | MassUnbalance | ShaftMisalignment):
            return self._fit_phase_amplitude(e, cur)
        if isinstance(e, ToothWear):
            return self._fit_scalar_amplitude(e, cur, None, "wear_depth_m", e.specs[0].upper)
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
        if isinstance(e, MeshStiffnessDamping):
            return self._fit_stiffness_damping(e, cur)
        if isinstance(e, ToothDamage):
            return self._fit_tooth(cur)
        return None

    def _signature_present(self, fit: CandidateFit, cur: Score) -> bool:
        """Bearing defects must improve their own characteristic envelope lines significantly."""
        e = fit.effect
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
        prominence = self._line_prominence(
            e.key_frequencies_hz(ratio * self.m.operating_point.speed_rpm / 60.0), predicted
        )
        if prominence < self.fit.line_prominence:
            self.notes.append(
                f"{e.label}: its lines are present but weak (peak {prominence:.2f} x the local envelope "
                f"floor < {self.fit.line_prominence:g}): below the detection threshold, not claimed"
            )
            return False
        return True

    def _line_prominence(self, freqs: Sequence[float], predicted: list[np.ndarray]) -> float:
        """Largest ratio of a measured envelope line to its local floor, over lines and channels.

        The floor is the median of the measured bins within +-25 % of the line frequency where the
        fitted candidate itself predicts no line (its sidebands and shaft-rate lines excluded), the
        line's own +-3 % excluded.
        """
        f = self.cmp.env_f
        best = 0.0
        for fk in freqs:
            own = self.cmp.line_mask([fk])
            near = (np.abs(f - fk) <= 0.25 * fk) & (np.abs(f - fk) > 0.03 * fk) & ~own
            if not own.any():
                continue
            for d, pm, fl in zip(self.cmp.d_env, predicted, self.cmp.env_floor, strict=True):
                neigh = near & (pm < 0.5 * fl)
                if neigh.sum() < 3:
                    neigh = near
                if neigh.sum() < 3:
                    continue
                floor = float(np.median(d[neigh]))
                if floor > 0:
                    best = max(best, float(np.max(d[own])) / floor)
        return best

    # ------------------------------------------------------------------------------ refinement
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

    def _refine(self, fit: CandidateFit, accepted: list[Effect]) -> CandidateFit:
        """Refine the main scalar parameter with full simulations (parabola through three runs).

        Linear effects (amplitude/phase, bearing impulse force) are exact by superposition and only
        verified; wear (backlash: nonlinear once contact is lost), temperature, stiffness and tooth
        damage are refined. Returns the best verified fit (``raw`` from a full simulation).
        """
        e = fit.effect
        if isinstance(e, GearEccentricity | MassUnbalance | ShaftMisalignment | BearingDefect):
            raw = self._raw((*accepted, e))
            return dataclasses.replace(fit, raw=raw, score=self.cmp.score(self._features(raw)))
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
            pts.append((x, self.cmp.score(self._features(raw)).balanced_chi2, raw))

        run(x0)
        if self.fit.refine_steps > 0:
            run(x0 + h)
            x1 = pts[-1][0]
            if len(pts) == 2 and pts[1][1] > pts[0][1]:
                run(x0 - h)
            else:
                run(x1 + h)
            xs = np.array([p[0] for p in pts])
            vs = np.array([p[1] for p in pts])
            if len(pts) == 3 and np.ptp(xs) > 0:
                c2 = np.polyfit(xs - x0, vs, 2)
                if c2[0] > 0:
                    xq = x0 - c2[1] / (2 * c2[0])
                    if abs(xq - x0) <= 4 * h:
                        run(x0 + (xq - x0))
        xb, _, rb = min(pts, key=lambda t: t[1])
        eff = e.with_parameters(**{main.name: xb})
        return dataclasses.replace(fit, effect=eff, raw=rb, score=self.cmp.score(self._features(rb)))

    # ------------------------------------------------------------------------------------- run
    def run(self) -> CalibrationResult:
        self.base_raw = self._raw(())
        base_out = self.runner.outputs(self.base_raw)
        if self.runner.sensors is not None and any(housing_source(c) for c in self.runner.channels):
            self.cmp.set_baseline(base_out)
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
        else:
            self.cmp.set_baseline(base_out)
        cur_raw = self.base_raw
        cur_feat = self._features(cur_raw)
        self._sig_cache: dict[str, ModelFeatures] = {}
        self._sig_checked: dict[tuple, bool] = {}
        score0 = self.cmp.score(cur_feat)
        self.n_total = score0.n_total
        cur_score = score0
        accepted: list[Effect] = []
        found: list[FoundEffect] = []
        rounds: list[list[dict[str, Any]]] = []
        N = score0.n_total
        self.log(f"healthy model: error {score0.error:.3g}")
        conclusion = ""
        while len(accepted) < self.fit.max_effects:
            if cur_score.error <= self.fit.stop_error:
                conclusion = (
                    "the healthy model already fits to within the noise level: no effect claimed"
                    if not accepted
                    else "the remaining residual is at the noise level"
                )
                break
            self._cur_feat = cur_feat
            fits: list[CandidateFit] = []
            table: list[dict[str, Any]] = []
            used = {a_.label for a_ in accepted}
            for e in self.candidates:
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
            admissible = [f for f in fits if self._signature_present(f, cur_score)]
            chosen = None
            for _idx, f in enumerate(fits[:3]):
                if f.delta_bic <= self.fit.bic_threshold or f.explained < self.fit.min_explained:
                    break
                if f not in admissible:
                    self.notes.append(
                        f"{f.effect.label}: not claimed, its characteristic lines do not carry the "
                        "improvement or are below the detection threshold"
                    )
                    continue
                try:
                    ver = self._refine(f, accepted)
                except (ValueError, RuntimeError) as exc:
                    self.notes.append(f"{f.effect.label}: refinement failed ({exc}); not claimed")
                    continue
                dbic = cur_score.balanced_chi2 - ver.score.balanced_chi2 - f.k * math.log(N)
                expl = (cur_score.balanced_chi2 - ver.score.balanced_chi2) / max(
                    cur_score.balanced_chi2 - N, 1e-12
                )
                others = [g.delta_bic for g in admissible if g is not f]
                runner_up = max(others) if others else -np.inf
                p_sep = _logistic((dbic - runner_up) / 2) if np.isfinite(runner_up) else 1.0
                if dbic > self.fit.bic_threshold and expl >= self.fit.min_explained and p_sep >= 0.5:
                    ver.delta_bic, ver.explained = dbic, expl
                    chosen = (ver, runner_up)
                    break
                if p_sep < 0.5:
                    self.notes.append(
                        f"{f.effect.label}: after the full simulation it no longer beats the "
                        "runner-up; not claimed"
                    )
                    continue
                self.notes.append(
                    f"{f.effect.label}: fitted but not confirmed by the full simulation (dBIC {dbic:.3g})"
                )
            if chosen is None:
                conclusion = (
                    "no effect claimed: no candidate explains the residual beyond noise and the parsimony "
                    "penalty with its own signature"
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
            found.append(
                FoundEffect(
                    ver.name,
                    ver.effect.label,
                    ver.effect.parameters(),
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
            accepted.append(ver.effect)
            cur_raw = ver.raw
            cur_feat = self._features(cur_raw)
            cur_score = self.cmp.score(cur_feat)
        else:
            conclusion = f"stopped after {self.fit.max_effects} effects"
        model_after = self.runner.outputs(cur_raw)
        return CalibrationResult(
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
        )

    def _plain(self, model: np.ndarray, score: Score) -> dict[str, dict[str, float]]:
        fs = self.m.sample_rate_hz
        lag = int(0.5 * fs / self.cmp.mesh_hz) if self.cmp.mesh_hz else int(0.002 * fs)
        return {
            c: time_and_spectrum_errors(self.m.data[:, i], model[:, i], fs, max(lag, 1))
            for i, c in enumerate(self.cmp.names)
        }


def _logistic(x: float) -> float:
    if x > 50:
        return 1.0
    if x < -50:
        return 0.0
    return 1.0 / (1.0 + math.exp(-x))


def calibrate(measurement: Measurement, cfg: Any = None, **kw: Any) -> CalibrationResult:
    """Convenience wrapper: ``Calibrator(measurement, cfg, **kw).run()``."""
    return Calibrator(measurement, cfg, **kw).run()


def model_residual_spectra(
    result: CalibrationResult, channel: int
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Amplitude spectra of the time residual before and after, for the report."""
    fs = result.measurement.sample_rate_hz
    y = result.measurement.data[:, channel]
    lag = int(0.5 * fs / result.comparison.mesh_hz) if result.comparison.mesh_hz else 1
    return {
        "before": residual_spectrum(
            y, result.model_before[:, channel], fs, float(result.score_before.gains[channel]), max(lag, 1)
        ),
        "after": residual_spectrum(
            y, result.model_after[:, channel], fs, float(result.score_after.gains[channel]), max(lag, 1)
        ),
    }


def synthetic_measurement(
    cfg: Any,
    effects: Sequence[Effect],
    speed_rpm: float,
    temperature_c: float,
    channels: Sequence[str],
    path: str | Any,
    gearbox: str,
    *,
    duration_s: float = 0.3,
    warmup_s: float = 0.15,
    sample_rate_hz: float = 20000.0,
    noise_rms: float = 0.03,
    gain_error: float = 0.03,
    damping_scale: float = 1.2,
    seed: int = 0,
    output_torque_nm: float | None = None,
    steps_per_mesh: int = 32,
) -> Any:
    """Data made by our simulator for the self-test, written as CSV + sidecar (the measurement contract).

    The declared operating point and gearbox are the healthy ones; ``effects`` are injected but not
    declared. Nuisances: the mesh damping ratio times ``damping_scale`` (model mismatch), per-channel
    sensor gains ``1 +- gain_error`` (random sign), white noise of ``noise_rms`` times each channel's
    RMS (about its mean).

    Returns
    -------
    Path
        The CSV file (its ``.yaml`` sidecar next to it).
    """
    from pathlib import Path

    from gear_rotor_sim.blocks import SampleBlock
    from gear_rotor_sim.calibration.measurement import OperatingPoint, write_csv
    from gear_rotor_sim.simulator import Simulator

    data_cfg = cfg.replace(
        meshes=tuple(
            dataclasses.replace(m, damping_ratio=m.damping_ratio * damping_scale) for m in cfg.meshes
        )
    )
    speed, temp = speed_rpm, temperature_c
    for e in effects:
        speed, temp = e.operating_point(speed, temp)
    if output_torque_nm is not None and data_cfg.load is not None:
        data_cfg = data_cfg.replace(load=dataclasses.replace(data_cfg.load, torque_nm=output_torque_nm))
    sim = Simulator(
        data_cfg, speed, temp, sample_rate_hz, list(channels), steps_per_mesh, effects=tuple(effects)
    )
    i0 = round(warmup_s * sample_rate_hz)
    n = round(duration_s * sample_rate_hz)
    block = sim.advance((i0 + n + 0.5) / sample_rate_hz)
    data = block.data[i0 : i0 + n].copy()
    rng = np.random.default_rng(seed)
    gains = 1.0 + gain_error * rng.choice([-1.0, 1.0], size=data.shape[1])
    data = data * gains + noise_rms * data.std(axis=0) * rng.standard_normal(data.shape)
    out = SampleBlock(i0 / sample_rate_hz, sample_rate_hz, tuple(channels), block.units, data)
    op = OperatingPoint(speed_rpm, temperature_c, output_torque_nm)
    return write_csv(Path(path), out, op, gearbox)
