"""``average_table_jumps`` of the gear kernel (numba): a step whose only events are table jumps taken
whole with the tables' average over the step (docs/solver.md, "Events inside a step", "Session 11").

Part of the gear kernel (:mod:`.gear_kernel`; docs/solver.md, "Module layout").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gear_rotor_sim.solver.gear_mesh_solve import _set_columns, _state_force
from gear_rotor_sim.solver.gear_tables import _tables_at
from gear_rotor_sim.solver.kernels import _FM


@njit(cache=True, fastmath=_FM, error_model="numpy", _nrt=False)
def _jump_average_start(
    n: int,
    pha: np.ndarray,
    exc: tuple,
    tables: tuple,
    mesh_par: np.ndarray,
    prev: tuple,
    cur: tuple,
    ja: tuple,
) -> None:
    """``average_jumps``: the tables of the meshes with a jump in step ``n`` replaced by their average
    over the step (``cur``'s ``kk``, ``coef``; the step end's kept in ``jk[0]``, ``jc[0]``), and their
    carried columns by those of the start force with the average (the originals kept in ``jc[2]``).

    ``pha`` the meshes' phases at the step start; ``exc``, ``tables``, ``prev`` (per-mesh state at
    the step start), ``cur`` (end values) as in :func:`_event_step`; ``ja`` = (jc, jk, jm): per mesh
    the step end's coefficients, the weighted sums and the saved carried columns (jc, (3, nm, nb));
    the end stiffness, the average, the jump's fraction and phase (jk, (4, nm)); whether the mesh
    has a jump (jm). A call, not inlined: the step loop's regular path keeps its code (and speed)
    when the option is off; without the numba runtime, its tuples of arrays cost no reference count.
    """
    phase, kfac = exc[0], exc[2]
    d_p, dd_p, e_p, ed_p, f_p, s_p = prev
    kk, coef, beta_prev = cur[0], cur[3], cur[4]
    jc, jk, jm = ja
    has_kfac = kfac.shape[0] > 0
    nm = kk.shape[0]
    nb = coef.shape[1]
    for i in range(nm):
        if jm[i] == 0:
            continue
        th = jk[2, i]
        w1 = 0.5 * th
        w2 = 0.5 * (1.0 - th)
        jk[0, i] = kk[i]  # the step end's, kept for the carried force
        for j in range(nb):
            jc[0, i, j] = coef[i, j]
        # pieces: start -> jump (left limit), jump (right limit) -> end; trapezoid each
        k_ = _tables_at(i, phase[n, i], False, tables, coef)
        ksum = w2 * k_
        for j in range(nb):
            jc[1, i, j] = w2 * k_ * coef[i, j]
        k_ = _tables_at(i, pha[i], False, tables, coef)
        ksum += w1 * k_
        for j in range(nb):
            jc[1, i, j] += w1 * k_ * coef[i, j]
        k_ = _tables_at(i, jk[3, i], True, tables, coef)
        ksum += w1 * k_
        for j in range(nb):
            jc[1, i, j] += w1 * k_ * coef[i, j]
        k_ = _tables_at(i, jk[3, i], False, tables, coef)
        ksum += w2 * k_
        for j in range(nb):
            jc[1, i, j] += w2 * k_ * coef[i, j]
        for j in range(nb):
            coef[i, j] = jc[1, i, j] / ksum
        jk[1, i] = ksum
        ka = ksum * kfac[n - 1, i] if has_kfac else ksum
        fa = _state_force(
            s_p[i], d_p[i] - e_p[i], dd_p[i] - ed_p[i], ka, mesh_par[i, 2], mesh_par[i, 3], f_p[i]
        )
        for j in range(nb):
            jc[2, i, j] = beta_prev[i * nb + j]
        _set_columns(i, beta_prev, coef, fa, d_p[i], dd_p[i], mesh_par)
        kk[i] = ksum * kfac[n, i] if has_kfac else ksum


@njit(cache=True, fastmath=_FM, error_model="numpy", _nrt=False)
def _jump_average_end(mesh_par: np.ndarray, prev: tuple, cur: tuple, ja: tuple) -> None:
    """``average_jumps``: after the step, the end force with the end's own tables (``jk[0]``,
    ``jc[0]``), carried (``prev``'s force and ``cur``'s carried columns) into the next step."""
    d_p, dd_p, e_p, ed_p, f_p, s_p = prev
    kk, coef, beta_prev = cur[0], cur[3], cur[4]
    jc, jk, jm = ja
    nm = kk.shape[0]
    nb = coef.shape[1]
    for i in range(nm):
        if jm[i] == 0:
            continue
        kk[i] = jk[0, i]
        for j in range(nb):
            coef[i, j] = jc[0, i, j]
        fb = _state_force(
            s_p[i], d_p[i] - e_p[i], dd_p[i] - ed_p[i], kk[i], mesh_par[i, 2], mesh_par[i, 3], f_p[i]
        )
        f_p[i] = fb
        _set_columns(i, beta_prev, coef, fb, d_p[i], dd_p[i], mesh_par)
