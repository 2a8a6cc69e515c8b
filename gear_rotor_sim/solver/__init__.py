"""Nonlinear Newmark solver: exact modal trapezoidal map.

The stepper in ``newmark``, its set-up in ``linear_model``, ``modal_basis``, ``modal_map``,
``gear_arrays``, ``excitation``, ``state``, ``channels``, ``arrays`` (re-exported by ``newmark``);
compiled kernels in ``gear_kernel`` (any number of table meshes, full or
reduced modal basis, event location) and ``kernels`` (general: dense fallback, per-step arrays); the
default dt rule in ``dt_rule``; constant-speed runs in ``steady``; anti-aliasing decimation in
``decimate``.
"""

from gear_rotor_sim.solver.newmark import (
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
from gear_rotor_sim.solver.steady import SteadyResult, simulate_steady

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
