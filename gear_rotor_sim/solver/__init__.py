"""Nonlinear Newmark solver: exact modal trapezoidal map.

The stepper in ``newmark``, its set-up in ``linear_model``, ``modal_basis``, ``modal_map``,
``gear_arrays``, ``excitation``, ``state``, ``channels``, ``arrays`` (re-exported by ``newmark``);
compiled kernels in ``gear_kernel`` (any number of table meshes, full or
reduced modal basis, event location) and ``kernels`` (general: dense fallback, per-step arrays); the
default dt rule in ``dt_rule``; constant-speed runs in ``steady``; anti-aliasing decimation in
``decimate``. Importing the package runs ``cache_guard.check()``: numba's cached kernels are deleted
when the kernel sources' content changed (a caller's cache holds its callees' code).
"""

from gear_rotor_sim.solver import cache_guard as _cache_guard

# before any kernel is called (numba reads its cache at the first call): a stale caller's cache away
_cache_guard.check()

from gear_rotor_sim.solver.newmark import (  # noqa: E402
    DTE_BOUND_M,
    MIN_STEPS_PER_MESH,
    SPEED_QUANTUM_REL,
    LinearModel,
    NewmarkStepper,
    SimulationDiverged,
    SolverState,
    StepContext,
    available_channels,
    mesh_law,
    parse_channels,
    quantize_speed_rpm,
    static_equilibrium,
)
from gear_rotor_sim.solver.steady import SteadyResult, simulate_steady  # noqa: E402

__all__ = [
    "DTE_BOUND_M",
    "MIN_STEPS_PER_MESH",
    "SPEED_QUANTUM_REL",
    "LinearModel",
    "NewmarkStepper",
    "SimulationDiverged",
    "SolverState",
    "SteadyResult",
    "StepContext",
    "available_channels",
    "mesh_law",
    "parse_channels",
    "quantize_speed_rpm",
    "simulate_steady",
    "static_equilibrium",
]
