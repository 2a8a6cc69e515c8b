"""The regular step's fused modal pass at 20000 rpm in four layouts and orders (prints figures; not a test).

Issue 13 (docs/history/solver_sessions.md, "Session 23"). The regular step of the gear kernel ends
with one pass over the forced modes (:func:`gear_rotor_sim.solver.gear_step._update_fused`, one mesh,
no effect columns): ``z <- r z + c0 + sum_q SW_q alpha_q`` and the next step's mesh predictions
``y = Re((V Phi) r z)``. This script times that pass alone on the arrays of a chunk captured from
``Simulator.advance`` (``profile_event_steps.py capture``: paper gearbox, 25 C, DTE only, default
model and dt rule), in a loop whose next column amplitude depends on the last prediction (a chain of
``--chain`` dependent operations stands in for the mesh solve), CPU medians:

``kernel``  the kernel's layout: 16 separate rows (map, static increment, 4 column responses, 2
            prediction rows, real and imaginary parts) and the state in two arrays, one fused loop;
``packed``  the same arithmetic on one (18, nf) array, contiguous by role, and a (2, nf) state;
``two``     ``packed`` as two loops: the update, then the predictions from the new state;
``ahead``   the predictions' modal sum moved off the mesh solve's chain: ``W = Re((V Phi) r r z)``
            from the old state before the solve, then ``y = W + Re((V Phi) r c0) + Re((V Phi) r SW) alpha``
            (a few operations) after it; equal to ``kernel`` to round-off (printed).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/profile_event_steps.py capture /tmp/c20k.pkl``
then ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_modal_pass.py /tmp/c20k.pkl``.
"""

from __future__ import annotations

import argparse
import os
import pickle
import time
from collections.abc import Callable

import numpy as np
from numba import njit

_FM = {"reassoc", "contract", "arcp", "nsz"}  # gear_rotor_sim.solver.kernels._FM


@njit(fastmath=_FM, error_model="numpy", inline="always")
def _columns(y0: float, y1: float, chain: int, al: np.ndarray) -> tuple[float, float, float, float]:
    """The step's four column sums: the first from the predictions through a dependent chain of
    ``chain`` multiply-adds (the mesh solve's place), the others ``al``'s."""
    x = y0 * 1e-3 + y1 * 1e-4
    for _ in range(chain):
        x = x * 0.999 + 1e-9
    return x + al[0], al[1], al[2], al[3]


@njit(fastmath=_FM, error_model="numpy")
def pass_kernel(nrep: int, chain: int, zr: np.ndarray, zi: np.ndarray, rows: tuple, al: np.ndarray) -> float:
    """``kernel``: the loop of ``_update_fused`` (one mesh, no effect columns) on separate rows."""
    rr, ri, c0r, c0i, s0r, s0i, s1r, s1i, s2r, s2i, s3r, s3i, p0r, p0i, p1r, p1i = rows
    y0 = y1 = acc = 0.0
    for _ in range(nrep):
        b0, b1, b2, b3 = _columns(y0, y1, chain, al)
        y0 = y1 = 0.0
        for j in range(zr.shape[0]):
            xr = zr[j]
            xi = zi[j]
            tr = rr[j] * xr - ri[j] * xi + c0r[j] + s0r[j] * b0 + s1r[j] * b1 + s2r[j] * b2 + s3r[j] * b3
            ti = rr[j] * xi + ri[j] * xr + c0i[j] + s0i[j] * b0 + s1i[j] * b1 + s2i[j] * b2 + s3i[j] * b3
            zr[j] = tr
            zi[j] = ti
            y0 += p0r[j] * tr - p0i[j] * ti
            y1 += p1r[j] * tr - p1i[j] * ti
        acc += y0
    return acc


