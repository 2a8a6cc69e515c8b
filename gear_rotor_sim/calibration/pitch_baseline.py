"""The wheels' pitch deviations as a baseline update of the machine (issue 11;
docs/history/calibration_sessions.md Sec. 8.68).

Every wheel carries manufacturing pitch deviations (ISO 1328-1). They are a property of the machine, not a
fault: where the DTE's synchronous average of a wheel holds a tooth-by-tooth pattern that the model lacks,
the flank positions are read from it (``pitch_pattern.py``) and put into the model as a per-tooth static
transmission error (``faults/pitch.py``), reported in ``baseline_updates`` (name ``pitch_deviation``).

When: once the search for effects has ended (:func:`pitch_round`), on the record minus the model with the
effects found. The rule that separates a damaged tooth from the pattern (a fault is what is left after the
best pattern): a damaged tooth and its own flank lagging give one DTE pulse but for its shape within the
engagement (their pulses correlate to 0.96 with the library's shares) and its load dependence (one load per
record). On one record they cannot be told apart tooth by tooth: on the independent gearbox at quality 7
(3000 rpm) the pinion tooth damaged to depth 0.4 reads as a flank 5.1 um behind, while a healthy tooth of the
same pinion lags 8.5 um. So the pattern never takes a fault's place: it is read after the search, the teeth
that accepted tooth damages name keep their position at the pattern's mean (their slots are the faults'), the
long-wave part (per-tooth harmonics 1-2) only on a wheel with no eccentricity or misalignment found, and a
wheel's pattern is fitted only where it is

* significant: its energy at the orders read at least :data:`MIN_SIGNIFICANCE` times what its noise gives
  there plus what the healthy model itself holds there (numerical lines; ``WheelPattern.significance``,
  without the long-wave part; measured 0.75-1.44 on the generator's records without pitch errors, 214-327
  with 6 um; 49.6 on the table's healthy 2000 rpm residual before the model's own content was counted),
* spread round the wheel: at least :data:`MIN_SPREAD` of its energy more than two teeth from its largest
  flank (``pitch_pattern.spread``; 0.05 for one damaged tooth read as a pattern, 0.60-0.89 for pitch
  deviations and for noise), and
* not a smooth wave: at least :data:`MIN_HIGH_SHARE` of its energy in the per-tooth harmonics above a
  quarter of the teeth (``pitch_pattern.high_harmonic_share``; 0.54-0.64 at quality 7, 0.06 on the table's
  gear misalignment record, whose even orders read significance 21 and spread 0.84),

and kept where it lowers the balanced chi^2 beyond the BIC penalty of its positions and path factors
(:func:`path_factors`). The pattern is synchronous with its wheel: it enters the order features, never the
envelope's input (every shaft's synchronous part is removed there).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from gear_rotor_sim.calibration.pitch_pattern import (
    fit_wheel_pattern,
    high_harmonic_share,
    pattern_basis,
    pattern_orders,
    spread,
    wheel_orders,
)
from gear_rotor_sim.faults import GearEccentricity, GearMisalignment, ToothDamage
from gear_rotor_sim.faults.pitch import PitchDeviation

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.fit_types import FoundEffect
    from gear_rotor_sim.calibration.residual import ModelFeatures, Score
    from gear_rotor_sim.faults import Effect

#: smallest significance of a wheel's pattern (its energy over its noise's) for it to be read
MIN_SIGNIFICANCE = 20.0
#: smallest share of a wheel's pattern energy away from its largest flank (not one tooth)
MIN_SPREAD = 0.4
#: smallest share of a wheel's pattern energy in the per-tooth harmonics above a quarter of its teeth (not a
#: smooth wave round the wheel)
MIN_HIGH_SHARE = 0.3
#: largest factor on the pattern's path to a bearing or housing channel (``path_factors``)
MAX_PATH_FACTOR = 2.0
#: first mesh-harmonic band whose factor is fitted at the DTE (``path_factors``)
DTE_FITTED_BAND = 2


@dataclasses.dataclass
class WheelReading:
    """What the rule read on one wheel: the pattern's statistics and whether it is fitted."""

    wheel: str
    teeth: int
    positions_m: np.ndarray
    significance: float
    spread: float
    explained: float
    fixed: tuple[int, ...]
    high_share: float = 0.0
    long_wave: bool = False

    @property
    def applies(self) -> bool:
        return (
            self.significance >= MIN_SIGNIFICANCE
            and self.spread >= MIN_SPREAD
            and self.high_share >= MIN_HIGH_SHARE
        )

    def text(self) -> str:
        rms = float(np.sqrt(np.mean(self.positions_m**2))) * 1e6
        fixed = f", teeth {', '.join(str(j + 1) for j in self.fixed)} held at the mean" if self.fixed else ""
        fixed += ", with its long-wave part" if self.long_wave else ""
        return (
            f"{self.wheel}: significance {self.significance:.3g} (rule {MIN_SIGNIFICANCE:g}), spread "
            f"{self.spread:.2f} (rule {MIN_SPREAD:g}), high harmonics {self.high_share:.2f} (rule "
            f"{MIN_HIGH_SHARE:g}), flank RMS {rms:.2f} um, explains "
            f"{100 * self.explained:.0f} % of the average's non-carrier content{fixed}"
        )


