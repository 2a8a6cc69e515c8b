"""Exact modal form of Newmark average acceleration for Eq 39 with the nonlinear mesh (Eqs 21-33).

The stepper (:class:`NewmarkStepper`: one linear model, cached bases, the kernel) is here; its set-up
(Python/NumPy/SciPy) is in modules of one role each, whose names this module re-exports:
:mod:`.linear_model` (the linear part and force columns), :mod:`.modal_basis` (the eigenbasis per
speed), :mod:`.modal_map` (the step map per dt, the modal reduction with static correction),
:mod:`.gear_arrays` (the mesh tables split at their jumps, the gear kernel's arrays),
:mod:`.excitation` (mesh phases and effects per step), :mod:`.state` (the carried state, the static
equilibrium), :mod:`.channels` (output channels), :mod:`.arrays` (aligned and per-chunk arrays). The
per-step work is compiled: :mod:`gear_rotor_sim.solver.gear_kernel`, :mod:`gear_rotor_sim.solver.kernels`.

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

from collections import OrderedDict
from collections.abc import Callable, Sequence

import numpy as np

from gear_rotor_sim.solver import gear_kernel, kernels
from gear_rotor_sim.solver.arrays import ChunkBuffers, aligned, aligned_zeros
from gear_rotor_sim.solver.channels import ChannelSpec, available_channels, parse_channels
from gear_rotor_sim.solver.excitation import (
    StepContext,
    effect_columns,
    excitation,
    make_context,
    mesh_phases,
)
from gear_rotor_sim.solver.excitation import _effect_arrays as _effect_arrays
from gear_rotor_sim.solver.excitation import _effect_call as _effect_call
from gear_rotor_sim.solver.gear_arrays import OUTPUT_BLOCK_STEPS, GearMap, gear_map, split_table_jumps
from gear_rotor_sim.solver.gear_arrays import _jump_intervals as _jump_intervals
from gear_rotor_sim.solver.gear_arrays import _output_stack as _output_stack
from gear_rotor_sim.solver.gear_arrays import _static_feed as _static_feed
from gear_rotor_sim.solver.linear_model import LinearModel
from gear_rotor_sim.solver.modal_basis import _BASIS_MEMO as _BASIS_MEMO
from gear_rotor_sim.solver.modal_basis import COND_LIMIT, Basis, eigen_basis, state_blocks
from gear_rotor_sim.solver.modal_basis import _block_eig as _block_eig
from gear_rotor_sim.solver.modal_basis import _eigen_basis as _eigen_basis
from gear_rotor_sim.solver.modal_map import (
    EXACT_MAP_MU_MAX,
    StepMap,
    reduce_basis,
    residual_flexibility,
    step_map,
)
from gear_rotor_sim.solver.modal_map import _pad as _pad
from gear_rotor_sim.solver.state import SolverState, mesh_law, static_equilibrium
from gear_rotor_sim.system_data import AssembledSystem

# The set-up was one module; its parts are re-exported here so that every name stays importable.
__all__ = [
    "COND_LIMIT",
    "DTE_BOUND_M",
    "EXACT_MAP_MU_MAX",
    "MAX_STEPS_PER_MESH",
    "MIN_STEPS_PER_MESH",
    "OUTPUT_BLOCK_STEPS",
    "SPEED_QUANTUM_REL",
    "SPEED_ZERO_RPM",
    "Basis",
    "ChannelSpec",
    "ChunkBuffers",
    "GearMap",
    "LinearModel",
    "NewmarkStepper",
    "SimulationDiverged",
    "SolverState",
    "StepContext",
    "StepMap",
    "aligned",
    "aligned_zeros",
    "available_channels",
    "check_steps_per_mesh",
    "effect_columns",
    "eigen_basis",
    "excitation",
    "gear_map",
    "make_context",
    "mesh_frequencies_hz",
    "mesh_frequency_hz",
    "mesh_law",
    "mesh_phases",
    "parse_channels",
    "quantize_speed_rpm",
    "reduce_basis",
    "residual_flexibility",
    "split_table_jumps",
    "state_blocks",
    "static_equilibrium",
    "step_map",
]

#: Relative speed quantum of the eigenbasis cache: the gyroscopic matrix is taken at the speed rounded
#: to a log grid of this ratio, so the gyroscopic moments are within half of it (0.5 %) of exact.
SPEED_QUANTUM_REL = 0.01
#: Below this input speed the gyroscopic term is taken at zero speed.
SPEED_ZERO_RPM = 0.5

#: Smallest accepted steps per mesh period.
MIN_STEPS_PER_MESH = 8
#: Largest accepted steps per mesh period.
MAX_STEPS_PER_MESH = 4096
#: Divergence bound on |DTE|, m.
DTE_BOUND_M = 1e-2


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
        excitation_rows: bool = True,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
        """Advance over the new steps ``t[1:-1]`` (arrays with one extra step on each side).

        Returns channel samples (n, nch), delta (n, nm), delta' (n, nm), mesh force (n, nm),
        contact states (n, nm) and the excitation arrays (k, e, e_dot, coef, ampl); updates ``st``.
        ``excitation_rows=False`` (the table-mesh kernel only): delta' and the excitation arrays k,
        e, e_dot, coef hold the last step's row only, and so does delta where the channels do not
        read it (``event_average``); the channels, the mesh force, the states and ``st`` are the
        same (docs/history/solver_sessions.md, "Session 24").
        """
        mp = self.map
        assert mp is not None
        lin = self.lin
        if self.gear is not None:
            return self._run_gear(t, angle, speed, st, bound, excitation_rows)
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
        self,
        t: np.ndarray,
        angle: np.ndarray,
        speed: np.ndarray,
        st: SolverState,
        bound: float,
        excitation_rows: bool = True,
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
        avg = bool(self.event_average)
        # rows of delta and of the excitation arrays: every step's, or the last step's only
        nx = n if excitation_rows else min(n, 1)
        nd = n if (excitation_rows or not avg) else nx
        if bufs is None:
            dte = np.empty((nd, nm))
            fm = np.empty((n, nm))
            dted, kt, et, edt = (np.empty((nx, nm)) for _ in range(4))
            states = np.empty((n, nm), dtype=np.int8)
            coef = np.empty((nx, nm, lin.nb))
        else:  # the channels (``out``) stay fresh: the decimator may hold them past this call
            dte = bufs.get("d", (nd, nm))
            fm = bufs.get("f", (n, nm))
            dted, kt, et, edt = (bufs.get(k, (nx, nm)) for k in ("dd", "k", "e", "ed"))
            states = bufs.get("states", (n, nm), np.int8)
            coef = bufs.get("coef", (nx, nm, lin.nb))
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