@njit(fastmath=_FM, error_model="numpy", inline="always")
def _mode_packed(
    z: np.ndarray, m: np.ndarray, j: int, b0: float, b1: float, b2: float, b3: float
) -> tuple[float, float]:
    """Mode ``j``'s new amplitude ``r z + c0 + sum_q SW_q b_q`` (real, imaginary) on the packed rows."""
    xr = z[0, j]
    xi = z[1, j]
    tr = m[0, j] * xr - m[1, j] * xi + m[2, j] + m[4, j] * b0 + m[6, j] * b1 + m[8, j] * b2 + m[10, j] * b3
    ti = m[0, j] * xi + m[1, j] * xr + m[3, j] + m[5, j] * b0 + m[7, j] * b1 + m[9, j] * b2 + m[11, j] * b3
    return tr, ti


@njit(fastmath=_FM, error_model="numpy")
def pass_packed(nrep: int, chain: int, z: np.ndarray, m: np.ndarray, al: np.ndarray) -> float:
    """``packed``: the same pass on ``m`` (18, nf) = rr, ri, c0r, c0i, s0r, s0i, ..., s3i, p0r, p0i,
    p1r, p1i and ``z`` (2, nf)."""
    nf = z.shape[1]
    y0 = y1 = acc = 0.0
    for _ in range(nrep):
        b0, b1, b2, b3 = _columns(y0, y1, chain, al)
        y0 = y1 = 0.0
        for j in range(nf):
            tr, ti = _mode_packed(z, m, j, b0, b1, b2, b3)
            z[0, j] = tr
            z[1, j] = ti
            y0 += m[12, j] * tr - m[13, j] * ti
            y1 += m[14, j] * tr - m[15, j] * ti
        acc += y0
    return acc


@njit(fastmath=_FM, error_model="numpy", inline="always")
def _update_packed(z: np.ndarray, m: np.ndarray, b0: float, b1: float, b2: float, b3: float) -> None:
    """``z <- r z + c0 + sum_q SW_q b_q`` on the packed rows (``m`` as :func:`pass_packed`'s)."""
    for j in range(z.shape[1]):
        z[0, j], z[1, j] = _mode_packed(z, m, j, b0, b1, b2, b3)


@njit(fastmath=_FM, error_model="numpy")
def pass_two(nrep: int, chain: int, z: np.ndarray, m: np.ndarray, al: np.ndarray) -> float:
    """``two``: ``packed``'s update, then the predictions in a second loop over the new state."""
    nf = z.shape[1]
    y0 = y1 = acc = 0.0
    for _ in range(nrep):
        b0, b1, b2, b3 = _columns(y0, y1, chain, al)
        _update_packed(z, m, b0, b1, b2, b3)
        y0 = y1 = 0.0
        for j in range(nf):
            y0 += m[12, j] * z[0, j] - m[13, j] * z[1, j]
            y1 += m[14, j] * z[0, j] - m[15, j] * z[1, j]
        acc += y0
    return acc


@njit(fastmath=_FM, error_model="numpy")
def pass_ahead(
    nrep: int, chain: int, z: np.ndarray, m: np.ndarray, q: np.ndarray, hk: np.ndarray, al: np.ndarray
) -> float:
    """``ahead``: ``W = Re(Q z)`` (``q`` (4, nf) the rows of ``Q = (V Phi) r r``) before the stand-in
    solve, then the update and ``y = W + K + H alpha`` (``hk`` (2, 5) = ``H`` then ``K``)."""
    nf = z.shape[1]
    y0 = y1 = acc = 0.0
    for _ in range(nrep):
        w0 = w1 = 0.0
        for j in range(nf):
            w0 += q[0, j] * z[0, j] - q[1, j] * z[1, j]
            w1 += q[2, j] * z[0, j] - q[3, j] * z[1, j]
        b0, b1, b2, b3 = _columns(y0, y1, chain, al)
        _update_packed(z, m, b0, b1, b2, b3)
        y0 = w0 + hk[0, 4] + hk[0, 0] * b0 + hk[0, 1] * b1 + hk[0, 2] * b2 + hk[0, 3] * b3
        y1 = w1 + hk[1, 4] + hk[1, 0] * b0 + hk[1, 1] * b1 + hk[1, 2] * b2 + hk[1, 3] * b3
        acc += y0
    return acc