def _dte_index(cal: Calibrator) -> int | None:
    for i, n in enumerate(cal.cmp.names):
        if n == "dte":
            return i
    return None


def _wheels(cal: Calibrator) -> list[tuple[str, float, int]]:
    """(wheel, shaft rate Hz, teeth) of the first mesh's two wheels among the order-analysed shafts."""
    from gear_rotor_sim.calibration.candidates_tooth import wheel_shaft

    out = []
    for wheel in ("pinion", "gear"):
        sh = wheel_shaft(cal, ToothDamage(wheel=wheel))
        if sh is not None:
            out.append((wheel, float(sh[0]), int(sh[1])))
    return out


def read_wheels(cal: Calibrator, model_dte: np.ndarray, accepted: list[Effect]) -> list[WheelReading]:
    """Each wheel's pattern in the record's DTE minus ``model_dte`` (the model with the effects found), the
    teeth named by accepted tooth damages held at the mean."""
    from gear_rotor_sim.calibration.residual import cached_system

    c = _dte_index(cal)
    if c is None or len(cal.runner.cfg.meshes) != 1:
        return []
    eps = float(cached_system(cal.runner.cfg, cal.m.operating_point.temperature_c).meshes[0].contact_ratio)
    fs = cal.m.sample_rate_hz
    base_dte = cal.runner.outputs(cal.base_raw)[:, c]
    out = []
    for wheel, f, teeth in _wheels(cal):
        orders = pattern_orders(teeth)
        rec, var = wheel_orders(cal.m.data[:, c], fs, f, float(getattr(cal.m, "t0", 0.0)), orders)
        mod, _ = wheel_orders(model_dte, fs, f, float(cal.runner.start_time), orders)
        fixed = tuple(
            sorted(
                {(e.tooth - 1) % teeth for e in accepted if isinstance(e, ToothDamage) and e.wheel == wheel}
            )
        )
        # the healthy model's own content at these orders (numerical lines of the integration, no pitch
        # errors: 0.12 um of flank RMS on the table's healthy 2000 rpm record) raises the significance's floor
        base, _ = wheel_orders(base_dte, fs, f, float(cal.runner.start_time), orders)
        floor = fit_wheel_pattern(base, np.zeros(orders.size), teeth, eps).energy
        w = fit_wheel_pattern(rec - mod, var, teeth, eps, fixed, floor_energy=floor)
        p = w.positions_m
        r = WheelReading(
            wheel, teeth, p, w.significance, spread(p), w.explained, fixed, high_harmonic_share(p)
        )
        owned = any(
            isinstance(e, (GearEccentricity, GearMisalignment)) and e.member == wheel for e in accepted
        )
        if r.applies and not owned:
            # the long-wave part too where no eccentricity or misalignment of the wheel was found
            whole = fit_wheel_pattern(rec - mod, var, teeth, eps, fixed, long_wave=True, floor_energy=floor)
            r.positions_m, r.explained, r.long_wave = whole.positions_m, whole.explained, True
        out.append(r)
    return out


