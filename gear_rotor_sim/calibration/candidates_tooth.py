"""Depth of a named damaged tooth from its scale-free signature (issue 11;
docs/history/calibration_sessions.md Sec. 8.10).

Where the record's own dynamics do not identify the mesh stiffness scale (no reference record; at
3000 rpm the fitted scale ranged over x1.10-x1.95 for a physical x1.34, Sec. 8.7), the depth fitted
on absolute amplitudes is read against the wrong ``F / k`` and comes out low (-34 %, -38 % on the
independent records). Once the wheel and tooth are named, the depth is read again from the sideband
energy ratios of that wheel's synchronous average (:mod:`.features_sidebands`), in which the sensor
gain, ``F / k`` and most of the transfer path cancel:

1. the measured ``SER_m`` (mesh harmonics ``m = 1..3``, ``+-6`` sidebands) of every channel, with
   their jackknife standard errors;
2. the model's ``SER_m`` from full simulations of the current machine (baseline updates, the effects
   already accepted) with the named tooth at the depths of :data:`DEPTH_GRID`;
3. a first depth from ``log SER`` with the noise variances and a 5 % floor; the
   :data:`CONTACT_ENSEMBLE` (mesh and bearing stiffness x0.8 / x1.25, mesh damping x0.7 / x1.4) at
   the grid depth nearest to it gives each ratio's model-form spread, and the depth is fitted again
   with it;
4. uncertainty: the statistical part (chi^2 + 1, scaled by the reduced chi^2) and the model-form
   part (the depth each ensemble member's ratios read against the nominal grid), in quadrature;
5. with the depth held, the absolute size of the tooth's signature (``delta0 d``, ``delta0 = F / k``)
   and the carriers identify the mesh stiffness scale: it is fitted on the whole feature set (bounded
   minimisation on full simulations) and goes with the tooth as a baseline update
   (``mesh_stiffness_damping`` in ``baseline_updates``), unless a mesh set is already in the baseline
   or the scale ends at an edge of its range (0.6, 2.0);
6. the ratio depth (with that scale) replaces the absolute one only if it explains the whole record
   better: balanced chi^2 plus ``ln N`` for the scale below that of the absolute depth
   (``Calibrator._refine``). Otherwise the ratios contradict the absolute features even with the
   mesh scale free, and the absolute depth stays (the note gives both).

The ratio depth is offered when the fit uses at least ``MIN_FEATURES`` ratios and its minimum is
inside the grid; the full simulation at that depth is then the candidate's model (its error and
Delta BIC are judged as before). Applied without a held reference baseline (with one the absolute
depth is read against the reference's mesh scale: -1 % / +1 % on the independent records at 3000
rpm). Where the teeth separate (the healthy model's contact-loss fraction above
``features_rattle.MIN_CONTACT_LOSS``; docs/history/calibration_sessions.md Sec. 8.14) the model's ratios come
from full simulations of the rattling model as everywhere (no linear response is assumed), and three things
change: the mesh scale of step 5 is fitted on the candidate's own scoring (bearing path factors and
envelope scatter fitted against the healthy run at that scale, ``Calibrator._tooth_features``); the
tooth must explain the record beyond the healthy model at that scale (``Calibrator._refine``: a mesh
scale moves the whole rattle response); and a sideband family left out as a locked rattle component
(``features_rattle.py`` rule 2) is left out of the ratios.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from gear_rotor_sim.calibration.features_rattle import MIN_CONTACT_LOSS
from gear_rotor_sim.calibration.features_sidebands import (
    CONTACT_ENSEMBLE,
    DEPTH_GRID,
    ensemble_depth_spread,
    ensemble_log_spread,
    fit_depth_from_ratios,
    sideband_energy_ratios,
)
from gear_rotor_sim.faults import Effect, MeshStiffnessDamping, ToothDamage

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator

#: smallest number of significant ratios for the ratio depth to replace the absolute one
MIN_FEATURES = 3


@dataclasses.dataclass
class RatioDepth:
    """The depth read from the sideband energy ratios of the named tooth."""

    effect: ToothDamage  # the tooth at the ratio depth
    sigma: float  # total standard deviation (statistical and model-form in quadrature)
    sigma_model_form: float
    n_features: int
    absolute_depth: float  # the depth from the absolute features it replaces
    raw: np.ndarray  # full simulation at the ratio depth (with the mesh set)
    mesh_set: MeshStiffnessDamping | None = None  # mesh stiffness scale fitted with the depth held


def wheel_shaft_name(cal: Calibrator, e: ToothDamage) -> str:
    """Name of the damaged wheel's shaft."""
    cfg = cal.runner.cfg
    mesh = cfg.meshes[e.mesh - 1]
    node0 = cfg.gear(mesh.pinion if e.wheel == "pinion" else mesh.gear).node0
    return str(cfg.shafts[cfg.shaft_of_node(node0)].name)


