"""Depth of a named damaged tooth from its transmission-error comb (issue 11;
docs/history/calibration_sessions.md Sec. 8.25).

Where the teeth stay in contact and the record holds the DTE, the depth of the tooth named by the
fit is read again from the DTE's low sideband families of the damaged wheel's synchronous average
(:mod:`.features_dte_depth`: transfer-free, quasi-static, one depth per family and their median):

1. the record's family amplitudes, with jackknife standard errors;
2. the model's from full runs of the current machine (baseline updates, accepted effects) with the
   named tooth at the depths of :data:`~.features_sidebands.DEPTH_GRID` (the same runs as the ratio
   depth's, cached);
3. the depth from each family's amplitude on the model's rising branch, and their median.

The pulse is ``F / k`` times a function of the depth, so the reading is only as good as the model's
static mesh compliance. The record's own dynamics do not identify the mesh scale where the teeth stay in
contact (Sec. 8.7), and fitted on the whole record with the DTE depth held it ran to x1.68-x1.69 on the
two x1.6 held-out records (the two models' mean-stiffness ratio is 1.342; depths then +12 % / +14 %,
the gear tooth lost to the runner-up). So the DTE depth is read on the current machine, or, where the
sideband-ratio depth and the mesh scale fitted with it explain the whole record better than the
absolute depth (``candidates_tooth.py`` step 6), at that mesh scale, which goes with the tooth into
``baseline_updates`` as before. The caller (``Calibrator._refine``) takes this depth in place of the
absolute and the ratio depths: the absolute depth's whole-record minimum is pulled by the transfer paths
of the bearing and housing channels, the ratio depth by the stiffness-variation shape of the carriers
(Sec. 8.25). The tooth at the DTE depth must be confirmed by the whole record as the caller's acceptance
does; otherwise the candidate of the rules before is verified in its place (:func:`confirmed_or_fallback`).

Also applied against a held reference when the reference numerics take the exact modal map
(``ResidualSettings.reference_exact_map``, off by default; session 12, Sec. 8.27): there the depth is read
on the reference-updated machine, whose mesh scale is the reference's *dynamic* one (x1.11 on the independent
2000 rpm record with the converged map, against the two models' mean-stiffness ratio 1.342). Measured on
the table's contact tooth records with the held mesh stiffness between x1.111 and x1.342, the DTE depth
moves as ``s^0.6``, the absolute depth as ``s^1.2-1.3`` (nearly ``F / k``): the comb halves the depth's
dependence on the held scale, it does not remove it. It was off against a reference in session 11
because the held-out x1.6 pinion tooth (0.64) lost its error halving at the DTE depth against the 64-step
Newmark reference; traced to that reference's mesh damping (x1.0; the converged reference fits x1.7, and
with it the row halves), not to this rule.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from gear_rotor_sim.calibration.baseline_mesh_inertia import inertia_for_dte_depth
from gear_rotor_sim.calibration.candidates_tooth import (
    ratio_depth_in_contact,
    wheel_shaft,
)
from gear_rotor_sim.calibration.candidates_tooth_share import min_share
from gear_rotor_sim.calibration.features_dte_depth import DteDepthFit, depth_from_dte, dte_tooth_signature
from gear_rotor_sim.calibration.features_sidebands import DEPTH_GRID
from gear_rotor_sim.calibration.features_tooth_window import HALF_WIDTH, MIN_OUTSIDE_SHARE, named_tooth_window
from gear_rotor_sim.faults import Effect, MeshStiffnessDamping, ToothDamage
from gear_rotor_sim.faults.mesh_inertia import MeshInertia

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator, CandidateFit
    from gear_rotor_sim.calibration.residual import Score


@dataclasses.dataclass
class DteDepth:
    """The depth read from the DTE comb of the named tooth."""

    effect: ToothDamage  # the tooth at the DTE depth
    sigma: float  # statistical (families' scatter and noise)
    n_families: int
    absolute_depth: float  # the depth of the absolute features it replaces
    raw: np.ndarray  # full run at the DTE depth (with the mesh set)
    #: the baseline set it was read with: the mesh stiffness scale of the ratio depth, or the gear pair's
    #: inertia that makes the DTE comb and the ratios agree (``baseline_mesh_inertia.py``, Sec. 8.41)
    mesh_set: MeshStiffnessDamping | MeshInertia | None = None


def dte_channel(cal: Calibrator) -> int | None:
    """Index of the record's DTE channel, or None."""
    for i, n in enumerate(cal.cmp.names):
        if n.startswith("dte"):
            return i
    return None


