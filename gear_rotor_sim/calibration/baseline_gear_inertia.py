"""The mesh mode against a held reference: the gear pair's inertia read with the named tooth
(docs/history/calibration_sessions.md Sec. 8.71; issue 11).

A reference record fixes what its own features identify. At 2000 rpm the third mesh harmonic lies at
2.9 kHz, far below either model's mesh mode (FE 5.3-6.7 kHz, ``lumped_gearbox`` 6.4 kHz at 75 C), so the
reference's mesh stiffness scale (x1.199 on the table's reference) fixes the static compliance ``F / k``
and nothing of the mode. A record at 4500 rpm places its mesh harmonics' sidebands on the mode (6.1-7.0 kHz
for the third), where a damaged tooth's signature is amplified by it (Sec. 8.35). The FE mode on the
reference-updated machine is not the record's, and the tooth is fitted at the wrong dynamic amplification
(Sec. 8.69: error ratio 0.66 on the held-out 4500 rpm pinion tooth, the gear tooth not named).

With ``F / k`` held, the mode has one free parameter left: the inertia of the gear pair. The gear discs'
mass and inertia times ``s`` (``faults.mesh_inertia.GearInertia``, Sun et al. 2021 Eqs 19-20) move the
mesh mode ``sqrt(k / m_e)`` by ``1 / sqrt(s)`` and leave every static quantity as it was. Without a
reference the same reading is Sec. 8.66's: the record's own mesh set places the mode and the DTE comb sets
``F / k`` through ``MeshInertia``; against a reference ``F / k`` is the reference's and the record places
the mode through ``s``.

The reading (:func:`tooth_with_mode_placed`, ``FitSettings.gear_inertia_with_reference``; called by
``search_rounds.examine_round`` before the share rule): a damaged tooth's candidate, admissible and
significant in its round against a held reference where the teeth stay in contact, is scored on full runs
with the tooth at its ranking depth at the inertia scales 1 and :data:`SCALES`; ``s`` is the vertex of the
parabola in ``log s`` through the three least. Where a scale other than 1 scores least and ``s`` differs
from 1 the tooth is refined on the reference's machine (``Calibrator._refine``, as without this rule) and on
the machine with ``GearInertia(s)`` (its depth from the grid :data:`DEPTHS` first, then the local
refinement). That machine is taken (``s`` goes with the tooth into ``baseline_updates``, never an effect)
only if

1. the tooth with it explains the whole record better than the reference machine's verified tooth by more
   than one parameter's penalty ``ln N`` (BIC, Schwarz 1978), and
2. the tooth explains the record beyond that machine's own healthy run by the acceptance thresholds
   (Delta BIC and share of the excess): the inertia alone must not carry the claim.

Why with the tooth and not on the healthy model: on the 4500 rpm tooth records the healthy model's chi^2 is
flat in ``s`` (within 1.5 % over 0.5-1: the tooth's residual dominates the record), while with the tooth in
the model it changes by a factor 2.5-3.5: what the mode moves most is the tooth's sidebands at the third mesh
harmonic (Sec. 8.71). Where no tooth candidate is examined nothing changes.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from gear_rotor_sim.calibration.candidates_tooth import ratio_depth_in_contact
from gear_rotor_sim.calibration.candidates_tooth_share import min_share
from gear_rotor_sim.calibration.mesh_mode import mesh_mode_hz
from gear_rotor_sim.faults import Effect, MeshStiffnessDamping, ToothDamage
from gear_rotor_sim.faults.mesh_inertia import GearInertia, MeshInertia

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator, CandidateFit

#: gear inertia scales scored with the tooth (1, the reference's machine, is the caller's run); within
#: ``GearInertia``'s bounds 0.5-2, both sides of 1
SCALES: tuple[float, ...] = (1.25, 0.8, 0.65, 0.5)
#: depths scored on the machine with the inertia before the refinement: thirds of the library's range (0-0.9)
DEPTHS: tuple[float, ...] = (0.15, 0.45, 0.75)


def mode_placement_applies(cal: Calibrator, accepted: Sequence[Effect]) -> bool:
    """Against a held reference that carries a mesh stiffness scale, order features, the healthy model's
    teeth in contact, and no inertia set yet (on the machine or among ``accepted``)."""
    if not cal.fit.gear_inertia_with_reference or cal.fit_baseline:
        return False
    if "order" not in cal.cmp.families or not ratio_depth_in_contact(cal):
        return False
    if not any(isinstance(b, MeshStiffnessDamping) for b in cal.baseline):
        return False
    return not any(isinstance(b, GearInertia | MeshInertia) for b in (*cal.baseline, *accepted))


def vertex(points: Sequence[tuple[float, float]], lower: float, upper: float, log: bool = False) -> float:
    """The abscissa at the minimum of the parabola (in ``log x`` if ``log``) through the three lowest of
    ``points`` ``(x, chi2)``, within their span; the best point where the parabola has no minimum;
    clipped to ``[lower, upper]``."""
    best = sorted(points, key=lambda p: p[1])[:3]
    xs = np.array([p[0] for p in best], dtype=float)
    xs = np.log(xs) if log else xs
    vs = np.array([p[1] for p in best])
    x = float(xs[0])
    if len(best) == 3 and np.ptp(xs) > 0:
        c = np.polyfit(xs - xs[0], vs, 2)
        if c[0] > 0:
            # the vertex, within the span of the three points (no extrapolation past the scored ones)
            x = float(np.clip(-c[1] / (2 * c[0]) + xs[0], xs.min(), xs.max()))
    return float(np.clip(math.exp(x) if log else x, lower, upper))


def scale_at_minimum(points: Sequence[tuple[float, float]], lower: float, upper: float) -> float:
    """The inertia scale at the minimum of the parabola in ``log s`` through the three lowest of
    ``points`` ``(s, chi2)`` (:func:`vertex`)."""
    return vertex(points, lower, upper, log=True)


def tooth_with_mode_placed(
    cal: Calibrator, f: CandidateFit, accepted: Sequence[Effect]
) -> tuple[CandidateFit | None, CandidateFit | None]:
    """The round's tooth candidate ``f`` verified on the reference's machine and on the machine whose gear
    inertia places the mesh mode where the record shows it (module docstring).

    Parameters
    ----------
    cal : Calibrator
        The calibration against a held reference (:func:`mode_placement_applies`).
    f : CandidateFit
        A damaged tooth's candidate from the round's ranking (tooth and depth of the shifted-signature
        search, its parameter count ``k``).
    accepted : sequence of Effect
        Effects accepted so far.

    Returns
    -------
    (CandidateFit or None, CandidateFit or None)
        The tooth refined on the current machine (``Calibrator._refine``; None where the scan's least
        chi^2 is at the reference's inertia and it was not run), and the tooth refined with
        ``GearInertia(s)``, which it carries as ``baseline_set`` (None where that machine is not taken).
    """
    e = f.effect
    if not isinstance(e, ToothDamage):
        return None, None
    spec = GearInertia.specs[0]
    pts: list[tuple[float, float]] = []
    for s in (1.0, *SCALES):
        pre = (GearInertia(inertia_scale=s), *accepted) if s != 1.0 else tuple(accepted)
        raw = cal._raw((*pre, e))
        pts.append((s, float(cal.cmp.score(cal._tooth_features(raw, e, pre)).balanced_chi2)))
    s = round(scale_at_minimum(pts, spec.lower, spec.upper), 3)
    scored = ", ".join(f"x{a:g} {b:.4g}" for a, b in sorted(pts))
    temp = cal.m.operating_point.temperature_c
    f0 = mesh_mode_hz(cal.runner.cfg, temp, cal.baseline)
    head = (
        f"{e.label}: gear inertia against the reference, whole record with tooth {e.tooth} at depth "
        f"{e.depth:.3g} by inertia scale: {scored}"
    )
    if min(pts, key=lambda p: p[1])[0] == 1.0 or abs(s - 1.0) < 0.02:
        # no scored scale explains the record better than the reference's (the table's 3000 rpm / 25 C contact
        # teeth: chi2 x1 8684, 6.9e4-9.7e4 elsewhere; a parabola through such a peak is no estimate)
        cal.notes.append(head + f"; the reference's machine kept (FE mesh mode {f0:.0f} Hz)")
        return None, None
    gi = GearInertia(inertia_scale=s)
    plain = cal._refine(f, list(accepted))
    # the depth on that machine from a coarse grid over the library's range first: the ranking's depth
    # was fitted at the misplaced mode (0.043 for 0.4 on a 0.6 s record of the 4500 rpm gear tooth)
    lo, hi = (float(v) for v in (ToothDamage.specs[0].lower, ToothDamage.specs[0].upper))
    at_depth = []
    for d in sorted({*DEPTHS, float(e.depth)}):
        pre = (gi, *accepted)
        ed = dataclasses.replace(e, depth=d)
        at_depth.append(
            (d, float(cal.cmp.score(cal._tooth_features(cal._raw((*pre, ed)), ed, pre)).balanced_chi2))
        )
    start = dataclasses.replace(e, depth=round(vertex(at_depth, lo, hi), 4))
    placed = cal._refine(dataclasses.replace(f, effect=start), [gi, *accepted])
    chi_ref, chi_s = float(plain.score.balanced_chi2), float(placed.score.balanced_chi2)
    f_s = mesh_mode_hz(cal.runner.cfg, temp, [*cal.baseline, gi])
    a, b = placed.effect, plain.effect
    text = (
        f"{head}; x{s:g} (FE mesh mode {f0:.0f} -> {f_s:.0f} Hz): tooth {a.tooth} at depth {a.depth:.3g}, "
        f"chi2 {chi_s:.5g} against {chi_ref:.5g} on the reference's machine (tooth {b.tooth}, depth "
        f"{b.depth:.3g})"
    )
    if not chi_s + math.log(cal.n_total) < chi_ref:
        cal.notes.append(text + "; not taken (not better by the parameter's ln N)")
        return plain, None
    dbic, share = cal._gain_beyond_baseline((gi, *accepted), placed.score, f.k)
    if not (dbic > cal.fit.bic_threshold and share >= min_share(cal, placed.effect)):
        cal.notes.append(
            text + f"; not taken: beyond that machine's healthy run the tooth explains {share:.2f} of the "
            f"excess (dBIC {dbic:.4g})"
        )
        return plain, None
    cal.notes.append(text + f"; taken (beyond that machine's healthy run: {share:.2f} of the excess)")
    return plain, dataclasses.replace(placed, baseline_set=gi)