def variants(path: str) -> tuple[dict[str, Callable[[int, int], float]], int]:
    """The four passes as functions of (repeats, chain) returning the sum of the first mesh's
    predictions over the passes, each from a fresh copy of the captured state."""
    with open(path, "rb") as fh:
        args = pickle.load(fh)
    modal, nf = args[0], int(args[1])
    zr, zi, rr, ri, c0r, c0i, swr2, swi2, crr2, cri2 = modal[:10]
    rows = [rr[:nf], ri[:nf], c0r[:nf], c0i[:nf]]
    for q in range(4):
        rows += [swr2[q, :nf], swi2[q, :nf]]
    rows += [crr2[0, :nf], cri2[0, :nf], crr2[1, :nf], cri2[1, :nf]]
    sep = tuple(np.ascontiguousarray(r) for r in rows)
    m = np.ascontiguousarray(np.array(rows))
    p = np.array([crr2[0, :nf] + 1j * cri2[0, :nf], crr2[1, :nf] + 1j * cri2[1, :nf]])  # (V Phi) r
    r = rr[:nf] + 1j * ri[:nf]
    qc = p * r
    q = np.ascontiguousarray(np.array([qc[0].real, qc[0].imag, qc[1].real, qc[1].imag]))
    h = (p @ (swr2[:, :nf] + 1j * swi2[:, :nf]).T).real
    k = (p @ (c0r[:nf] + 1j * c0i[:nf])).real
    hk = np.ascontiguousarray(np.column_stack([h, k]))
    al0 = np.array([0.0, 0.3, 0.2, 0.1])  # the first column from the predictions alone
    z0 = np.array([zr[:nf], zi[:nf]])

    def kernel(n: int, c: int) -> float:
        return pass_kernel(n, c, z0[0].copy(), z0[1].copy(), sep, al0.copy())

    def packed(n: int, c: int) -> float:
        return pass_packed(n, c, z0.copy(), m, al0.copy())

    def two(n: int, c: int) -> float:
        return pass_two(n, c, z0.copy(), m, al0.copy())

    def ahead(n: int, c: int) -> float:
        return pass_ahead(n, c, z0.copy(), m, q, hk, al0.copy())

    fns: dict[str, Callable[[int, int], float]] = {
        "kernel": kernel,
        "packed": packed,
        "two": two,
        "ahead": ahead,
    }
    return fns, nf


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", help="a chunk from profile_event_steps.py capture")
    ap.add_argument("--repeats", type=int, default=100000, help="passes per timed run")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--chain", type=int, nargs="+", default=[0, 20, 60])
    args = ap.parse_args()
    fns, nf = variants(args.path)
    res = {name: fn(1, 0) for name, fn in fns.items()}  # the first pass's prediction of delta
    print(
        f"{nf} forced modes; load {os.getloadavg()[0]:.1f}; one pass's delta prediction against the kernel's"
    )
    print(
        "  (relative): "
        + ", ".join(f"{k} {abs(v - res['kernel']) / abs(res['kernel']):.1e}" for k, v in res.items())
    )
    for chain in args.chain:
        cpu: dict[str, list[float]] = {name: [] for name in fns}
        for _ in range(args.runs):  # alternated
            for name, fn in fns.items():
                c0 = time.process_time()
                fn(args.repeats, chain)
                cpu[name].append(time.process_time() - c0)
        med = {name: 1e9 * float(np.median(v)) / args.repeats for name, v in cpu.items()}
        print(
            f"chain {chain:3d}: ns per pass (CPU medians of {args.runs}) "
            + ", ".join(f"{k} {v:.1f} (x{med['kernel'] / v:.2f})" for k, v in med.items())
        )


if __name__ == "__main__":
    main()