def dte_depth_applies(cal: Calibrator) -> bool:
    """Order features, a DTE channel and the healthy model's teeth in contact; with the baseline fitted on
    this record, or held from a reference fitted and used with the exact modal map
    (``ResidualSettings.reference_exact_map``: the rule is validated against the converged reference
    only; against the 64-step Newmark one the held-out x1.6 pinion tooth loses its error halving,
    Secs. 8.25, 8.27)."""
    held_ok = cal.fit_baseline or bool(cal.reference_numerics and cal.settings.reference_exact_map)
    return bool(
        "order" in cal.cmp.families
        and held_ok
        and dte_channel(cal) is not None
        and ratio_depth_in_contact(cal)
    )


def refine_depth_by_dte(
    cal: Calibrator,
    e: ToothDamage,
    accepted: list[Effect],
    mesh_set: MeshStiffnessDamping | MeshInertia | None = None,
) -> DteDepth | None:
    """Depth of the named tooth ``e`` from the DTE's low sideband families (module docstring).

    Returns None when fewer than three families are read (not significant, or beyond the model's
    rising branch) or the record has no DTE.
    """
    c = dte_channel(cal)
    shaft = wheel_shaft(cal, e)
    if c is None or shaft is None:
        return None
    f_shaft, teeth = shaft
    fs = cal.m.sample_rate_hz

    def runs_at(mesh: tuple[Effect, ...]) -> dict[float, np.ndarray]:
        out = {}
        for d in DEPTH_GRID:
            effects = (*mesh, *accepted, dataclasses.replace(e, depth=d)) if d > 0 else (*mesh, *accepted)
            out[d] = cal.runner.outputs(cal._raw(effects))[:, c]
        return out

    if mesh_set is None and cal.fit.mesh_inertia_from_comb:
        # the gear inertia at which the DTE comb and the sideband ratios agree (Sec. 8.41)
        mesh_set = inertia_for_dte_depth(cal, e, accepted)
    pre = (mesh_set,) if mesh_set is not None else ()
    runs = runs_at(pre)
    # the other teeth's pitch errors left out where they outweigh the named tooth (features_tooth_window.py)
    lead = f_shaft * (cal.runner.start_time - float(getattr(cal.m, "t0", 0.0)))
    center, share = named_tooth_window(
        cal.m.data[:, c], runs[DEPTH_GRID[-1]], runs[0.0], fs, f_shaft, teeth, lead
    )
    cal.notes.append(
        f"{e.label}: {100 * share:.2g} % of the DTE's non-carrier {e.wheel} average lies away from the tooth"
        + (
            f" (the other teeth's pitch errors): its comb read within +-{HALF_WIDTH:g} mesh periods of it"
            if center is not None
            else f" (below {100 * MIN_OUTSIDE_SHARE:g} %): the comb read over the whole revolution"
        )
    )
    meas, meas_se = dte_tooth_signature(cal.m.data[:, c], fs, f_shaft, teeth, center_rev=center)
    at_model = None if center is None else (center - lead) % 1.0  # the same angle in the model's runs
    grid = {
        d: dte_tooth_signature(x, fs, f_shaft, teeth, debias=False, center_rev=at_model)[0]
        for d, x in runs.items()
    }
    fit = depth_from_dte(meas, meas_se, grid)
    if fit is None:
        cal.notes.append(f"{e.label}: the DTE comb gives no depth (fewer than 3 sideband families read)")
        return None
    eff = dataclasses.replace(e, depth=round(fit.depth, 4))
    raw = cal._raw((*pre, *accepted, eff))
    cal.notes.append(
        f"{e.label}: depth from the DTE comb of the {e.wheel}'s synchronous average {fit.depth:.3g} +- "
        f"{fit.sigma:.2g} ({_families(fit)}"
        + _with_set(mesh_set)
        + f"); from the absolute features {e.depth:.3g}"
    )
    return DteDepth(eff, fit.sigma, fit.n_families, float(e.depth), raw, mesh_set)