def wheel_shaft(cal: Calibrator, e: ToothDamage) -> tuple[float, int] | None:
    """Rotation frequency (Hz) of the damaged wheel's shaft and the wheel's teeth, or None if the
    shaft is not among the order-analysed shafts."""
    cfg = cal.runner.cfg
    mesh = cfg.meshes[e.mesh - 1]
    node0 = cfg.gear(mesh.pinion if e.wheel == "pinion" else mesh.gear).node0
    name = cfg.shafts[cfg.shaft_of_node(node0)].name
    for sh in cal.cmp.shafts:
        if sh.name == name:
            teeth = int(mesh.pinion_teeth if e.wheel == "pinion" else mesh.gear_teeth)
            return sh.ratio * cal.cmp.speed_hz, teeth
    return None


def ratio_depth_applies(cal: Calibrator) -> bool:
    """Order features available, baseline fitted on this record, and either continuous contact or the
    rattle rules in force where the teeth separate (Sec. 8.14: the ratios there are read against full
    simulations of the rattling model, and the whole-record comparison of step 6 scores both depths
    with the bearing path and the envelope scatter fitted)."""
    if "order" not in cal.cmp.families or not cal.fit_baseline:
        return False
    return bool(cal.base_contact_loss <= MIN_CONTACT_LOSS or cal.rattle_rules)


def ratio_depth_in_contact(cal: Calibrator) -> bool:
    """The healthy model's teeth stay in contact (contact-loss fraction at most ``MIN_CONTACT_LOSS``)."""
    return bool(cal.base_contact_loss <= MIN_CONTACT_LOSS)


def _rattling(cal: Calibrator) -> bool:
    return not ratio_depth_in_contact(cal)


def refine_depth_by_ratios(cal: Calibrator, e: ToothDamage, accepted: list[Effect]) -> RatioDepth | None:
    """Depth of the named tooth ``e`` from the sideband energy ratios (module docstring).

    Parameters
    ----------
    cal : Calibrator
        The calibration in progress (its model runner and measured record).
    e : ToothDamage
        The named tooth with its absolute-feature depth.
    accepted : list of Effect
        Effects already accepted (the baseline sets and screened effects are added by ``cal``).

    Returns
    -------
    RatioDepth or None
        None when the ratios do not determine the depth (fewer than ``MIN_FEATURES`` significant
        ratios, or the minimum at an end of the grid).
    """
    shaft = wheel_shaft(cal, e)
    if shaft is None:
        return None
    f_shaft, teeth = shaft
    fs = cal.m.sample_rate_hz
    harmonics, sidebands = cal.settings.mesh_harmonics, cal.settings.sidebands
    # a sideband family left out as a locked rattle component (features_rattle.py) is left out here too
    skip = tuple(getattr(cal.cmp, "locked_families", {}).get(wheel_shaft_name(cal, e), ()))

    def model_ser(effects: tuple[Effect, ...]) -> np.ndarray:
        out = cal.runner.outputs(cal._raw(effects))
        return sideband_energy_ratios(out, fs, f_shaft, teeth, harmonics, sidebands, debias=False, skip=skip)[
            0
        ]

    meas, meas_se = sideband_energy_ratios(cal.m.data, fs, f_shaft, teeth, harmonics, sidebands, skip=skip)

    def at(d: float) -> tuple[Effect, ...]:
        return (*accepted, dataclasses.replace(e, depth=d)) if d > 0 else tuple(accepted)

    grid = {d: model_ser(at(d)) for d in DEPTH_GRID}
    first = fit_depth_from_ratios(meas, meas_se, grid, None, cal.settings.tolerance)
    if first is None:
        return None
    d_ref = min((d for d in DEPTH_GRID if d > 0), key=lambda d: abs(d - first.depth))
    members = [model_ser((*accepted, m, dataclasses.replace(e, depth=d_ref))) for m in CONTACT_ENSEMBLE]
    mf = ensemble_log_spread(grid[d_ref], members)
    fit = fit_depth_from_ratios(meas, meas_se, grid, mf, cal.settings.tolerance)
    if fit is None:
        return None
    rel_mf = ensemble_depth_spread(members, d_ref, grid, mf, cal.settings.tolerance)
    sigma_mf = fit.depth * rel_mf if math.isfinite(rel_mf) else float("nan")
    sigma = math.hypot(fit.sigma, sigma_mf) if math.isfinite(sigma_mf) else fit.sigma
    cal.notes.append(
        f"{e.label}: depth from the sideband energy ratios of the {e.wheel}'s synchronous average "
        f"{fit.depth:.3g} +- {sigma:.2g} (statistical {fit.sigma:.2g}, model-form {sigma_mf:.2g} from the "
        f"{len(CONTACT_ENSEMBLE)}-member ensemble at depth {d_ref:g}; {fit.n_features} ratios, chi2 "
        f"{fit.chi2:.3g}); from the absolute features {e.depth:.3g}"
    )
    if fit.n_features < MIN_FEATURES or fit.at_edge:
        cal.notes.append(
            f"{e.label}: the ratio depth is not used ({fit.n_features} ratios"
            f"{', minimum at the end of the depth grid' if fit.at_edge else ''})"
        )
        return None
    eff = dataclasses.replace(e, depth=round(fit.depth, 4))
    mesh_set, raw = _mesh_scale_at_depth(cal, eff, accepted)
    return RatioDepth(eff, sigma, sigma_mf, fit.n_features, float(e.depth), raw, mesh_set)


