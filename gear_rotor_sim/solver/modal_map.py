"""The exact modal Newmark step map at one (basis, dt, channel set) (``StepMap``, ``step_map``), and
the modal reduction with static correction (``reduce_basis``, ``residual_flexibility``;
docs/solver.md, "Modal reduction")."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from gear_rotor_sim.solver.arrays import aligned
from gear_rotor_sim.solver.channels import ChannelSpec
from gear_rotor_sim.solver.linear_model import LinearModel
from gear_rotor_sim.solver.modal_basis import Basis


@dataclass
class StepMap:
    """Everything the kernel needs at one (basis, dt, channel set)."""

    dt: float
    dense: bool
    rr: np.ndarray
    ri: np.ndarray
    tmat: np.ndarray
    swr: np.ndarray
    swi: np.ndarray
    crr: np.ndarray
    cri: np.ndarray
    pq: np.ndarray
    outr: np.ndarray
    outi: np.ndarray
    dfeed: np.ndarray
    basis: Basis
    nmode: int
    # modal reduction: static response of the dropped modes to the column amplitudes, (nstate, m)
    resid: np.ndarray | None = None
    # (Re Phi^T, Im Phi^T, R^T) for ``kernels.modal_to_physical``, built on first use
    xrec: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    exact: bool = False  # the exact modal propagator instead of Newmark's map (step_map)


def reduce_basis(basis: Basis, cutoff_hz: float) -> tuple[Basis, np.ndarray]:
    """The kept modes with ``|lambda| <= 2 pi cutoff_hz`` (forced ones first, as in ``basis``), and the
    positions of the dropped ones in ``basis``'s kept order. At least one mode is retained."""
    mag = np.abs(basis.lam)
    ret = np.flatnonzero(mag <= 2.0 * np.pi * cutoff_hz)
    if ret.size == 0:
        ret = np.array([int(np.argmin(mag))])
    drop = np.setdiff1d(np.arange(mag.size), ret)
    nf = basis.n_forced if basis.n_forced >= 0 else mag.size
    red = Basis(
        basis.omega,
        False,
        basis.lam[ret],
        basis.phi[:, ret],
        basis.lu,
        basis.kept[ret],
        basis.cond,
        None,
        basis.scale,
        int(np.count_nonzero(ret < nf)),
        basis.light,
    )
    return red, drop


def residual_flexibility(lin: LinearModel, basis: Basis, drop: np.ndarray) -> np.ndarray:
    """Static (mode-acceleration) response of the dropped modes to unit column amplitudes, (nstate, m).

    A mode far above the excitation follows it quasi-statically: ``z_j' = lam_j z_j + w_j g`` gives
    ``z_j = -w_j g / lam_j`` (``w = Phi^-1 B f``), so the dropped modes add ``Re(Phi_D diag(-1/lam_D)
    W_D) g`` to the state. For a conjugate pair the velocity part of this sum vanishes (the q-part of
    ``B`` is zero), so it is a displacement correction, the residual flexibility of the dropped modes.
    """
    n = lin.nfree
    bf = np.zeros((lin.nstate, lin.m))
    bf[n:] = lin.MinvF
    w = basis.to_modal(bf)[drop]  # (nd, m)
    return (basis.phi[:, drop] @ (w / -basis.lam[drop][:, None])).real


def _pad(n: int) -> int:
    return max(8, -(-n // 8) * 8)


def step_map(
    lin: LinearModel, basis: Basis, dt: float, specs: Sequence[ChannelSpec], exact: bool = False
) -> StepMap:
    """Trapezoidal (Newmark average acceleration) map of step ``dt`` in the basis.

    ``exact``: for the modes the step resolves (``|h lam| <= EXACT_MAP_MU_MAX``) the exact
    propagator ``r = exp(h lam)``, with the forces by the same two-point quadrature weighted so that
    a constant force gives the exact static response, ``s = (exp(h lam) - 1) / (2 lam)`` (-> h/2 for
    h lam -> 0): free of Newmark's period error, second order in the forcing like Newmark. The
    stiffer modes keep Newmark's map (quasi-static at the step: the two-point weights of the exact
    propagator would make them follow the mean of the two end loads, half a step late). Docs:
    docs/solver.md, "Exact modal map". The dense fallback stays Newmark's map.
    """
    n = lin.nfree
    nstate = lin.nstate
    bf = np.zeros((nstate, lin.m))
    bf[n:] = lin.MinvF
    mrows = np.zeros((2 * lin.nm, nstate))
    mrows[: lin.nm, :n] = lin.V
    mrows[lin.nm :, n:] = lin.V
    cx, df = lin.output_rows(specs, basis.omega)
    if basis.dense:
        a = basis.a
        lhs = np.eye(nstate) - 0.5 * dt * a
        lu = sla.lu_factor(lhs)
        tmat = sla.lu_solve(lu, np.eye(nstate) + 0.5 * dt * a)
        sw = sla.lu_solve(lu, 0.5 * dt * bf)  # (N, m)
        nmode = nstate
        z0 = np.zeros((0, nmode))
        return StepMap(
            dt,
            True,
            aligned(np.zeros(nmode)),
            aligned(np.zeros(nmode)),
            aligned(np.ascontiguousarray(tmat.T)),
            aligned(np.ascontiguousarray(sw.T)),
            aligned(np.zeros((lin.m, nmode))),
            aligned(mrows @ tmat),
            aligned(np.zeros_like(mrows)),
            aligned(mrows @ sw),
            aligned(cx if cx.size else z0),
            aligned(np.zeros_like(cx) if cx.size else z0),
            aligned(df),
            basis,
            nmode,
        )
    lam = basis.lam
    nk = lam.size
    npad = _pad(nk)
    den = 1.0 - 0.5 * dt * lam
    r = (1.0 + 0.5 * dt * lam) / den
    s = (0.5 * dt) / den
    if exact:  # the modes the step resolves (|h lam| <= EXACT_MAP_MU_MAX)
        mu = dt * lam
        ex = np.abs(mu) <= EXACT_MAP_MU_MAX
        small = np.abs(mu) < 1e-8
        r = np.where(ex, np.exp(mu), r)
        se = np.where(small, 0.5 * dt * (1.0 + 0.5 * mu), np.expm1(mu) / (2.0 * np.where(small, 1.0, lam)))
        s = np.where(ex, se, s)
    w = basis.to_modal(bf)  # (nk, m) = Phi^-1 B f_k
    sw = (s[:, None] * w).T  # (m, nk)
    cm = mrows @ basis.phi  # (2nm, nk)
    cr = cm * r
    pq = (cm @ sw.T).real  # (2nm, m)
    co = cx @ basis.phi

    def padc(x: np.ndarray, part: str) -> np.ndarray:
        y = np.zeros((*x.shape[:-1], npad))
        y[..., :nk] = getattr(x, part)
        return aligned(y)

    return StepMap(
        dt,
        False,
        padc(r, "real"),
        padc(r, "imag"),
        aligned(np.zeros((1, 1))),
        padc(sw, "real"),
        padc(sw, "imag"),
        padc(cr, "real"),
        padc(cr, "imag"),
        aligned(pq),
        padc(co, "real"),
        padc(co, "imag"),
        aligned(df),
        basis,
        npad,
        exact=bool(exact),
    )


#: ``step_map(exact=True)``: modes with ``|h lambda|`` up to this value take the exact propagator.
EXACT_MAP_MU_MAX = 1.0