def _with_set(mesh_set: MeshStiffnessDamping | MeshInertia | None) -> str:
    if isinstance(mesh_set, MeshStiffnessDamping):
        return f"; at the mesh scale x{mesh_set.stiffness_scale:.3g} fitted with the ratio depth"
    if isinstance(mesh_set, MeshInertia):
        return f"; with the gear inertia and mesh stiffness x{mesh_set.inertia_scale:.3g} (mesh mode held)"
    return ""


def _families(fit: DteDepthFit) -> str:
    return "families " + ", ".join(
        f"{k + 1}: {v:.3g}" if np.isfinite(v) else f"{k + 1}: -" for k, v in enumerate(fit.per_family)
    )


def take_dte_depth(
    cal: Calibrator, fit: CandidateFit, dd: DteDepth, accepted: list[Effect], fallback: CandidateFit
) -> CandidateFit:
    """The candidate at the DTE depth (on the machine with the mesh set it was read with, if any);
    ``fallback`` is the candidate the rules before chose (the ratio depth with its mesh scale where that
    step was taken, else the absolute depth; :func:`confirmed_or_fallback`)."""
    pre = [dd.mesh_set] if dd.mesh_set is not None else []
    feats = cal._tooth_features(dd.raw, dd.effect, (*pre, *accepted))
    cal._tooth_notes(dd.effect, f"depth {dd.effect.depth:.3g} (DTE comb)")
    unc = {**fit.uncertainty, "depth": dd.sigma}
    return dataclasses.replace(
        fit,
        effect=dd.effect,
        raw=dd.raw,
        score=cal.cmp.score(feats),
        uncertainty=unc,
        feats=feats,
        baseline_set=dd.mesh_set,
        fallback=fallback,
    )


def confirmed_or_fallback(
    cal: Calibrator, ver: CandidateFit, screened: CandidateFit, cur: Score, runner_up: float
) -> CandidateFit:
    """``ver`` (the tooth at its DTE depth) if the whole record confirms it as the caller's acceptance
    does (Delta BIC above the threshold, its share of the excess, ahead of the runner-up); else its
    fallback (the tooth at the ratio depth with its mesh scale, or at the absolute depth), with a note.

    At the right depth the model's signature can explain the record less than at a compromise depth:
    on the x1.6 held-out gear tooth (0.64) the FE model's sidebands of the higher mesh harmonics at the
    DTE depth 0.631 exceed the record's, and the tooth lost to the runner-up; at its absolute depth
    0.449 it is named (Sec. 8.25).
    """
    fb = ver.fallback
    if fb is None:
        return ver
    n = cur.n_total
    dbic = cur.balanced_chi2 - ver.score.balanced_chi2 - screened.k * math.log(n)
    expl = (cur.balanced_chi2 - ver.score.balanced_chi2) / max(cur.balanced_chi2 - n, 1e-12)
    p_sep = 1.0 / (1.0 + math.exp(-max(min((dbic - runner_up) / 2, 700.0), -700.0)))
    ok = dbic > cal.fit.bic_threshold and max(expl, screened.comb_explained) >= min_share(cal, ver.effect)
    if ok and (p_sep >= 0.5 or not math.isfinite(runner_up)):
        return dataclasses.replace(ver, fallback=None)
    cal.notes.append(
        f"{ver.effect.label}: at the DTE depth {ver.effect.depth:.3g} the whole record does not confirm "
        f"the tooth (dBIC {dbic:.4g}, {expl:.2f} of the excess, runner-up dBIC {runner_up:.4g}); verified "
        f"at the depth {fb.effect.depth:.3g} of the rules before (Sec. 8.25) instead"
    )
    return fb