#: coarse grid of the mesh stiffness scale (within MeshStiffnessDamping's bounds 0.3-2)
MESH_SCALE_GRID: tuple[float, ...] = (0.6, 0.8, 1.0, 1.25, 1.6, 2.0)


def _mesh_scale_at_depth(
    cal: Calibrator, eff: ToothDamage, accepted: list[Effect]
) -> tuple[MeshStiffnessDamping | None, np.ndarray]:
    """Mesh stiffness scale with the tooth's depth held (step 5): coarse grid, then bounded Brent on
    full simulations. Returns ``(None, raw)`` at scale 1 or when a mesh set is already held."""
    from scipy.optimize import minimize_scalar

    if any(isinstance(b, MeshStiffnessDamping) for b in cal.baseline):
        return None, cal._raw((*accepted, eff))
    memo: dict[float, tuple[float, np.ndarray]] = {}

    def run(sk: float) -> float:
        sk = round(float(sk), 3)
        if sk not in memo:
            mesh = () if sk == 1.0 else (MeshStiffnessDamping(stiffness_scale=sk),)
            effects = (*mesh, *accepted, eff)
            raw = cal._raw(effects)
            # where the teeth separate: scored as the candidate is (bearing path and envelope scatter
            # fitted against the healthy run at that scale)
            feats = (
                cal._tooth_features(raw, eff, (*mesh, *accepted)) if _rattling(cal) else cal._features(raw)
            )
            memo[sk] = (cal.cmp.score(feats).balanced_chi2, raw)
        return memo[sk][0]

    vals = [run(sk) for sk in MESH_SCALE_GRID]
    i = int(np.argmin(vals))
    lo, hi = MESH_SCALE_GRID[max(i - 1, 0)], MESH_SCALE_GRID[min(i + 1, len(MESH_SCALE_GRID) - 1)]
    minimize_scalar(run, bounds=(lo, hi), method="bounded", options={"xatol": 0.01, "maxiter": 6})
    best = min(memo, key=lambda k: memo[k][0])
    if best in (MESH_SCALE_GRID[0], MESH_SCALE_GRID[-1]):
        # at the edge of the range: the truth may lie beyond, nothing is said about the scale
        cal.notes.append(
            f"{eff.label}: mesh stiffness scale at the edge of its range (x{best:.3g}) with the ratio "
            f"depth {eff.depth:.3g} held: not taken"
        )
        return None, memo[1.0][1]
    cal.notes.append(
        f"{eff.label}: mesh stiffness scale x{best:.3g} with the ratio depth {eff.depth:.3g} held (chi2 "
        f"{memo[1.0][0]:.4g} at x1 -> {memo[best][0]:.4g})"
    )
    if best == 1.0:
        return None, memo[best][1]
    return MeshStiffnessDamping(stiffness_scale=best), memo[best][1]
