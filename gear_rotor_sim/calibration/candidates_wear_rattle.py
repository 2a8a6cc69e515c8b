"""Tooth wear where the teeth separate: the rattle amplitude scales with the gap (``--baseline``).

Where the teeth separate (8000 rpm on the paper gearbox) the mesh is a clearance oscillator driven
near its resonance: free flight across the backlash ``2 b``, impacts on both flanks. On the backbone
of such an oscillator the response scales with the gap: its shape (the distribution of the DTE, the
share of time in contact, the ratio of the mesh harmonics) does not move with wear, and its
amplitude at the mesh frequency follows ``A = alpha (b + F0 / k)`` (``F0 = T / r_b`` the static mesh
force: the drive flank is preloaded by ``F0 / k``). Measured on the DTE at 8000 rpm, 25 C
(docs/history/calibration_sessions.md Sec. 8.16): 20 um of wear (``b`` 35 -> 55 um) multiplies the amplitude
by 1.455 in the independent lumped gearbox and by 1.460 in the FE model, where the law gives
``1 + 20 / (35 + 9.2) = 1.45``; kurtosis, quantile ratios and ``H2 / H1`` stay within 1-2 % in both.

``alpha`` is set by the mesh resonance (stiffness, damping): the nominal FE model's is 30 % above the
lumped gearbox's (2.61 against 2.00 um per um), more than 20 um of wear moves the amplitude, so
without a reference the amplitude cannot tell wear from model-form error and nothing is claimed
from it (no scale-free measure of the record separates them either: docs/history/calibration_sessions.md
Sec. 8.20). A healthy reference record of the same machine (``--baseline``, any speed; the benchmark's is at
2000 rpm, teeth in contact) carries the mesh stiffness and damping scales, and with them ``alpha``
only as far as it identifies them: the reference fitted at 32 steps per mesh (mesh x1.31, damping
x1.7) put the model's healthy amplitude within 3.5 % of the lumped record's and the law read 22.8 um
for 20; the one fitted at 64 steps (main since session 9: x1.20, x1.0; the stiffness 11 % below the
two models' mean-stiffness ratio) puts it 17 % above, and the law reads 10-12 um (Sec. 8.20). The
depth is only as good as the reference's ``alpha``.

Rule (:func:`screen_wear_on_rattle_amplitude`; a held reference baseline, the healthy model's teeth
separating, a DTE channel): the record's DTE amplitude at the first mesh order ``A_d`` against the
healthy model's ``A_m`` must stand more than :data:`Z_TRIGGER` standard deviations above it (noise,
the spread of that amplitude over the baseline ensemble of ``features_rattle.py``,
:func:`amplitude_spread`, and the contact model-form tolerance, 5 %, on ``A_m``; not the spread of
the complex coefficient, which counts its phase too, nor the channel's rattle tolerance of rule 3,
the median over all its orders, which the rattle products with their 100-400 % spread set); the
depth is ``h = (A_d / A_m - 1) (b + F0 / k)`` with ``b`` the model's half backlash and ``k`` its mean
mesh stiffness (baseline scale applied); the full run at ``h`` must improve the balanced chi^2
beyond the BIC threshold and lower the main (family-balanced) error. It is found before the
rounds, like the DTE-mean wear in contact (``candidates_wear_reference.py``).

A healthy reference recorded where the teeth separate does carry ``alpha`` (session 12,
docs/history/calibration_sessions.md Sec. 8.26): fitted there, it saves its DTE amplitude at the first mesh
order and its model's (``ReferenceBaseline.rattle_amplitude``), and at the same operating point the rule reads
against the model's amplitude times their ratio (:func:`rattle_scale`): 19-22 um for 20 on the
independent records, 23 um on the FE model's own, healthy records 0.4-0.9 sd. The claim then still
needs the full run to lower the error, which by the oracle of Sec. 8.26 the right depth hardly does at
rattle (3.58 -> 3.49 at 20 um on the benchmark record): measured, it is refused on the independent
records (the error rises by 0.01, the DTE mean) and on the FE model's own 2 s record (dBIC 5 < 10).

Why the law and not the model's own worn runs for the depth: the reference-updated FE model (damping
x1.7 at its grid bound) grows less with wear than both the law and the lumped record (x1.39 at
22.8 um), and from the static equilibrium it is bistable above 15 um (a small-amplitude branch, DTE
mean 27-43 um). A gearbox wears over millions of mesh cycles and stays on its branch, so wear runs
at rattle start on the healthy branch (``ModelRunner.grown_effects``: whole hunting periods without
the wear, then with it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from gear_rotor_sim.calibration.candidates_wear_reference import dte_channel
from gear_rotor_sim.calibration.features_rattle import ENSEMBLE
from gear_rotor_sim.faults import MeshStiffnessDamping, ToothWear

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.residual import Score

#: the healthy model's teeth must separate (contact-loss fraction of its run above this)
MIN_CONTACT_LOSS = 0.01
#: the record's amplitude must stand this many standard deviations above the model's
Z_TRIGGER = 3.0
#: relative model-form tolerance of an amplitude compared at the contact tolerance (``ResidualSettings``'s
#: default ``tolerance``; the sensor gain of the contract is known to +-3 %)
CONTACT_TOLERANCE = 0.05
#: a reference's rattle amplitude scale is carried to records within this relative speed and this
#: temperature difference of its own operating point (:func:`rattle_scale`)
SAME_SPEED = 0.01
SAME_TEMPERATURE_C = 10.0


def wear_from_amplitude(a_record: float, a_model: float, half_backlash_m: float, preload_m: float) -> float:
    """Wear depth from the rattle amplitude law ``A = alpha (b + F0/k)``, m (negative: smaller gap).

    Parameters
    ----------
    a_record, a_model : float
        DTE amplitude at the mesh frequency of the record and of the healthy model.
    half_backlash_m : float
        The model's half backlash ``b`` at the operating temperature, m.
    preload_m : float
        The static mesh deflection ``F0 / k``, m.
    """
    if not (a_model > 0 and half_backlash_m + preload_m > 0):
        raise ValueError(
            f"a_model: {a_model!r} and half_backlash_m + preload_m: {half_backlash_m + preload_m!r} "
            "must be > 0"
        )
    return (a_record / a_model - 1.0) * (half_backlash_m + preload_m)


def amplitude_spread(nominal: float, members: Sequence[float]) -> float:
    """Root mean square deviation of the members' amplitudes from the nominal one.

    The trigger compares amplitudes (``|c|``), so its model-form uncertainty is the spread of the
    amplitude over the baseline ensemble, not that of the complex coefficient (``features_rattle``
    rule 1 for the order features), which also counts the coefficient's phase: at 8000 rpm on the
    independent wear record against the held 2000 rpm reference the complex spread of the DTE's first
    mesh order is 10.3 % of it, the amplitude's 5.6 % (docs/history/calibration_sessions.md Sec. 8.20).
    """
    m = np.asarray(list(members), dtype=float)
    if m.size == 0:
        return 0.0
    return float(np.sqrt(np.mean((m - float(nominal)) ** 2)))


def gap_and_preload(cal: Calibrator, mesh: int) -> tuple[float, float]:
    """The model's half backlash ``b`` (thermal, at the operating temperature) and ``F0 / k`` of ``mesh``,
    with the baseline and the screened effects applied."""
    from gear_rotor_sim.calibration.residual import cached_system

    effects = (*cal.baseline, *cal.pre_effects)
    cfg = cal.runner.cfg
    temp = cal.m.operating_point.temperature_c
    speed = cal.m.operating_point.speed_rpm
    for e in effects:
        cfg = e.modify_config(cfg)
        fn = getattr(e, "operating_point", None)
        if fn is not None:
            speed, temp = fn(speed, temp)
    sysm = cached_system(cfg, temp).meshes[mesh - 1]
    scale = math.prod(e.stiffness_scale for e in effects if isinstance(e, MeshStiffnessDamping))
    torque = float(cfg.load.torque_nm) if cfg.load is not None else 0.0
    k = scale * float(sysm.mean_stiffness)
    return float(sysm.half_backlash), torque / float(sysm.base_radius_gear) / k


def dte_mesh_amplitudes(cal: Calibrator) -> tuple[float, float, float, float] | None:
    """The DTE's first-mesh-order amplitude of the record and of the healthy (baseline-updated) model,
    the noise variance of the record's coefficient and the amplitude's spread over the baseline
    ensemble (:func:`amplitude_spread`; the runs of ``features_rattle`` rule 1, cached). None without a
    single mesh, a DTE channel, the order family or teeth separating in the healthy model."""
    if "order" not in cal.cmp.families or not getattr(cal, "_at_rattle", False):
        return None
    if not cal.base_contact_loss > MIN_CONTACT_LOSS or len(cal.runner.cfg.meshes) != 1:
        return None
    c = dte_channel(list(cal.cmp.names), 1, 1)
    sh = next((s for s, x in enumerate(cal.cmp.shafts) if x.teeth), None)
    if c is None or sh is None:
        return None
    orders = np.asarray(cal.cmp.shafts[sh].orders)
    hit = np.flatnonzero(orders == cal.cmp.shafts[sh].teeth)
    if hit.size == 0:
        return None
    i = int(hit[0])
    a_m = float(abs(cal._features(cal.base_raw).order[c][sh][i]))
    a_d = float(abs(cal.cmp.d_order[c][sh][i]))
    spread = amplitude_spread(a_m, [abs(cal._features(cal._raw((e,))).order[c][sh][i]) for e in ENSEMBLE])
    return a_d, a_m, float(cal.cmp.v_order[c][sh][i]), spread


def rattle_reference_amplitude(cal: Calibrator) -> dict[str, float] | None:
    """What a healthy reference record where the teeth separate carries for the rattle amplitude law
    (``ReferenceBaseline.rattle_amplitude``): its DTE amplitude at the first mesh order, the
    reference-updated model's, and the spread of the model's over the baseline ensemble, m. None where
    the reference's healthy model stays in contact or has no DTE channel."""
    amp = dte_mesh_amplitudes(cal)
    if amp is None:
        return None
    a_d, a_m, v, spread = amp
    return {"record_m": a_d, "model_m": a_m, "noise_m": math.sqrt(max(v, 0.0)), "spread_m": spread}


