"""Mesh tables and transmission error of the gear kernel (numba): look-up at a mesh phase, and the
transmission error's sin/cos of a chunk.

Part of the gear kernel (:mod:`.gear_kernel`; docs/solver.md, "Module layout"). The tables are
``newmark.split_table_jumps``'s (the ``tables`` tuple of :func:`.gear_kernel.run_chunk_gear`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gear_rotor_sim.solver.kernels import _FM

#: :func:`_te_sin_cos` takes sin/cos directly every this many steps (and where the phase step is
#: larger than 0.25 rad) and rotates by the phase increment in between.
TE_ANCHOR_STEPS = 64
_C4, _C6, _C8, _C10 = 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0, -1.0 / 3628800.0
_S3, _S5, _S7, _S9, _S11 = -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0, -1.0 / 39916800.0


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _table_cell(f: float, nt: int) -> tuple[int, int, float]:
    """Table interval of cycle fraction ``f`` on a periodic table of ``nt`` points: its left and right
    points (wrapped) and the fraction ``fr`` in [0, 1) across it."""
    x = f * nt
    i0 = int(np.floor(x))
    fr = x - i0
    i0 = i0 % nt
    i1 = i0 + 1
    if i1 == nt:
        i1 = 0
    return i0, i1, fr


@njit(cache=True, fastmath=_FM, error_model="numpy", _nrt=False)
def _tables_at(
    i: int,
    f: float,
    strict: bool,
    tables: tuple,
    coef: np.ndarray,
) -> float:
    """Stiffness (returned) and force coefficients (into ``coef[i]``) of mesh ``i`` at cycle fraction
    ``f`` in [0, 1].

    On a table interval without a jump (``jflag == 0``) the full tables are interpolated linearly;
    otherwise, and for ``strict`` (the left limit at a jump phase; at the period wrap ``f = 1``), the
    continuous parts plus the jumps through the periodic steps ``[f >= p] - f``
    (``newmark.split_table_jumps``). Right-continuous.

    Compiled without the numba runtime (``_nrt=False``: it allocates nothing), so that its array
    arguments cost no atomic reference-count increment and decrement per call: with them, the
    calls from the event steps were half of the NRT_incref/NRT_decref calls at 20000 rpm (gdb
    backtraces with NUMBA_DEBUGINFO), and the atomics 20-38 % of the run (perf). The arrays of
    ``tables`` (tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, n_jump) are indexed
    where they are used.
    """
    nt = tables[3].shape[1]
    nb = tables[4].shape[2]
    i0, i1, fr = _table_cell(f, nt)
    if tables[2][i, i0] == 0 and not strict:
        for j in range(nb):
            c0 = tables[1][i, i0, j]
            coef[i, j] = c0 + fr * (tables[1][i, i1, j] - c0)
        k0 = tables[0][i, i0]
        return k0 + fr * (tables[0][i, i1] - k0)
    k0 = tables[3][i, i0]
    k = k0 + fr * (tables[3][i, i1] - k0)
    for j in range(nb):
        c0 = tables[4][i, i0, j]
        coef[i, j] = c0 + fr * (tables[4][i, i1, j] - c0)
    for q in range(tables[8][i]):
        p = tables[5][i, q]
        saw = (1.0 if (f > p or (f == p and not strict)) else 0.0) - f
        k += tables[6][i, q] * saw
        for j in range(nb):
            coef[i, j] += tables[7][i, q, j] * saw
    return k


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _lerp(a: float, b: float, th: float) -> float:
    return b if th == 1.0 else a + th * (b - a)


@njit(cache=True, fastmath=_FM, error_model="numpy", _nrt=False)
def _te_sin_cos(phase: np.ndarray, mesh_par: np.ndarray, out: np.ndarray) -> None:
    """sin and cos of the transmission error's argument ``2 pi phase + phi_te`` (Eq 24) for every
    step and mesh of a chunk into ``out`` ``(n + 1, 2 nm)`` (sin columns, then cos), read by the
    regular steps of :func:`_run_loop` (the event sub-steps evaluate them at their own phases).

    A rotation by the phase increment ``x`` from one step to the next (Taylor series of sin x, cos x
    to x^11 / x^10: exact to round-off for ``|x| <= 0.25``), sin/cos directly every
    ``TE_ANCHOR_STEPS`` steps and wherever the increment is larger: 1e-16-level differences from
    sin/cos at every step, at a fraction of their cost (measured: sin/cos at every step were 15 % of
    the paper gearbox's regular step; NumPy's ``np.sin``/``np.cos`` of the chunk cost as much again).
    """
    nm = phase.shape[1]
    two_pi = 2.0 * np.pi
    for i in range(nm):
        sv = 0.0
        cv = 1.0
        for n in range(phase.shape[0]):
            x = 0.0
            if n > 0:
                x = phase[n, i] - phase[n - 1, i]
                if x < 0.0:
                    x += 1.0
                x *= two_pi
            if n % TE_ANCHOR_STEPS == 0 or x > 0.25:
                arg = two_pi * phase[n, i] + mesh_par[i, 5]
                sv = np.sin(arg)
                cv = np.cos(arg)
            else:
                x2 = x * x
                cx = 1.0 + x2 * (-0.5 + x2 * (_C4 + x2 * (_C6 + x2 * (_C8 + x2 * _C10))))
                sx = x * (1.0 + x2 * (_S3 + x2 * (_S5 + x2 * (_S7 + x2 * (_S9 + x2 * _S11)))))
                sn = sv * cx + cv * sx
                cv = cv * cx - sv * sx
                sv = sn
            out[n, i] = sv
            out[n, nm + i] = cv
