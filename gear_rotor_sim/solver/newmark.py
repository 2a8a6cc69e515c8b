"""Exact modal form of Newmark average acceleration for Eq 39 with the nonlinear mesh (Eqs 21-33).

Set-up done here (Python/NumPy/SciPy), per-step work in :mod:`gear_rotor_sim.solver.kernels`.

Formulation
-----------
On the free DOFs, ``M q'' + D q' + K_lin q = g`` with

* ``K_lin = K + sum_m k_mean V^T V`` and ``D = C + Omega G + sum_m c_m V^T V`` (mean mesh terms moved
  into the linear part so that no rigid-body zero eigenvalue remains),
* ``g = f_static + sum_m [basis_m @ coef_m(t) F_m + V_m^T (k_mean delta_m + c_m delta_m')] + E a(t)``
  (the second mesh term cancels what was put into the linear part; ``E a(t)`` are effect forces).

Newmark with beta = 1/4, gamma = 1/2 is the trapezoidal rule on ``x = [q; v]``,
``x' = A x + B g``. With ``A = Phi Lambda Phi^-1`` each step is diagonal in ``z = Phi^-1 x``:
``z_{n+1} = r z_n + s Phi^-1 B (g_n + g_{n+1})``, ``r = (1 + h lam / 2) / (1 - h lam / 2)``,
``s = (h / 2) / (1 - h lam / 2)``. Only one eigenvalue of each conjugate pair is kept (the physical
state is ``Re`` of the kept part with a factor 2 folded into the output rows). Nothing is truncated,
so the map is exactly Newmark's. If the eigenvector matrix is ill-conditioned (defective system) the
same map is run with the dense real transition matrix ``T = (I - hA/2)^-1 (I + hA/2)``.
"""

from __future__ import annotations

import hashlib
import math
import re
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from gear_rotor_sim.solver import gear_kernel, kernels
from gear_rotor_sim.system_data import DOF_NAMES, AssembledSystem

#: Relative speed quantum of the eigenbasis cache: the gyroscopic matrix is taken at the speed rounded
#: to a log grid of this ratio, so the gyroscopic moments are within half of it (0.5 %) of exact.
SPEED_QUANTUM_REL = 0.01
#: Below this input speed the gyroscopic term is taken at zero speed.
SPEED_ZERO_RPM = 0.5
#: Eigenvector matrices with a 1-norm condition estimate above this use the dense fallback.
COND_LIMIT = 1e9
#: Smallest accepted steps per mesh period.
MIN_STEPS_PER_MESH = 8
#: Largest accepted steps per mesh period.
MAX_STEPS_PER_MESH = 4096
#: Divergence bound on |DTE|, m.
DTE_BOUND_M = 1e-2

_ALIGN = 64


def aligned_zeros(shape: int | tuple[int, ...], dtype: type = np.float64) -> np.ndarray:
    """C-contiguous zeros whose data pointer is 64-byte aligned."""
    shape_t = (shape,) if isinstance(shape, int) else tuple(shape)
    n = math.prod(shape_t)
    item = np.dtype(dtype).itemsize
    buf = np.zeros(n * item + _ALIGN, dtype=np.uint8)
    off = (-buf.ctypes.data) % _ALIGN
    return buf[off : off + n * item].view(dtype).reshape(shape_t)