def rattle_scale(
    reference: dict[str, Any] | None, speed_rpm: float, temperature_c: float
) -> tuple[float, float, str]:
    """The rattle amplitude scale ``alpha_machine / alpha_model`` carried by a reference record where
    the teeth separate at the record's operating point, its relative standard deviation, and why it
    is not used ('' when it is).

    The ratio of the reference record's DTE amplitude at the first mesh order to the reference-updated
    model's. It is used only if the reference's amplitude stands within :data:`Z_TRIGGER` standard
    deviations (noise, the baseline ensemble's spread of the model amplitude, the contact tolerance)
    of its model's: the healthy machine and the model are then on the same rattle branch, and the
    ratio measures the model's ``alpha`` error. Beyond, the reference sits on another branch of the
    clearance oscillator (measured on the independent gearbox: healthy at 7500 rpm a 11 um response
    against the model's 41 um, docs/history/calibration_sessions.md Sec. 8.26) and says nothing about
    ``alpha``.

    Only at the same operating point (speed within :data:`SAME_SPEED`, temperature within
    :data:`SAME_TEMPERATURE_C`): how the model's ``alpha`` error changes with the speed is not known.
    Measured on the independent gearbox against a reference fitted at 8500 rpm (mesh x1.46, damping
    x1.7): the ratio is x1.13 there and x1.03 at 8000 rpm, and a 20 um depth read with it is -25 %
    (the law multiplies a ratio error by ``A_d / (A_d - A_m)``, 3 at 20 um).
    """
    amp = (reference or {}).get("rattle_amplitude")
    if not isinstance(amp, dict):
        return math.nan, math.nan, "the reference's teeth stay in contact: no rattle amplitude carried"
    op = (reference or {}).get("operating_point") or {}
    sp, tc = float(op.get("speed_rpm", math.nan)), float(op.get("temperature_c", math.nan))
    if not (abs(sp - speed_rpm) <= SAME_SPEED * speed_rpm and abs(tc - temperature_c) <= SAME_TEMPERATURE_C):
        return (
            math.nan,
            math.nan,
            f"the reference's rattle amplitude is carried at its own operating point only ({sp:g} rpm, "
            f"{tc:g} C)",
        )
    a_r, a_m = float(amp["record_m"]), float(amp["model_m"])
    sd = math.sqrt(amp["noise_m"] ** 2 + amp["spread_m"] ** 2 + (CONTACT_TOLERANCE * a_m) ** 2)
    if not (a_r > 0 and a_m > 0 and sd > 0):
        return math.nan, math.nan, "the reference's rattle amplitude is not positive"
    z = abs(a_r - a_m) / sd
    if z > Z_TRIGGER:
        return (
            math.nan,
            math.nan,
            f"the reference record's DTE amplitude ({1e6 * a_r:.3g} um) stands {z:.3g} sigma from its "
            f"model's ({1e6 * a_m:.3g} um): another rattle branch, alpha not carried",
        )
    rel = math.sqrt(amp["noise_m"] ** 2 + (CONTACT_TOLERANCE * a_r) ** 2) / a_r
    return a_r / a_m, rel, ""


