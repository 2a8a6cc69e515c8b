"""Per-step excitation of a chunk: mesh phases, what effects see (``StepContext``), their stiffness
factors, transmission errors and force amplitudes (``excitation``, ``effect_columns``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gear_rotor_sim.solver.linear_model import LinearModel
from gear_rotor_sim.system_data import AssembledSystem


@dataclass
class StepContext:
    """What effects see, on the step grid of one chunk (times of the new steps).

    ``shaft_angle`` and ``shaft_speed`` are (n, n_shafts) in rad and rad/s (signed, per shaft);
    ``mesh_phases`` (n, n_meshes) are the mesh phases in [0, 1) and ``mesh_phase`` (n,) the first
    mesh's. Effect terms of the mesh (stiffness factor, transmission error) are returned as (n,)
    (the same for every mesh) or (n, n_meshes).
    """

    t: np.ndarray
    shaft_angle: np.ndarray
    shaft_speed: np.ndarray
    mesh_phase: np.ndarray
    system: AssembledSystem
    mesh_phases: np.ndarray | None = None


def mesh_phases(system: AssembledSystem, angle: np.ndarray) -> np.ndarray:
    """(n, nm) mesh phase in [0, 1) from the integrated input-shaft angle (rad)."""
    out = np.zeros((angle.size, len(system.meshes)))
    for i, m in enumerate(system.meshes):
        ratio = abs(float(system.shaft_speed_ratios[m.pinion_shaft]))
        cyc = m.pinion_teeth * ratio * angle / (2.0 * np.pi)
        out[:, i] = cyc - np.floor(cyc)
    return out


def _effect_call(effect: object, name: str, arg: object) -> np.ndarray | None:
    fn = getattr(effect, name, None)
    if fn is None:
        return None
    res = fn(arg)
    return None if res is None else np.asarray(res, dtype=float)


def make_context(system: AssembledSystem, t: np.ndarray, angle: np.ndarray, speed: np.ndarray) -> StepContext:
    ratios = np.asarray(system.shaft_speed_ratios, float)
    ph = mesh_phases(system, angle)
    return StepContext(
        t,
        angle[:, None] * ratios[None, :],
        speed[:, None] * ratios[None, :],
        ph[:, 0] if ph.shape[1] else np.zeros(t.size),
        system,
        ph,
    )


def _effect_arrays(
    lin: LinearModel,
    t: np.ndarray,
    angle: np.ndarray,
    speed: np.ndarray,
    effects: Sequence[object],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, None, np.ndarray]:
    """Effect contributions at the new steps: stiffness factor (n, nm), added e and e_dot (n, nm),
    force amplitudes (n, ne). Same conventions as :func:`excitation`."""
    system = lin.system
    n = t.size - 2
    nm = lin.nm
    kfac = np.ones((n, nm))
    te = np.zeros((n, nm))
    ted = np.zeros((n, nm))
    ampl = np.zeros((n, lin.ne))
    inner = slice(1, n + 1)
    ctx_full = None
    if nm and any(getattr(eff, "transmission_error", None) is not None for eff in effects):
        # one context over the neighbours too; the inner one is its views (the same elementwise values)
        ctx_full = make_context(system, t, angle, speed)
        ph = ctx_full.mesh_phases
        ctx = StepContext(
            ctx_full.t[inner],
            ctx_full.shaft_angle[inner],
            ctx_full.shaft_speed[inner],
            ctx_full.mesh_phase[inner],
            system,
            None if ph is None else ph[inner],
        )
    else:
        ctx = make_context(system, t[inner], angle[inner], speed[inner])
    j0 = 0
    for eff in effects:
        fac = _effect_call(eff, "mesh_stiffness_factor", ctx)
        if fac is not None and nm:
            kfac *= fac.reshape(n, -1)
        if getattr(eff, "transmission_error", None) is not None and nm:
            if ctx_full is None:
                ctx_full = make_context(system, t, angle, speed)
            te_full = _effect_call(eff, "transmission_error", ctx_full)
            if te_full is not None:
                te_full = te_full.reshape(n + 2, -1)
                te += te_full[1:-1]
                ted += (te_full[2:] - te_full[:-2]) / (t[2:] - t[:-2])[:, None]
        cols = _effect_call(eff, "external_forces", system)
        if cols is not None:
            nj = cols.reshape(system.ndof, -1).shape[1]
            amp = _effect_call(eff, "force_amplitudes", ctx)
            if amp is None:
                raise ValueError(
                    f"effects: {getattr(eff, 'name', eff)!r} has external_forces but no amplitudes"
                )
            ampl[:, j0 : j0 + nj] = amp.reshape(n, nj)
            j0 += nj
    return kfac, te, ted, None, ampl


def excitation(
    lin: LinearModel,
    t: np.ndarray,
    angle: np.ndarray,
    speed: np.ndarray,
    effects: Sequence[object],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-step arrays at the new steps: k (n, nm), e, e_dot (n, nm), coef (n, nm, nb), ampl (n, ne).

    ``t``, ``angle``, ``speed`` are the time (s), integrated input-shaft angle (rad) and input speed
    (rad/s) at the n new steps, plus one step before and one after (n + 2 entries) so that effect
    transmission errors can be differentiated by central differences (second order, consistent
    across chunks).
    """
    system = lin.system
    n = t.size - 2
    nm, nb = lin.nm, lin.nb
    kt = np.zeros((n, nm))
    et = np.zeros((n, nm))
    edt = np.zeros((n, nm))
    coef = np.zeros((n, nm, nb))
    ampl = np.zeros((n, lin.ne))
    if not effects and nm == 0:
        return kt, et, edt, coef, ampl
    inner = slice(1, n + 1)
    ph = mesh_phases(system, angle[inner])
    for i, m in enumerate(system.meshes):
        ratio = abs(float(system.shaft_speed_ratios[m.pinion_shaft]))
        arg = 2.0 * np.pi * ph[:, i] + m.te_phase
        kt[:, i] = m.stiffness(ph[:, i])
        et[:, i] = m.te_amplitude * np.sin(arg)  # Eq 24 with omega t = 2 pi (mesh phase)
        edt[:, i] = m.te_amplitude * np.cos(arg) * m.pinion_teeth * ratio * speed[inner]
        cf = np.asarray(m.force_coefficients(ph[:, i]), float).reshape(n, -1)
        coef[:, i, : cf.shape[1]] = cf
    if effects:
        kfac, te, ted, _, ampl = _effect_arrays(lin, t, angle, speed, effects)
        kt *= kfac
        et += te
        edt += ted
    return kt, et, edt, coef, ampl


def effect_columns(system: AssembledSystem, effects: Sequence[object]) -> np.ndarray | None:
    """(ndof, ne) fixed force vectors of all effects, or None."""
    cols = []
    for eff in effects:
        c = _effect_call(eff, "external_forces", system)
        if c is not None:
            cols.append(c.reshape(system.ndof, -1))
    return np.hstack(cols) if cols else None