def pattern_effect(cal: Calibrator, readings: list[WheelReading]) -> PitchDeviation | None:
    """The machine's pitch deviations: a held pattern plus the wheels' readings that apply (None if none)."""
    held = next((b for b in cal.baseline if isinstance(b, PitchDeviation)), None)
    pos: dict[str, np.ndarray] = {}
    for r in readings:
        if r.applies:
            base = getattr(held, f"{r.wheel}_m", ()) if held is not None else ()
            pos[r.wheel] = r.positions_m + (np.asarray(base) if len(base) else 0.0)
    if not pos:
        return None
    kw = {f"{w}_m": tuple(float(v) for v in p) for w, p in pos.items()}
    return dataclasses.replace(held, **kw) if held is not None else PitchDeviation(**kw)


def n_parameters(readings: list[WheelReading]) -> int:
    """Free flank positions of the wheels fitted (the basis of ``pitch_pattern`` less the held teeth)."""
    return sum(pattern_basis(r.teeth, r.long_wave).shape[1] - len(r.fixed) for r in readings if r.applies)


def path_factors(
    cal: Calibrator, base: ModelFeatures, pattern: list[list[np.ndarray]], score: Score
) -> tuple[list[list[np.ndarray]], int]:
    """Factors on the pattern's order features, per feature, and how many were fitted.

    Per channel, shaft and band (the shaft's low orders, then each mesh harmonic's sidebands) one real factor
    in ``[0, MAX_PATH_FACTOR]``, fitted by weighted least squares (the current noise and tolerance) on the
    record: the two models' lateral modes place the bearing and housing channels' response differently
    (Sec. 8.25), and the pulse's shape within the engagement (the model's shares jump, a real pair's load
    rises smoothly) sets the higher mesh harmonics' sidebands (as a damaged tooth's, ``tooth_band_shape.py``).
    At the DTE (the mesh itself, quasi-static) the low orders and the first carrier's sidebands take the
    model's response (factor 1), the bands from :data:`DTE_FITTED_BAND` on a fitted factor.
    """
    cmp = cal.cmp
    out: list[list[np.ndarray]] = []
    n_fit = 0
    for c, name in enumerate(cmp.names):
        row = []
        for s, sh in enumerate(cmp.shafts):
            p = pattern[c][s]
            fac = np.ones(p.shape)
            band = np.rint(np.asarray(sh.orders, dtype=float) / max(int(sh.teeth), 1)).astype(int)
            # the DTE is the mesh itself: its low orders and first carrier's sidebands as the model gives them
            fitted = band >= DTE_FITTED_BAND if name.startswith("dte") else np.ones(p.shape, dtype=bool)
            if fitted.any():
                g = cmp.order_gain(score.gains, c, s)
                mg = g * base.order[c][s]
                w = 1.0 / np.maximum(cmp.order_sigma2(c, s, mg), 1e-300)
                gp = g * p
                for b in np.unique(band[fitted]):
                    m = band == b
                    n_fit += 1
                    den = float(np.sum(w[m] * np.abs(gp[m]) ** 2))
                    num = float(np.sum(w[m] * np.real(np.conj(gp[m]) * (cmp.d_order[c][s][m] - mg[m]))))
                    fac[m] = float(np.clip(num / den, 0.0, MAX_PATH_FACTOR)) if den > 0 else 0.0
            row.append(fac)
        out.append(row)
    return out, n_fit