class ChunkBuffers:
    """Work arrays kept from one chunk to the next, grown when a chunk needs more rows.

    :meth:`NewmarkStepper.run` takes its per-chunk arrays (phases, phase rates, the kernel's per-step
    mesh outputs) from here when the stepper holds one (``stepper.chunk_buffers``, set by the
    :class:`~gear_rotor_sim.simulator.Simulator`): then the arrays it returns, other than the
    channels, are views valid until its next call. Without it every chunk allocates them afresh,
    and glibc may map and fault them in anew each time (about 5000 minor page faults and 4-12 ms of
    system CPU per simulated second at 20000 rpm; docs/solver.md, "Session 10").
    """

    def __init__(self) -> None:
        self._arrays: dict[str, np.ndarray] = {}

    def get(self, name: str, shape: tuple[int, ...], dtype: type = np.float64) -> np.ndarray:
        """A C-contiguous array of ``shape`` (contents undefined), the first ``shape[0]`` rows of the
        buffer ``name`` (re-made, with room to spare, when it is too small or of another layout)."""
        a = self._arrays.get(name)
        if a is None or a.shape[1:] != shape[1:] or a.dtype != dtype or a.shape[0] < shape[0]:
            a = np.empty((max(shape[0], 1) + shape[0] // 4 + 64, *shape[1:]), dtype=dtype)
            self._arrays[name] = a
        return a[: shape[0]]


def aligned(a: np.ndarray) -> np.ndarray:
    """64-byte aligned C-contiguous copy of ``a``."""
    out = aligned_zeros(a.shape, a.dtype.type)
    out[...] = a
    return out


def quantize_speed_rpm(speed_rpm: float, quantum_rel: float | None = None) -> float:
    """Speed at which the gyroscopic matrix is evaluated: a log grid of ratio 1 + ``quantum_rel``
    (default ``SPEED_QUANTUM_REL``)."""
    if speed_rpm < SPEED_ZERO_RPM:
        return 0.0
    step = np.log1p(SPEED_QUANTUM_REL if quantum_rel is None else quantum_rel)
    return float(np.exp(np.round(np.log(speed_rpm) / step) * step))


def mesh_frequencies_hz(system: AssembledSystem, speed_rpm: float) -> list[float]:
    """Mesh frequency of every mesh at an input speed, Hz, in the order of ``meshes``."""
    return [
        m.pinion_teeth * abs(float(system.shaft_speed_ratios[m.pinion_shaft])) * speed_rpm / 60.0
        for m in system.meshes
    ]


def mesh_frequency_hz(system: AssembledSystem, speed_rpm: float) -> float:
    """Highest mesh frequency of the system at an input speed, Hz (0 without meshes)."""
    return max(mesh_frequencies_hz(system, speed_rpm), default=0.0)


# ----------------------------------------------------------------------------------------------
# channels


@dataclass(frozen=True)
class ChannelSpec:
    """How one output channel is formed: a state row, a mesh scalar, with its unit."""

    name: str
    unit: str
    kind: str  # "row" | "dte" | "force"
    mesh: int = -1
    dof: int = -1  # global DOF for node channels
    order: int = 0  # 0 displacement, 1 velocity, 2 acceleration
    bearing: int = -1  # index into system.bearings
    component: int = -1  # 0..2 for bearing forces


_NODE_RE = re.compile(r"^node(\d+)_(v|a)?(x|y|z|theta_x|theta_y|theta_z)$")
_BEARING_RE = re.compile(r"^bearing(\d+)_f(x|y|z)$")
_MESH_RE = re.compile(r"^(?:mesh(\d+)_)?(dte|mesh_force|force)$")


def available_channels(system: AssembledSystem) -> list[tuple[str, str]]:
    """All channel names of a system with their SI units."""
    out: list[tuple[str, str]] = []
    if system.meshes:  # the first mesh's, and every mesh's by its 1-based number in ``meshes:``
        out += [("dte", "m"), ("mesh_force", "N")]
    for i in range(len(system.meshes)):
        out += [(f"mesh{i + 1}_dte", "m"), (f"mesh{i + 1}_force", "N")]
    for b in system.bearings:
        out += [(f"bearing{b.number}_f{c}", "N") for c in "xyz"]
    for node in range(1, system.n_nodes + 1):
        for prefix, lin, ang in (("", "m", "rad"), ("v", "m/s", "rad/s"), ("a", "m/s^2", "rad/s^2")):
            for d in DOF_NAMES:
                out.append((f"node{node}_{prefix}{d}", ang if d.startswith("theta") else lin))
    return out


def parse_channels(system: AssembledSystem, names: Sequence[str]) -> list[ChannelSpec]:
    """Channel specifications; ValueError naming ``channels`` and the allowed forms otherwise."""
    specs: list[ChannelSpec] = []
    units = dict(available_channels(system))
    numbers = {b.number: i for i, b in enumerate(system.bearings)}
    for name in names:
        if name not in units:
            raise ValueError(
                f"channels: {name!r} is not available; allowed: dte, mesh_force (the first mesh), "
                f"mesh{{1..{len(system.meshes)}}}_dte, mesh{{1..{len(system.meshes)}}}_force, "
                f"bearing{{1..{len(system.bearings)}}}_f{{x,y,z}}, node{{1..{system.n_nodes}}}_[v|a]"
                "{x,y,z,theta_x,theta_y,theta_z}"
            )
        if mm := _MESH_RE.match(name):
            i = int(mm.group(1)) - 1 if mm.group(1) else 0
            specs.append(ChannelSpec(name, units[name], "dte" if mm.group(2) == "dte" else "force", mesh=i))
        elif mb := _BEARING_RE.match(name):
            specs.append(
                ChannelSpec(
                    name,
                    units[name],
                    "row",
                    bearing=numbers[int(mb.group(1))],
                    component="xyz".index(mb.group(2)),
                )
            )
        elif mn := _NODE_RE.match(name):
            order = {None: 0, "v": 1, "a": 2}[mn.group(2)]
            specs.append(
                ChannelSpec(
                    name, units[name], "row", dof=system.dof(int(mn.group(1)), mn.group(3)), order=order
                )
            )
    return specs


# ----------------------------------------------------------------------------------------------
# linear part and force columns


class LinearModel:
    """Free-DOF matrices, force columns and output rows of one AssembledSystem (one temperature).

    Parameters
    ----------
    system : AssembledSystem
    effect_columns : ndarray, optional
        (ndof, ne) fixed generalised force vectors of effects (their amplitudes vary per step).
    """

    def __init__(self, system: AssembledSystem, effect_columns: np.ndarray | None = None) -> None:
        self.system = system
        free = np.asarray(system.free_dofs, dtype=np.int64)
        self.free = free
        self.nfree = n = free.size
        self.nstate = 2 * n
        pos = np.full(system.ndof, -1, dtype=np.int64)
        pos[free] = np.arange(n)
        self.pos = pos
        ix = np.ix_(free, free)
        self.M = np.asarray(system.M, float)[ix]
        self.K = np.asarray(system.K, float)[ix].copy()
        self.C = np.asarray(system.C, float)[ix].copy()
        self.G = np.asarray(system.G, float)[ix]
        meshes = system.meshes
        self.nm = nm = len(meshes)
        self.nb = nb = max((mc.force_basis.shape[1] for mc in meshes), default=1)
        self.V = np.zeros((nm, n))
        for i, mc in enumerate(meshes):
            v = np.asarray(mc.line_of_action, float)[free]
            self.V[i] = v
            self.K += mc.mean_stiffness * np.outer(v, v)
            self.C += mc.damping * np.outer(v, v)
        self.kbar = np.array([mc.mean_stiffness for mc in meshes], float)
        self.cmesh = np.array([mc.damping for mc in meshes], float)
        self.bstar = np.array([mc.half_backlash for mc in meshes], float)
        ne = 0 if effect_columns is None else effect_columns.shape[1]
        self.ne = ne
        cols = [np.asarray(system.static_load, float)[free]]
        self.col_basis = np.full((nm, nb), -1, dtype=np.int64)
        self.col_comp = np.zeros(nm, dtype=np.int64)
        for i, mc in enumerate(meshes):
            fb = np.asarray(mc.force_basis, float)
            for j in range(fb.shape[1]):
                self.col_basis[i, j] = len(cols)
                cols.append(fb[free, j])
            self.col_comp[i] = len(cols)
            cols.append(self.V[i].copy())
        self.col_eff0 = len(cols)
        for j in range(ne):
            cols.append(np.asarray(effect_columns[:, j], float)[free])  # type: ignore[index]
        self.Fc = np.column_stack(cols)
        self.m = self.Fc.shape[1]
        self.lu_M = sla.lu_factor(self.M)
        self.MinvF = sla.lu_solve(self.lu_M, self.Fc)
        self.MinvK = sla.lu_solve(self.lu_M, self.K)
        self.MinvC = sla.lu_solve(self.lu_M, self.C)
        self.MinvG = sla.lu_solve(self.lu_M, self.G)

    def damping(self, omega: float) -> np.ndarray:
        """``M^-1 D`` at input speed omega (rad/s)."""
        return self.MinvC + omega * self.MinvG

    def state_matrix(self, omega: float) -> np.ndarray:
        """``A = [[0, I], [-M^-1 K_lin, -M^-1 D]]``."""
        n = self.nfree
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -self.MinvK
        a[n:, n:] = -self.damping(omega)
        return a

    def output_rows(self, specs: Sequence[ChannelSpec], omega: float) -> tuple[np.ndarray, np.ndarray]:
        """State rows (no, 2n) and force feed-through rows (no, m) of the ``row`` channels."""
        n = self.nfree
        rows = [s for s in specs if s.kind == "row"]
        cx = np.zeros((len(rows), 2 * n))
        df = np.zeros((len(rows), self.m))
        md = None
        for o, s in enumerate(rows):
            if s.bearing >= 0:
                site = self.system.bearings[s.bearing]
                for d in range(6):
                    p = self.pos[6 * site.node0 + d]
                    if p >= 0:
                        cx[o, p] += site.stiffness[s.component, d]
                        cx[o, n + p] += site.damping[s.component, d]
                continue
            p = self.pos[s.dof]
            if p < 0:
                continue  # a constrained DOF has no vibration
            if s.order == 0:
                cx[o, p] = 1.0
            elif s.order == 1:
                cx[o, n + p] = 1.0
            else:
                if md is None:
                    md = self.damping(omega)
                cx[o, :n] = -self.MinvK[p]
                cx[o, n:] = -md[p]
                df[o] = self.MinvF[p]
        return cx, df


# ----------------------------------------------------------------------------------------------
# eigenbasis (per speed) and step map (per dt)


@dataclass
class Basis:
    """Eigenbasis of ``A`` at one speed; ``dense`` when the fallback is used."""

    omega: float
    dense: bool
    lam: np.ndarray  # (nk,) kept eigenvalues
    phi: np.ndarray  # (N, nk) kept eigenvectors with the factor (1 real, 2 complex) folded in
    lu: tuple  # LU of the full eigenvector matrix (or of nothing for dense)
    kept: np.ndarray  # indices of the kept eigenvalues in the full set
    cond: float
    a: np.ndarray | None = None  # state matrix (dense fallback only)
    scale: float = 1.0  # x = diag(I, scale I) Phi_s z; ``lu`` factorises Phi_s
    n_forced: int = -1  # kept modes [0, n_forced) are the forced ones (-1: all)
    light: tuple[np.ndarray, np.ndarray] | None = None  # (f_hz, zeta) of light_mesh_modes, cached

    def to_modal(self, x: np.ndarray) -> np.ndarray:
        """Kept modal coordinates of state vectors/columns ``x`` (N, ...) (exact, via the full Phi_s)."""
        y = np.array(x, dtype=complex)
        y[y.shape[0] // 2 :] /= self.scale
        return sla.lu_solve(self.lu, y, check_finite=False)[self.kept]


def state_blocks(lin: LinearModel) -> list[np.ndarray]:
    """Groups of free DOFs that the linear part does not couple (connected components).

    The pattern of ``M``, ``K_lin``, ``C``, ``G`` (mean mesh terms included) splits e.g. the axial
    DOFs of each shaft from the lateral-torsional ones (the mesh has no axial component, Eq 22), so the
    state matrix is block diagonal after a permutation and each block is diagonalised on its own:
    exact, and about (214/178)^3 = 1.7 times cheaper than one eigendecomposition for the paper model.
    """
    pat = (np.abs(lin.M) + np.abs(lin.K) + np.abs(lin.C) + np.abs(lin.G)) > 0.0
    ncomp, labels = connected_components(csr_matrix(pat), directed=False)
    return [np.flatnonzero(labels == c) for c in range(ncomp)]


def _block_eig(a_s: np.ndarray, blocks: list[np.ndarray], n: int) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and the (block-diagonal) eigenvector matrix of the balanced state matrix."""
    nstate = 2 * n
    lam = np.zeros(nstate, dtype=complex)
    phi = np.zeros((nstate, nstate), dtype=complex)
    col = 0
    for dofs in blocks:
        st = np.concatenate([dofs, n + dofs])
        lb, pb = np.linalg.eig(a_s[np.ix_(st, st)])
        cols = slice(col, col + st.size)
        lam[cols] = lb
        phi[np.ix_(st, np.arange(col, col + st.size))] = pb
        col += st.size
    return lam, phi


#: Bases by content (state matrix, force columns, mesh rows, speed): simulators of one machine that
#: differ only in effects without new matrices (a calibration runs dozens) diagonalise once.
_BASIS_MEMO: OrderedDict[str, Basis] = OrderedDict()
_BASIS_MEMO_SIZE = 6


def eigen_basis(lin: LinearModel, omega: float, force_dense: bool = False) -> Basis:
    """Diagonalise the state matrix at input speed ``omega`` (rad/s); fall back to dense if needed.

    Kept modes are ordered with the *forced* modes first: those that a force column other than the
    static load reaches, or that the mesh deflection reads (see :func:`gear_kernel.run_chunk_gear`).
    Memoised on the content of everything it reads (``_BASIS_MEMO``); bases are never modified.
    """
    a = lin.state_matrix(omega)
    h = hashlib.sha1()
    for arr in (a, lin.MinvF, lin.V, lin.MinvK):
        h.update(np.ascontiguousarray(arr).tobytes())
    h.update(repr((float(omega), bool(force_dense), a.shape, np.shape(lin.MinvF))).encode())
    key = h.hexdigest()
    hit = _BASIS_MEMO.get(key)
    if hit is not None:
        _BASIS_MEMO.move_to_end(key)
        return hit
    out = _eigen_basis(lin, omega, force_dense, a)
    _BASIS_MEMO[key] = out
    if len(_BASIS_MEMO) > _BASIS_MEMO_SIZE:
        _BASIS_MEMO.popitem(last=False)
    return out


def _eigen_basis(lin: LinearModel, omega: float, force_dense: bool, a: np.ndarray) -> Basis:
    n = lin.nfree
    # balance q and v: eigenvectors of S^-1 A S with S = diag(I, s I) (much better conditioned)
    sc = float(np.sqrt(np.median(np.abs(np.diag(lin.MinvK))) + 1.0))
    a_s = a.copy()
    a_s[:n, n:] *= sc
    a_s[n:, :n] /= sc
    if not force_dense:
        try:
            lam, phi = _block_eig(a_s, state_blocks(lin), n)
        except (np.linalg.LinAlgError, ValueError):
            lam = phi = None
        if lam is not None and np.all(np.isfinite(lam)):
            scale = np.abs(lam) + 1.0
            pos = np.flatnonzero(lam.imag > 1e-9 * scale)
            neg = np.flatnonzero(lam.imag < -1e-9 * scale)
            real = np.flatnonzero(np.abs(lam.imag) <= 1e-9 * scale)
            if pos.size == neg.size:
                lu, piv = sla.lu_factor(phi, check_finite=False)
                anorm = np.abs(phi).sum(axis=0).max()
                rcond = sla.lapack.zgecon(lu, anorm, norm="1")[0]
                cond = 1.0 / rcond if rcond > 0 else np.inf
                if cond < COND_LIMIT:
                    kept = np.concatenate([real, pos])
                    fac = np.concatenate([np.ones(real.size), 2.0 * np.ones(pos.size)])
                    # forced modes first (exact zeros elsewhere thanks to the block structure)
                    bf = np.zeros((2 * n, lin.m))
                    bf[n:] = lin.MinvF
                    bf[n:] /= sc
                    w = sla.lu_solve((lu, piv), bf.astype(complex), check_finite=False)[kept]
                    rows = np.zeros((2 * lin.nm, 2 * n))
                    rows[: lin.nm, :n] = lin.V
                    rows[lin.nm :, n:] = lin.V * sc
                    reads = np.abs(rows @ phi[:, kept]).sum(axis=0) if lin.nm else np.zeros(kept.size)
                    pushed = np.abs(w[:, 1:]).sum(axis=1)
                    forced = (reads > 0.0) | (pushed > 0.0)
                    order = np.argsort(~forced, kind="stable")
                    kept, fac = kept[order], fac[order]
                    n_forced = int(np.count_nonzero(forced))
                    lamk = lam[kept].copy()
                    lamk[fac == 1.0] = lamk[fac == 1.0].real
                    phik = phi[:, kept] * fac
                    phik[n:] *= sc
                    return Basis(omega, False, lamk, phik, (lu, piv), kept, float(cond), None, sc, n_forced)
    return Basis(
        omega, True, np.zeros(0, complex), np.eye(lin.nstate, dtype=complex), (), np.arange(0), np.inf, a
    )


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

OUTPUT_BLOCK_STEPS = 64  # steps per output matrix product in the gear kernel (fits L1/L2)


def split_table_jumps(
    tab_k: np.ndarray, tab_c: np.ndarray, jumps: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Continuous tables plus periodic steps: ``k(f) = kc(f) + sum_j dk_j ([f >= p_j] - f)``.

    ``jumps`` rows are (phase, dk, dcoef...) as :attr:`MeshCoupling.table_jumps` (right minus left
    limit). Each ``[f >= p_j] - f`` is periodic on [0, 1) and jumps by 1 at ``p_j`` only (the ramp
    carries the net change, as the jumps of a periodic table need not sum to zero), so ``kc`` is
    continuous and periodic and its linear interpolation on the table grid is second-order accurate.
    Returns ``(kc, cc, jump_p, jump_k, jump_c)`` with the phases sorted.
    """
    nt = tab_k.size
    nb = tab_c.shape[1]
    if jumps is None or len(jumps) == 0:
        z = np.zeros(0)
        return tab_k.copy(), tab_c.copy(), z, z, np.zeros((0, nb))
    jumps = np.asarray(jumps, float)
    jumps = jumps[np.argsort(jumps[:, 0])]
    p, jk, jc = jumps[:, 0], jumps[:, 1], np.ascontiguousarray(jumps[:, 2 : 2 + nb])
    grid = np.arange(nt) / nt
    saw = (grid[:, None] >= p[None, :]).astype(float) - grid[:, None]  # (nt, nj)
    return tab_k - saw @ jk, tab_c - saw @ jc, p.copy(), jk.copy(), jc


def _jump_intervals(nt: int, jump_p: np.ndarray) -> np.ndarray:
    """int8 flag per interval [i/nt, (i+1)/nt) of the table grid: 1 if a jump phase lies in it."""
    flag = np.zeros(nt, dtype=np.int8)
    for p in jump_p:
        i = int(np.floor(p * nt)) % nt
        flag[i] = 1
        flag[(i - 1) % nt] = 1  # guard the interval before (phase round-off at a grid point)
    return flag


def _static_feed(mp: StepMap, specs: Sequence[ChannelSpec] | None) -> np.ndarray:
    """Output offset of the static-load column (amplitude 1), per output column of the gear map."""
    rows = mp.dfeed[:, 0] if mp.dfeed.size else np.zeros(mp.outr.shape[0])
    if specs is None or rows.size == 0:
        return rows.copy()
    out = np.zeros(len(specs))
    o = 0
    for i, sp in enumerate(specs):
        if sp.kind == "row":
            out[i] = rows[o]
            o += 1
    return out


def _output_stack(
    lin: LinearModel, mp: StepMap, specs: Sequence[ChannelSpec] | None, cols: np.ndarray, ucol: list[int]
) -> tuple[np.ndarray, np.ndarray]:
    """Output matrix ``[z_r, z_i, beta] -> channels`` of the gear kernel and the static offsets.

    With ``specs`` every channel in order (``dte_i = V_i x``, mesh force ``F_i = kbar_i delta_i + c_i
    delta_i' - u_i``, both linear in the modal state and the active column amplitudes; ``ucol[i]`` is
    the active column of ``u_i``); without, or with no state-row channel, only the state rows. With a
    reduced basis (``mp.resid``) each channel also reads the dropped modes' static part through the
    column amplitudes (the static-load column's into the offset).
    """
    npad = mp.nmode
    nk = mp.basis.lam.size
    n = lin.nfree
    nrow = mp.outr.shape[0]
    cx = rres = None
    if mp.resid is not None:
        cx, _ = lin.output_rows([sp for sp in specs or () if sp.kind == "row"], mp.basis.omega)
        rres = cx @ mp.resid  # (nrow, m)
    rows = np.zeros((2 * npad + cols.size, nrow))
    static_add = np.zeros(nrow)
    if nrow:
        rows[:npad] = mp.outr.T
        rows[npad : 2 * npad] = -mp.outi.T
        rows[2 * npad :] = mp.dfeed[:, cols].T
        if rres is not None and rres.shape[0] == nrow:
            rows[2 * npad :] += rres[:, cols].T
            static_add += rres[:, 0]
    if specs is None or nrow == 0:
        return rows, static_add
    cstack = np.zeros((rows.shape[0], len(specs)))
    static_add = np.zeros(len(specs))
    o = 0
    for i, sp in enumerate(specs):
        if sp.kind == "row":
            cstack[:, i] = rows[:, o]
            if rres is not None:
                static_add[i] = rres[o, 0]
            o += 1
            continue
        vd = np.zeros(npad, dtype=complex)
        vv = np.zeros(npad, dtype=complex)
        vd[:nk] = lin.V[sp.mesh] @ mp.basis.phi[:n]
        vv[:nk] = lin.V[sp.mesh] @ mp.basis.phi[n:]
        rd = np.zeros(lin.m)
        if mp.resid is not None:
            rd = lin.V[sp.mesh] @ mp.resid[:n]
        if sp.kind == "force":
            vd = lin.kbar[sp.mesh] * vd + lin.cmesh[sp.mesh] * vv
            cstack[2 * npad + ucol[sp.mesh], i] = -1.0
            if mp.resid is not None:
                rd = lin.kbar[sp.mesh] * rd + lin.cmesh[sp.mesh] * (lin.V[sp.mesh] @ mp.resid[n:])
        cstack[:npad, i] = vd.real
        cstack[npad : 2 * npad, i] = -vd.imag
        cstack[2 * npad :, i] += rd[cols]
        static_add[i] = rd[0]
    return cstack, static_add


@dataclass
class GearMap:
    """Arrays of :func:`gear_kernel.run_chunk_gear` (any number of table meshes, full or reduced modal
    basis), grouped by role as the kernel takes them (see its module docstring).

    Active force columns: mesh i owns ``i nb .. i nb + nb - 1`` (``u_i`` = the compensation column
    ``+V_i``, which also carries the line-of-action part ``-V_i F_i``, then the friction basis),
    then the effects.
    """

    cols: np.ndarray  # LinearModel column index of each active column
    # (zr, zi) are filled per chunk; (rr, ri, c0r, c0i, swr, swi, crr, cri, vrr, vri, mur, mui, pmr, pmi)
    modal: tuple
    n_forced: int
    mesh: tuple  # (pq, pqn, pq_static, rstat, pd, pv, mesh_par)
    tables: tuple  # (tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, n_jump)
    cstack: np.ndarray
    dfeed_static: np.ndarray


def gear_map(lin: LinearModel, mp: StepMap, specs: Sequence[ChannelSpec] | None = None) -> GearMap | None:
    """The gear kernel's arrays for a modal step map, or None if the kernel does not apply.

    Applies when every mesh has uniform tables of one common length and force basis width, whose first
    basis column is ``-V`` and first coefficient 1 (Eq 22 / Eq 29). With ``specs`` the output matrix
    gives every channel in their order (``dte_i = V_i x`` and ``F_i = kbar_i delta_i + c_i delta_i' -
    u_i`` are linear in the modal state and the column amplitudes too); without, only the state rows.
    With a reduced basis (``mp.resid``) delta, delta' and the outputs read the dropped modes' static
    response to the new column amplitudes (``pqn``, ``rstat``, :func:`_output_stack`).
    """
    nm = lin.nm
    if mp.dense or nm == 0:
        return None
    meshes = lin.system.meshes
    nb = lin.nb
    nt = None
    for i, mc in enumerate(meshes):
        if mc.table_stiffness is None or mc.table_coefficients is None:
            return None
        cb = lin.col_basis[i]
        if np.any(cb[:nb] < 0) or not np.array_equal(lin.Fc[:, cb[0]], -lin.Fc[:, lin.col_comp[i]]):
            return None
        tc = np.asarray(mc.table_coefficients, float).reshape(mc.table_stiffness.size, -1)
        if nt is None:
            nt = mc.table_stiffness.size
        if mc.table_stiffness.size != nt or tc.shape[1] != nb or not np.all(tc[:, 0] == 1.0):
            return None
    assert nt is not None
    cols_l: list[int] = []
    ucol: list[int] = []
    for i in range(nm):
        ucol.append(len(cols_l))
        cols_l += [int(lin.col_comp[i]), *(int(c) for c in lin.col_basis[i, 1:nb])]
    cols = np.array([*cols_l, *range(lin.col_eff0, lin.m)], dtype=np.int64)
    nf = mp.basis.n_forced if mp.basis.n_forced >= 0 else mp.basis.lam.size
    pq = mp.pq[:, cols]
    pq_static = 2.0 * mp.pq[:, 0]
    pqn = pq.copy()  # response to the new amplitudes (with a reduced basis: plus the dropped modes')
    rstat = np.zeros(2 * nm)
    n = lin.nfree
    if mp.resid is not None:
        rm = np.vstack([lin.V @ mp.resid[:n], lin.V @ mp.resid[n:]])  # (2 nm, m)
        pqn += rm[:, cols]
        rstat = rm[:, 0].copy()
        pq_static = pq_static + rstat
    hd = pqn[:nm, ucol]
    hv = pqn[nm:, ucol]
    emat = np.eye(nm) - lin.kbar[:, None] * hd - lin.cmesh[:, None] * hv
    einv = np.linalg.inv(emat)
    tab_kf = np.zeros((nm, nt))
    tab_cf = np.zeros((nm, nt, nb))
    tab_k = np.zeros((nm, nt))
    tab_c = np.zeros((nm, nt, nb))
    jflag = np.zeros((nm, nt), dtype=np.int8)
    split = []
    for i, mc in enumerate(meshes):
        tc = np.asarray(mc.table_coefficients, float).reshape(nt, nb)
        tab_kf[i] = mc.table_stiffness
        tab_cf[i] = tc
        split.append(split_table_jumps(np.asarray(mc.table_stiffness, float), tc, mc.table_jumps))
    nj = max(1, max(sp[2].size for sp in split))
    jump_p = np.zeros((nm, nj))
    jump_k = np.zeros((nm, nj))
    jump_c = np.zeros((nm, nj, nb))
    n_jump = np.zeros(nm, dtype=np.int64)
    for i, (kc, cc, jp, jk, jc) in enumerate(split):
        tab_k[i] = kc
        tab_c[i] = cc
        n_jump[i] = jp.size
        jump_p[i, : jp.size] = jp
        jump_k[i, : jp.size] = jk
        jump_c[i, : jp.size] = jc
        jflag[i] = _jump_intervals(nt, jp)
    mesh_par = np.array(
        [[lin.kbar[i], lin.cmesh[i], lin.cmesh[i], lin.bstar[i], mc.te_amplitude, mc.te_phase]
         for i, mc in enumerate(meshes)]
    )  # fmt: skip
    # sub-steps: mesh rows V Phi, h lambda, and the responses pm of the mesh rows to each mesh column
    # and to the static increment (rows q 2 nm + r)
    npad = mp.nmode
    nk = mp.basis.lam.size
    mrows = np.zeros((2 * nm, lin.nstate))
    mrows[:nm, :n] = lin.V
    mrows[nm:, n:] = lin.V
    vrow = np.zeros((2 * nm, npad), dtype=complex)
    vrow[:, :nk] = mrows @ mp.basis.phi
    mu = np.zeros(npad, dtype=complex)
    mu[:nk] = mp.dt * mp.basis.lam
    sw_act = mp.swr[cols] + 1j * mp.swi[cols]
    c0 = 2.0 * (mp.swr[0] + 1j * mp.swi[0])
    nmc = nm * nb
    pm = np.zeros(((nmc + 1) * 2 * nm, npad), dtype=complex)
    for q in range(nmc + 1):
        col = sw_act[q] if q < nmc else c0
        pm[q * 2 * nm : (q + 1) * 2 * nm] = vrow * col[None, :]
    modal = (
        mp.rr,
        mp.ri,
        aligned(c0.real),
        aligned(c0.imag),
        aligned(mp.swr[cols]),
        aligned(mp.swi[cols]),
        mp.crr,
        mp.cri,
        aligned(vrow.real),
        aligned(vrow.imag),
        aligned(mu.real),
        aligned(mu.imag),
        aligned(pm.real),
        aligned(pm.imag),
    )
    mesh = (
        aligned(pq), aligned(pqn), aligned(pq_static), aligned(rstat), aligned(hd @ einv), aligned(hv @ einv),
        mesh_par,
    )  # fmt: skip
    tables = (
        aligned(tab_kf), aligned(tab_cf), jflag, aligned(tab_k), aligned(tab_c),
        jump_p, jump_k, jump_c, n_jump,
    )  # fmt: skip
    cstack, static_add = _output_stack(lin, mp, specs, cols, ucol)
    return GearMap(
        cols, modal, int(nf), mesh, tables, aligned(cstack), aligned(_static_feed(mp, specs) + static_add)
    )


# ----------------------------------------------------------------------------------------------
# state carried between chunks and models


@dataclass
class SolverState:
    """Physical state carried across chunks, bases and temperature rebuilds (basis independent).

    ``x = [q_free; v_free]``; per mesh at the last step: ``delta``, ``delta_dot``, ``force``,
    ``coef`` (basis coefficients), contact ``state``; effect amplitudes ``ampl``; the integrated
    input-shaft angle (rad) and simulated time.
    """

    x: np.ndarray
    delta: np.ndarray
    delta_dot: np.ndarray
    force: np.ndarray
    coef: np.ndarray
    contact: np.ndarray
    ampl: np.ndarray
    angle: float = 0.0
    time: float = 0.0
    free_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def copy(self) -> SolverState:
        return SolverState(
            self.x.copy(),
            self.delta.copy(),
            self.delta_dot.copy(),
            self.force.copy(),
            self.coef.copy(),
            self.contact.copy(),
            self.ampl.copy(),
            self.angle,
            self.time,
            self.free_dofs.copy(),
        )

    def q_full(self, ndof: int) -> np.ndarray:
        """Displacements on all DOFs (constrained ones zero)."""
        q = np.zeros(ndof)
        q[self.free_dofs] = self.x[: self.free_dofs.size]
        return q


def mesh_law(
    delta: np.ndarray,
    delta_dot: np.ndarray,
    k: np.ndarray,
    c: np.ndarray,
    e: np.ndarray,
    e_dot: np.ndarray,
    b: np.ndarray,
) -> np.ndarray:
    """Eq 25-26 evaluated directly: F = k (gamma0 delta_m + gamma1 b) + c gamma0 delta_m'."""
    dm = delta - e
    g0 = (np.abs(dm) > b).astype(float)
    g1 = np.where(dm > b, -1.0, np.where(dm < -b, 1.0, 0.0))
    return k * (g0 * dm + g1 * b) + c * g0 * (delta_dot - e_dot)


# ----------------------------------------------------------------------------------------------
# per-step excitation


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


# ----------------------------------------------------------------------------------------------
# equilibrium


def static_equilibrium(system: AssembledSystem, effects: Sequence[object] = ()) -> SolverState:
    """Static state at mean mesh stiffness, no transmission error, phase-mean friction coefficients.

    Solves ``K q = f_static + sum u_m F_m`` with ``F_m = k_mean (V q -/+ b*)`` per the contact state of
    Eq 26, the states found by an active set (consistent: ``V q > b*`` on the drive side, etc.).
    """
    lin = LinearModel(system, effect_columns(system, effects))
    free = lin.free
    n, nm = lin.nfree, lin.nm
    ph = np.linspace(0.0, 1.0, 64, endpoint=False)
    u = np.zeros((nm, n))
    for i, m in enumerate(system.meshes):
        cf = np.asarray(m.force_coefficients(ph), float).reshape(ph.size, -1).mean(axis=0)
        u[i] = np.asarray(m.force_basis, float)[free] @ cf
    K0 = np.asarray(system.K, float)[np.ix_(free, free)]
    f0 = np.asarray(system.static_load, float)[free]
    contact = np.ones(nm, dtype=np.int64)
    q = np.zeros(n)
    for _ in range(3 ** max(nm, 1) + 2):
        kk = K0.copy()
        rhs = f0.copy()
        for i in range(nm):
            if contact[i]:
                kk -= lin.kbar[i] * np.outer(u[i], lin.V[i])
                rhs -= lin.kbar[i] * contact[i] * lin.bstar[i] * u[i]
        try:
            q = np.linalg.solve(kk, rhs)
        except np.linalg.LinAlgError:
            q = np.linalg.lstsq(kk, rhs, rcond=None)[0]
        d = lin.V @ q
        new = np.where(d > lin.bstar, 1, np.where(d < -lin.bstar, -1, 0))
        if np.array_equal(new, contact):
            break
        contact = new
    d = lin.V @ q
    force = lin.kbar * (d - contact * lin.bstar) * (contact != 0)
    coef = np.zeros((nm, lin.nb))
    for i, m in enumerate(system.meshes):
        cf = np.asarray(m.force_coefficients(np.zeros(1)), float).reshape(-1)
        coef[i, : cf.size] = cf
    x = np.concatenate([q, np.zeros(n)])
    return SolverState(
        x,
        d,
        np.zeros(nm),
        force,
        coef,
        (2 * contact).astype(np.int64),
        np.zeros(lin.ne),
        0.0,
        0.0,
        free.copy(),
    )


# ----------------------------------------------------------------------------------------------
# the stepper: one LinearModel, cached bases, the kernel


class NewmarkStepper:
    """Runs the kernel on one assembled system; switches speed basis and dt with exact state transfer.

    Parameters
    ----------
    system : AssembledSystem
    specs : list of ChannelSpec
    effects : sequence of Effect
    force_dense : bool
        Use the dense fallback map even when the eigenbasis is well conditioned (tests).
    cache_size : int
        Eigenbases kept per system (LRU over quantised speeds).
    disable_fast : bool
        Always use the general kernel (tests of the gear kernel against it).
    locate_events : bool
        Gear kernel: split steps at the mesh-table jumps and contact changes of any mesh inside them
        (docs/solver.md); False takes every event at the step instants, as the general kernel does.
    lin : LinearModel, optional
        The linear model of ``system`` with ``effects`` if already at hand (the ramp systems of
        :mod:`gear_rotor_sim.solver.rebase` derive it from their grid node's); None builds it.
    """

    def __init__(
        self,
        system: AssembledSystem,
        specs: Sequence[ChannelSpec],
        effects: Sequence[object] = (),
        force_dense: bool = False,
        cache_size: int = 16,
        disable_fast: bool = False,
        locate_events: bool = False,
        lin: LinearModel | None = None,
    ) -> None:
        self.system = system
        self.specs = list(specs)
        self.effects = tuple(effects)
        self.lin = LinearModel(system, effect_columns(system, self.effects)) if lin is None else lin
        self.force_dense = force_dense
        self._bases: OrderedDict[float, Basis] = OrderedDict()
        # where a basis not in the cache comes from (None: eigen_basis of ``lin``); the ramp systems of
        # solver/rebase.py take their grid node's bases (the same state matrix)
        self.basis_source: Callable[[float], Basis] | None = None
        self._cache_size = cache_size
        self.map: StepMap | None = None
        self.row_index = [i for i, s in enumerate(self.specs) if s.kind == "row"]
        self.zr = self.zi = np.zeros(0)
        self.beta_prev = np.zeros(self.lin.m)
        self.ypred = np.zeros(2 * self.lin.nm)
        self.contact = np.zeros(self.lin.nm, dtype=np.int64)
        self.n_mesh_fail = 0
        self.gear: GearMap | None = None
        self.disable_fast = disable_fast
        self.fuse_meshes = True  # gear kernel: fused mode pass for <= 2 meshes (False: tests)
        self.modal_cutoff_hz: float | None = None  # modal reduction with static correction (None: full)
        self.exact_map = False  # the exact modal propagator instead of Newmark's map (step_map)
        self._reduced: dict[tuple[float, float], tuple[Basis, np.ndarray]] = {}
        self.locate_events = bool(locate_events)
        self.n_substeps = 0
        self._hbuf = np.zeros((0, 0))
        self.beta_act = np.zeros(0)
        #: per-chunk work arrays reused across calls of :meth:`run` (None: allocated per call)
        self.chunk_buffers: ChunkBuffers | None = None
        #: gear kernel: on a step holding an event the channels carry the events' times
        #: (``gear_kernel.run_chunk_gear(event_average=True)``; docs/solver.md, "Session 10")
        self.event_average = False
        #: a step whose only events are table jumps taken whole with the tables' step average
        #: (``gear_kernel.run_chunk_gear(average_jumps=True)``; docs/solver.md, "Session 11")
        self.average_jumps = False

    # --- basis handling
    def basis(self, omega: float) -> Basis:
        b = self._bases.get(omega)
        if b is None:
            src = self.basis_source
            b = eigen_basis(self.lin, omega, self.force_dense) if src is None else src(omega)
            self._bases[omega] = b
            if len(self._bases) > self._cache_size:
                self._bases.popitem(last=False)
        else:
            self._bases.move_to_end(omega)
        return b

    def set_operating_point(self, omega: float, dt: float, state: SolverState) -> None:
        """Select the basis at quantised input speed ``omega`` (rad/s) and step ``dt``; load ``state``."""
        cut = self.modal_cutoff_hz
        if (
            self.map is None
            or self.map.basis.omega != omega
            or self.map.dt != dt
            or (self.map.resid is None) != (cut is None)
            or self.map.exact != (self.exact_map and not self.map.dense)
        ):
            basis = self.basis(omega)
            resid = None
            if cut is not None and not basis.dense and not self.disable_fast:
                hit = self._reduced.get((omega, cut))
                if hit is None:
                    red, drop = reduce_basis(basis, cut)
                    hit = (red, residual_flexibility(self.lin, basis, drop))
                    self._reduced[(omega, cut)] = hit
                    if len(self._reduced) > self._cache_size:
                        self._reduced.pop(next(iter(self._reduced)))
                basis, resid = hit
            self.map = step_map(self.lin, basis, dt, self.specs, self.exact_map)
            self.map.resid = resid
            self.gear = None if self.disable_fast else gear_map(self.lin, self.map, self.specs)
            if resid is not None and self.gear is None:  # only the gear kernel takes a reduced basis
                self.map = step_map(self.lin, self.basis(omega), dt, self.specs, self.exact_map)
        self.load_state(state)

    def _beta_of(self, st: SolverState) -> np.ndarray:
        """Amplitudes of all force columns (LinearModel order) at the state ``st``."""
        lin = self.lin
        beta = np.zeros(lin.m)
        beta[0] = 1.0
        for i in range(lin.nm):
            for j in range(lin.nb):
                c = lin.col_basis[i, j]
                if c >= 0:
                    beta[c] = st.coef[i, j] * st.force[i]
            beta[lin.col_comp[i]] = lin.kbar[i] * st.delta[i] + lin.cmesh[i] * st.delta_dot[i]
        beta[lin.col_eff0 :] = st.ampl
        return beta

    def load_state(self, st: SolverState) -> None:
        """Map a physical state into the current basis and rebuild the carried force amplitudes."""
        mp = self.map
        assert mp is not None
        lin = self.lin
        if mp.dense:
            self.zr = aligned(st.x)
            self.zi = aligned(np.zeros_like(st.x))
        else:
            z = mp.basis.to_modal(st.x)
            self.zr = aligned_zeros(mp.nmode)
            self.zi = aligned_zeros(mp.nmode)
            self.zr[: z.size] = z.real
            self.zi[: z.size] = z.imag
        beta = self._beta_of(st)
        self.beta_prev = aligned(beta)
        if self.gear is not None:
            self.beta_act = aligned(beta[self.gear.cols])
            for i in range(lin.nm):
                self.beta_act[i * lin.nb] -= st.coef[i, 0] * st.force[i]  # u_i also carries -V_i F_i
        self.ypred = aligned((mp.crr @ self.zr - mp.cri @ self.zi) if lin.nm else np.zeros(0))
        self.contact = st.contact.astype(np.int64).copy()

    def physical_x(self, st: SolverState | None = None) -> np.ndarray:
        """Physical state ``x``; with a reduced basis plus the dropped modes' static part at the column
        amplitudes of ``st`` (the state just reached)."""
        mp = self.map
        assert mp is not None
        if mp.dense:
            return self.zr.copy()
        if mp.xrec is None:  # contiguous transposes: the compiled loop runs along rows
            phi_t = mp.basis.phi.T
            nstate = mp.basis.phi.shape[0]
            rest = np.zeros((0, nstate)) if mp.resid is None else mp.resid.T
            mp.xrec = tuple(np.ascontiguousarray(a) for a in (phi_t.real, phi_t.imag, rest))
        phr, phi, rest = mp.xrec
        nk = mp.basis.lam.size
        beta = self._beta_of(st) if (mp.resid is not None and st is not None) else np.zeros(0)
        if beta.size == 0:
            rest = rest[:0]
        # plain compiled loops, not BLAS: a threaded BLAS matrix-vector product here cost 40x the
        # chunk on a loaded machine (docs/solver.md, "Cost")
        return kernels.modal_to_physical(phr, phi, self.zr[:nk], self.zi[:nk], rest, beta)

    def initial_outputs(self, st: SolverState) -> np.ndarray:
        """Channel values at the state ``st`` (for filter history before the start)."""
        mp = self.map
        assert mp is not None
        out = np.zeros(len(self.specs))
        cx, df = self.lin.output_rows(self.specs, mp.basis.omega)
        vals = cx @ st.x + df @ self.beta_prev
        for o, i in enumerate(self.row_index):
            out[i] = vals[o]
        for i, s in enumerate(self.specs):
            if s.kind == "dte":
                out[i] = st.delta[s.mesh]
            elif s.kind == "force":
                out[i] = st.force[s.mesh]
        return out

    # --- stepping
    def run(
        self,
        t: np.ndarray,
        angle: np.ndarray,
        speed: np.ndarray,
        st: SolverState,
        bound: float = DTE_BOUND_M,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
        """Advance over the new steps ``t[1:-1]`` (arrays with one extra step on each side).

        Returns channel samples (n, nch), delta (n, nm), delta' (n, nm), mesh force (n, nm),
        contact states (n, nm) and the excitation arrays (k, e, e_dot, coef, ampl); updates ``st``.
        """
        mp = self.map
        assert mp is not None
        lin = self.lin
        if self.gear is not None:
            return self._run_gear(t, angle, speed, st, bound)
        kt, et, edt, coef, ampl = excitation(lin, t, angle, speed, self.effects)
        n = kt.shape[0]
        no = len(self.row_index)
        out = np.empty((n, no))
        dte = np.empty((n, lin.nm))
        dted = np.empty((n, lin.nm))
        fm = np.empty((n, lin.nm))
        states = np.empty((n, lin.nm), dtype=np.int8)
        status, step, nfail = kernels.run_chunk(
            mp.dense,
            self.zr,
            self.zi,
            mp.rr,
            mp.ri,
            mp.tmat,
            mp.swr,
            mp.swi,
            mp.crr,
            mp.cri,
            mp.pq,
            mp.outr,
            mp.outi,
            mp.dfeed,
            lin.col_basis,
            lin.col_comp,
            lin.col_eff0,
            lin.kbar,
            lin.cmesh,
            lin.cmesh,
            lin.bstar,
            self.beta_prev,
            self.ypred,
            self.contact,
            kt,
            et,
            edt,
            coef,
            ampl,
            bound,
            out,
            dte,
            dted,
            fm,
            states,
        )
        self.n_mesh_fail += nfail
        if status != kernels.STATUS_OK:
            raise SimulationDiverged(
                float(t[1 + step]),
                float(speed[1 + step]) * 60.0 / (2.0 * np.pi),
                self.system.temperature_c,
                "non-finite state" if status == kernels.STATUS_NONFINITE else f"|DTE| above {bound:g} m",
            )
        ch = np.empty((n, len(self.specs)))
        for o, i in enumerate(self.row_index):
            ch[:, i] = out[:, o]
        for i, s in enumerate(self.specs):
            if s.kind == "dte":
                ch[:, i] = dte[:, s.mesh]
            elif s.kind == "force":
                ch[:, i] = fm[:, s.mesh]
        if n:
            _carry_chunk_end(st, dte, dted, fm, coef, ampl, self.contact, float(angle[-2]), float(t[-2]))
        st.x = self.physical_x(st)
        return ch, dte, dted, fm, states, (kt, et, edt, coef, ampl)

    def _run_gear(
        self, t: np.ndarray, angle: np.ndarray, speed: np.ndarray, st: SolverState, bound: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
        """:meth:`run` through :func:`gear_kernel.run_chunk_gear` (table meshes, modal map)."""
        gm = self.gear
        mp = self.map
        assert gm is not None and mp is not None
        lin = self.lin
        system = self.system
        nm = lin.nm
        n = t.size - 2
        known = slice(0, n + 1)  # the carried step and the new steps
        cyc_rate = np.array(
            [m.pinion_teeth * abs(float(system.shaft_speed_ratios[m.pinion_shaft])) / (2.0 * np.pi)
             for m in system.meshes]
        )  # fmt: skip
        bufs = self.chunk_buffers
        if bufs is None:
            cyc = angle[known, None] * cyc_rate[None, :]
            phase = np.ascontiguousarray(cyc - np.floor(cyc))
            prate = np.ascontiguousarray(speed[known, None] * cyc_rate[None, :])
        else:  # the same arithmetic into the kept arrays
            phase = bufs.get("phase", (n + 1, nm))
            fl = bufs.get("floor", (n + 1, nm))
            np.multiply(angle[known, None], cyc_rate[None, :], out=phase)
            np.floor(phase, out=fl)
            np.subtract(phase, fl, out=phase)
            prate = bufs.get("prate", (n + 1, nm))
            np.multiply(speed[known, None], cyc_rate[None, :], out=prate)
        none = np.zeros((0, nm))
        kfac = te = ted = none
        ampl_k = np.zeros((n + 1, lin.ne))
        if self.effects:
            # effect inputs on the carried step too (sub-steps interpolate between grid steps)
            t_e = np.concatenate([[2 * t[0] - t[1]], t])
            a_e = np.concatenate([[2 * angle[0] - angle[1]], angle])
            s_e = np.concatenate([[speed[0]], speed])
            kfac, te, ted, _, ampl_k = _effect_arrays(lin, t_e, a_e, s_e, self.effects)
            kfac, te, ted = (np.ascontiguousarray(a) for a in (kfac, te, ted))
        ampl_k = np.ascontiguousarray(ampl_k)
        all_in_gemm = gm.cstack.shape[1] == len(self.specs)
        out = np.empty((n, gm.cstack.shape[1]))  # every channel in order, or none (see gear_map)
        if bufs is None:
            dte, dted, fm, kt, et, edt = (np.empty((n, nm)) for _ in range(6))
            states = np.empty((n, nm), dtype=np.int8)
            coef = np.empty((n, nm, lin.nb))
        else:  # the channels (``out``) stay fresh: the decimator may hold them past this call
            dte, dted, fm, kt, et, edt = (bufs.get(k, (n, nm)) for k in ("d", "dd", "f", "k", "e", "ed"))
            states = bufs.get("states", (n, nm), np.int8)
            coef = bufs.get("coef", (n, nm, lin.nb))
        avg = bool(self.event_average)
        # the mesh channels with event_average (fresh: they are the channels; else unused, empty)
        dte_ch = np.empty((n, nm) if avg else (0, nm))
        fm_ch = np.empty((n, nm) if avg else (0, nm))
        if self._hbuf.shape[1] != gm.cstack.shape[0]:
            self._hbuf = aligned_zeros((OUTPUT_BLOCK_STEPS, gm.cstack.shape[0]))
        mcarry = np.ascontiguousarray(
            np.array([st.delta, st.delta_dot, st.force], dtype=float).reshape(3, nm)
        )
        outs = (gm.cstack, gm.dfeed_static, self._hbuf, out, dte, dted, fm, states, kt, et, edt, coef)
        outs += (dte_ch, fm_ch)
        status, step, nfail, nsub = gear_kernel.run_chunk_gear(
            (self.zr, self.zi, *gm.modal),
            gm.n_forced,
            gm.mesh,
            gm.tables,
            (phase, prate, kfac, te, ted, ampl_k),
            (self.beta_act, self.ypred, self.contact, mcarry),
            outs,
            float(mp.dt),
            bool(self.locate_events),
            bound,
            self.fuse_meshes,
            mp.exact,
            EXACT_MAP_MU_MAX,
            avg,
            bool(self.average_jumps),
        )
        self.n_substeps += nsub
        self.n_mesh_fail += nfail
        _check_chunk_status(status, float(t[1 + step]), float(speed[1 + step]), system.temperature_c, bound)
        if all_in_gemm:
            ch = out
        else:
            ch = _mesh_channels(self.specs, dte_ch if avg else dte, fm_ch if avg else fm, single_mesh=False)
        ampl = ampl_k[1:]
        if n:
            _carry_chunk_end(st, dte, dted, fm, coef, ampl, self.contact, float(angle[-2]), float(t[-2]))
        st.x = self.physical_x(st)
        return ch, dte, dted, fm, states, (kt, et, edt, coef, ampl)


class SimulationDiverged(RuntimeError):
    """The integration left the physical range (non-finite state or |DTE| above the bound)."""

    def __init__(self, time_s: float, speed_rpm: float, temperature_c: float, reason: str) -> None:
        super().__init__(
            f"simulation diverged at t = {time_s:.6g} s, speed = {speed_rpm:.6g} rpm, "
            f"temperature = {temperature_c:.6g} C: {reason}"
        )
        self.time_s = time_s
        self.speed_rpm = speed_rpm
        self.temperature_c = temperature_c
        self.reason = reason

    def __reduce__(self) -> tuple[type, tuple[float, float, float, str]]:
        """Rebuild from the constructor arguments (picklable across a process pool)."""
        return (type(self), (self.time_s, self.speed_rpm, self.temperature_c, self.reason))


def _carry_chunk_end(
    st: SolverState,
    dte: np.ndarray,
    dted: np.ndarray,
    fm: np.ndarray,
    coef: np.ndarray,
    ampl: np.ndarray,
    contact: np.ndarray,
    angle: float,
    time: float,
) -> None:
    """Carry the mesh state of a chunk's last step into ``st`` (every chunk path)."""
    st.delta = dte[-1].copy()
    st.delta_dot = dted[-1].copy()
    st.force = fm[-1].copy()
    st.coef = coef[-1].copy()
    st.ampl = ampl[-1].copy()
    st.contact = contact.copy()
    st.angle = angle
    st.time = time


def _check_chunk_status(
    status: int, t_s: float, speed_rad_s: float, temperature_c: float, bound: float
) -> None:
    """Raise :class:`SimulationDiverged` for a kernel status other than OK."""
    if status != kernels.STATUS_OK:
        raise SimulationDiverged(
            t_s,
            speed_rad_s * 60.0 / (2.0 * np.pi),
            temperature_c,
            "non-finite state" if status == kernels.STATUS_NONFINITE else f"|DTE| above {bound:g} m",
        )


def _mesh_channels(
    specs: list[ChannelSpec], dte: np.ndarray, fm: np.ndarray, single_mesh: bool
) -> np.ndarray:
    """The DTE / mesh-force channels of a chunk (the kernels' per-mesh columns, in ``specs`` order)."""
    ch = np.empty((dte.shape[0], len(specs)))
    for i, sp in enumerate(specs):
        col = 0 if single_mesh else sp.mesh
        ch[:, i] = dte[:, col] if sp.kind == "dte" else fm[:, col]
    return ch


def check_steps_per_mesh(steps_per_mesh: int) -> None:
    if not (
        isinstance(steps_per_mesh, int | np.integer)
        and MIN_STEPS_PER_MESH <= steps_per_mesh <= MAX_STEPS_PER_MESH
    ):
        raise ValueError(
            f"steps_per_mesh: {steps_per_mesh!r} must be an integer in "
            f"{MIN_STEPS_PER_MESH}..{MAX_STEPS_PER_MESH} "
            "(mesh-period resolution of the accuracy rule; the scheme itself is unconditionally stable)"
        )