def screen_wear_on_rattle_amplitude(cal: Calibrator, score: Score) -> tuple[ToothWear, Score, float] | None:
    """Wear depth from the DTE amplitude at the mesh frequency against a held reference baseline where
    the teeth separate (module docstring). Returns (effect, its full score, standard deviation of the
    depth) or None; reasons a user needs go to ``cal.notes``."""
    if cal.fit_baseline:
        return None
    cand = next((e for e in cal.candidates if isinstance(e, ToothWear)), None)
    if cand is None:
        return None
    amp = dte_mesh_amplitudes(cal)
    if amp is None:
        return None
    a_d, a_m, v_d, spread = amp
    op = cal.m.operating_point
    scale, rel, why = rattle_scale(cal.baseline_reference, op.speed_rpm, op.temperature_c)
    if np.isfinite(scale):
        # alpha measured on a reference record where the teeth separate: the model's amplitude times the
        # reference's ratio; the ensemble spread is replaced by the ratio's own uncertainty
        a_m *= scale
        var = v_d + (CONTACT_TOLERANCE * a_m) ** 2 + (rel * a_m) ** 2
        route = f"the reference's rattle amplitude scale x{scale:.3g}"
    else:
        # noise, the spread of this amplitude over the baseline ensemble (features_rattle rule 1; the
        # same cached runs) and the contact model-form tolerance
        var = v_d + (cal.cmp.s.tolerance * a_m) ** 2 + spread**2
        route = f"the reference-updated model's alpha ({why})"
    sd = math.sqrt(var)
    if not (np.isfinite(sd) and sd > 0 and a_m > 0):
        return None
    b, pre = gap_and_preload(cal, cand.mesh)
    h = wear_from_amplitude(a_d, a_m, b, pre)
    sd_h = sd / a_m * (b + pre)
    z = (a_d - a_m) / sd
    #: what the rule read, claimed or not (tests and notes)
    cal.rattle_wear_reading = {"wear_depth_m": h, "sigma_m": sd_h, "z": z, "route": route}
    if not z > Z_TRIGGER:
        if a_d > a_m:
            cal.notes.append(
                f"wear from the rattle amplitude: the DTE at the mesh frequency stands {z:.3g} "
                f"sigma above the reference-updated model ({1e6 * a_d:.3g} against {1e6 * a_m:.3g} um, "
                f"sigma {1e6 * sd:.3g} um; {route}), below the trigger of {Z_TRIGGER:g}: not read as wear"
            )
        return None
    upper = cand.specs[0].upper
    if not 0.0 < h < 0.99 * upper:
        return None
    eff = cand.with_parameters(wear_depth_m=h)
    sc = cal.cmp.score(cal._features(cal._raw((eff,))))
    dbic = score.balanced_chi2 - sc.balanced_chi2 - math.log(score.n_total)
    if dbic <= cal.fit.bic_threshold:
        cal.notes.append(
            f"wear from the rattle amplitude: the DTE at the mesh frequency stands {z:.3g} "
            f"sigma above the reference-updated model ({1e6 * a_d:.3g} against {1e6 * a_m:.3g} um), i.e. "
            f"{1e6 * h:.3g} um of wear by A = alpha (b + F0/k), but the full features do not gain beyond "
            f"the BIC threshold (dBIC {dbic:.3g} <= {cal.fit.bic_threshold:g}): not claimed"
        )
        return None
    if not sc.error < score.error:
        # the claim must lower the main metric it is reported with (family-balanced): at rattle the worn
        # FE model's DTE mean rises 4x faster than the independent record's
        # (docs/history/calibration_sessions.md Sec. 8.16)
        fam = ", ".join(
            f"{f} {math.sqrt(score.chi2[f] / score.n[f]):.3g} -> {math.sqrt(sc.chi2[f] / sc.n[f]):.3g}"
            for f in score.chi2
            if score.n.get(f, 0) > 0 and f in sc.chi2
        )
        cal.notes.append(
            f"wear from the rattle amplitude: {1e6 * h:.3g} um by A = alpha (b + F0/k) (the DTE at the mesh "
            f"frequency {z:.3g} sigma above the reference-updated model; {route}), dBIC {dbic:.3g}, "
            f"but the error gets worse ({score.error:.3g} -> {sc.error:.3g}; by family {fam}): not claimed"
        )
        return None
    cal.notes.append(
        f"wear from the rattle amplitude: DTE at the mesh frequency {1e6 * a_d:.3g} um against "
        f"{1e6 * a_m:.3g} um of the reference-updated model ({z:.3g} sigma; {route}); "
        f"h = (A_d / A_m - 1)(b + F0/k), b = {1e6 * b:.3g} um, F0/k = {1e6 * pre:.3g} um "
        "(candidates_wear_rattle.py)"
    )
    return eff, sc, sd_h
