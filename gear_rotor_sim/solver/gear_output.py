"""Output emission of the gear kernel (numba): a step's outputs, the buffered steps' by one matrix product.

Part of the gear kernel (:mod:`.gear_kernel`; docs/solver.md, "Module layout").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gear_rotor_sim.solver.kernels import _FM


@njit(cache=True, error_model="numpy", _nrt=True)
def _emit_block(
    hbuf: np.ndarray, hb: int, cstack: np.ndarray, dfeed_static: np.ndarray, out: np.ndarray, o0: int
) -> None:
    """Outputs of ``hb`` buffered steps ``[z_r, z_i, beta]`` by one matrix product (BLAS) into
    ``out[o0 : o0 + hb]``, plus the static feed-through (a call every ``hbuf.shape[0]`` steps)."""
    blk = out[o0 : o0 + hb]
    np.dot(hbuf[:hb], cstack, blk)
    no = cstack.shape[1]
    for r in range(hb):
        for c in range(no):
            blk[r, c] += dfeed_static[c]


@njit(cache=True, error_model="numpy", inline="always")
def _copy_int(src: np.ndarray, dst: np.ndarray) -> None:
    for i in range(src.shape[0]):
        dst[i] = src[i]


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _emit_outputs(
    n: int,
    nsteps: int,
    hb: int,
    o0: int,
    ev_step: bool,
    modal: tuple,
    carry: tuple,
    outs: tuple,
    meshw: tuple,
    avg: tuple,
) -> tuple[int, int]:
    """6. The outputs of step ``n`` of ``nsteps``: the per-step mesh arrays (end values; with
    ``event_average`` the mesh channels ``x_n + A_n - (x_{n-1} + x_n) / 2`` on an event step), and
    ``[z_r, z_i, beta]`` (or its event-step average) into the block buffer, emitted by
    :func:`_emit_block` when full or at the chunk's last step. Returns the buffer's fill and the next
    block's first output.

    ``dte`` and the excitation arrays (``dted``, ``kt``, ``et``, ``edt``, ``coef``) given with one
    row instead of ``nsteps`` receive the last step's values only (what the next chunk carries;
    ``NewmarkStepper.run(excitation_rows=False)``): at 20000 rpm the stores of those rows at every
    step were 0.07 us of a 0.27 us regular step (docs/history/solver_sessions.md, "Session 24")."""
    zr, zi = modal[0], modal[1]
    beta_prev = carry[0]
    cstack, dfeed_static, hbuf, out, dte, dted, fmesh, states, kt_out, et_out, edt_out, coef_out = outs[:12]
    dte_ch, fm_ch = outs[12], outs[13]
    d_p, dd_p, _e_p, _ed_p, f_p, s_p = meshw[0]
    kk, ee, ed, coef = meshw[1][0], meshw[1][1], meshw[1][2], meshw[1][3]
    azr, azi, abeta, adf, avg_mode, zsr, zsi, bs, dfs = avg
    nm = d_p.shape[0]
    nb = coef.shape[1]
    na = beta_prev.shape[0]
    no = cstack.shape[1]
    nmode = zr.shape[0]
    n_buf = hbuf.shape[0]
    amode = avg_mode[0]
    o = n - 1
    # the row of dte and of the excitation arrays: every step's, or the last step's only (-1: none)
    od = o if dte.shape[0] == nsteps else (0 if n == nsteps else -1)
    ox = o if kt_out.shape[0] == nsteps else (0 if n == nsteps else -1)
    for i in range(nm):
        if od >= 0:
            dte[od, i] = d_p[i]
        if ox >= 0:
            dted[ox, i] = dd_p[i]
            kt_out[ox, i] = kk[i]
            et_out[ox, i] = ee[i]
            edt_out[ox, i] = ed[i]
            for j in range(nb):
                coef_out[ox, i, j] = coef[i, j]
        fmesh[o, i] = f_p[i]
        states[o, i] = s_p[i]
        if amode > 0:  # x_n + A_n - (x_{n-1} + x_n) / 2 on an event step
            if ev_step:
                dte_ch[o, i] = adf[0, i] + 0.5 * (d_p[i] - dfs[0, i])
                fm_ch[o, i] = adf[1, i] + 0.5 * (f_p[i] - dfs[1, i])
            else:
                dte_ch[o, i] = d_p[i]
                fm_ch[o, i] = f_p[i]
    if no > 0:
        if amode == 2 and ev_step:
            for j in range(nmode):
                hbuf[hb, j] = azr[j] + 0.5 * (zr[j] - zsr[j])
                hbuf[hb, nmode + j] = azi[j] + 0.5 * (zi[j] - zsi[j])
            for q in range(na):
                hbuf[hb, 2 * nmode + q] = abeta[q] + 0.5 * (beta_prev[q] - bs[q])
        else:
            for j in range(nmode):
                hbuf[hb, j] = zr[j]
                hbuf[hb, nmode + j] = zi[j]
            for q in range(na):
                hbuf[hb, 2 * nmode + q] = beta_prev[q]
        hb += 1
        if hb == n_buf or n == nsteps:
            _emit_block(hbuf, hb, cstack, dfeed_static, out, o0)
            o0 += hb
            hb = 0
    return hb, o0