def pitch_round(
    cal: Calibrator,
    accepted: list[Effect],
    baseline_updates: list[FoundEffect],
    cur_raw: np.ndarray,
    cur_feat: ModelFeatures,
    cur_score: Score,
) -> tuple[np.ndarray, ModelFeatures, Score]:
    """Read the wheels' pitch deviations on the model with the effects found and report them as a baseline
    update where the rule of the module docstring holds; the new ``(raw, features, score)``.

    The pattern is synchronous with its wheel: it enters the order features (its path to the bearing and
    housing channels scaled by :func:`path_factors`), not the envelope's input (every shaft's synchronous
    part is removed there). The search is over: the calibrator's baseline is left as it was, so that the
    checks after the search run the model they judged. ``accepted`` holds the screened effects first
    (``cal.pre_effects``), as in ``Calibrator.run``.
    """
    from gear_rotor_sim.calibration.fit_types import FoundEffect
    from gear_rotor_sim.calibration.residual import ModelFeatures

    if not cal.fit.pitch_pattern or "order" not in cal.cmp.families:
        return cur_raw, cur_feat, cur_score
    c = _dte_index(cal)
    if c is None:
        return cur_raw, cur_feat, cur_score
    readings = read_wheels(cal, cal.runner.outputs(cur_raw)[:, c], accepted)
    if not readings:
        return cur_raw, cur_feat, cur_score
    text = "; ".join(r.text() for r in readings)
    eff = pattern_effect(cal, readings)
    if eff is None:
        cal.notes.append(f"pitch deviations not read (rule: pitch_baseline.py): {text}")
        return cur_raw, cur_feat, cur_score
    held = [b for b in cal.baseline if not isinstance(b, PitchDeviation)]
    own = [e for e in accepted if not any(e is p for p in cal.pre_effects)]
    raw = cal.runner.force_signals((*held, eff, *cal.pre_effects, *own))
    with_pattern = cal._features(raw)
    pattern = [
        [a - b for a, b in zip(xa, xb, strict=True)]
        for xa, xb in zip(with_pattern.order, cal._features(cur_raw).order, strict=True)
    ]
    fac, n_fac = path_factors(cal, cur_feat, pattern, cur_score)
    order = [
        [o + f * p for o, f, p in zip(os_, fs_, ps_, strict=True)]
        for os_, fs_, ps_ in zip(cur_feat.order, fac, pattern, strict=True)
    ]
    feat = ModelFeatures(order, cur_feat.analytic, cur_feat.static)
    score = cal.cmp.score(feat)
    k = n_parameters(readings) + n_fac
    gain = cur_score.balanced_chi2 - score.balanced_chi2
    penalty = k * math.log(max(cur_score.n_total, 2))
    fam = ", ".join(
        f"{f} {math.sqrt(cur_score.chi2[f] / cur_score.n[f]):.3g} -> "
        f"{math.sqrt(score.chi2[f] / score.n[f]):.3g}"
        for f in score.chi2
        if score.n.get(f, 0) > 0 and cur_score.n.get(f, 0) > 0
    )
    cal.log(f"pitch_deviation: error {cur_score.error:.3g} -> {score.error:.3g} ({fam})")
    if gain <= penalty:
        cal.notes.append(
            f"pitch deviations read but not kept: chi^2 {cur_score.balanced_chi2:.4g} -> "
            f"{score.balanced_chi2:.4g} "
            f"does not beat the penalty {penalty:.4g} of {k} parameters ({text})"
        )
        return cur_raw, cur_feat, cur_score
    baseline_updates.append(
        FoundEffect(
            "pitch_deviation",
            eff.label,
            dict(eff.parameters()),
            {},
            1.0,
            float(gain - penalty),
            float(gain / max(cur_score.balanced_chi2 - cur_score.n_total, 1e-12)),
            cur_score.error,
            score.error,
            eff,
            "baseline",
        )
    )
    flanks = "; ".join(
        f"{w}: " + " ".join(f"{1e6 * v:.2f}" for v in getattr(eff, f"{w}_m"))
        for w in ("pinion", "gear")
        if getattr(eff, f"{w}_m")
    )
    cal.notes.append(
        f"pitch deviations read from the DTE's synchronous averages (a baseline of the machine, error "
        f"{cur_score.error:.3g} -> {score.error:.3g}; by family {fam}): {text}; their path to the other "
        f"channels scaled per band by factors in [0, {MAX_PATH_FACTOR:g}] ({n_fac} fitted). Flank positions "
        f"on the line of action, um, tooth 1 first: {flanks}"
    )
    return raw, feat, score
