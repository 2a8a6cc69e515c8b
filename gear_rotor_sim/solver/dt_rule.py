"""The default dt rule (docs/solver.md, "Default dt rule"): steps per mesh period and event location.

Three parts, each measured (benchmarks/convergence_events.py): 32 steps per mesh period while the
teeth stay in contact; at least ``CONTACT_LOSS_RATE_HZ`` with the mesh events located while they
separate; and, near a resonance of a lightly damped mesh-coupled mode with a low mesh harmonic, a
step that keeps Newmark's period error at that mode small against its bandwidth.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gear_rotor_sim.solver.newmark import MAX_STEPS_PER_MESH

if TYPE_CHECKING:
    from gear_rotor_sim.solver.newmark import Basis, LinearModel

#: Steps per mesh period of the default dt rule while the teeth stay in contact.
DEFAULT_STEPS_PER_MESH = 32
#: Event location pays from this resolution on even without contact loss: below it the trapezoidal
#: rule's period error at the mesh-coupled modes dominates and location costs 30-50 % of the step
#: rate for no consistent gain (docs/solver.md).
LOCATE_EVENTS_FROM_STEPS = 48
#: The dt rule while the teeth separate: at least this many steps per second, events located.
#: Impacts excite the mesh-coupled modes (3.5-3.6 kHz) and the lightly damped 11.5-11.8 kHz modes
#: whatever the mesh frequency, so the step is bounded in time, not per mesh period (docs/solver.md).
CONTACT_LOSS_RATE_HZ = 320e3
#: The dt rule's resonance part: a mode with damping ratio below ``RESONANCE_ZETA_MAX`` whose resonant
#: DTE compliance is at least ``RESONANCE_PARTICIPATION`` of the static one is resolved, while a
#: mesh harmonic ``h <= RESONANCE_HARMONICS`` lies within ``RESONANCE_HALF_WIDTHS`` half-power
#: half-widths of it, so that the trapezoidal period error stays below ``RESONANCE_PERIOD_ERROR``
#: times its damping ratio (docs/solver.md, "Default dt rule").
RESONANCE_ZETA_MAX = 0.02
RESONANCE_PARTICIPATION = 0.05
RESONANCE_HARMONICS = 3
RESONANCE_HALF_WIDTHS = 10.0
RESONANCE_PERIOD_ERROR = 0.03


def check_contact_loss_rate(contact_loss_rate_hz: float | None, upper_hz: float = math.inf) -> None:
    """Refuse a contact-loss rate that is not finite and in (0, ``upper_hz``] (None: the rule is off)."""
    if contact_loss_rate_hz is not None and not (
        math.isfinite(contact_loss_rate_hz) and 0 < contact_loss_rate_hz <= upper_hz
    ):
        raise ValueError(
            f"contact_loss_rate_hz: {contact_loss_rate_hz!r} must be finite, > 0 and <= {upper_hz:g}, "
            "or None (fixed steps per mesh period)"
        )


def rule_locate_events(steps_per_mesh: float, contact_loss: bool) -> bool:
    """The dt rule's event location: on while the teeth separate, else from 48 steps per mesh."""
    return bool(contact_loss) or steps_per_mesh >= LOCATE_EVENTS_FROM_STEPS


def light_mesh_modes(lin: LinearModel, basis: Basis) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies (Hz) and damping ratios of the lightly damped modes the mesh drives.

    Participation of mode j in the DTE per unit mesh force at resonance, relative to the static
    mesh compliance: ``|c_j w_j| / (|lam_j| 2 zeta_j) / |sum_k Re(c_j w_j / -lam_k)|`` with
    ``c = V Phi`` and ``w = Phi^-1 [0; M^-1 V^T]`` (largest over the meshes). Cached on the basis.
    """
    if basis.light is not None:
        return basis.light
    none = (np.zeros(0), np.zeros(0))
    if basis.dense or lin.nm == 0:
        basis.light = none
        return none
    n = lin.nfree
    lam = basis.lam
    mag = np.abs(lam)
    zeta = -lam.real / np.maximum(mag, 1e-300)
    part = np.zeros(lam.size)
    for i in range(lin.nm):
        col = np.zeros(lin.nstate)
        col[n:] = lin.MinvF[:, lin.col_comp[i]]
        cw = (lin.V[i] @ basis.phi[:n]) * basis.to_modal(col[:, None])[:, 0]
        static = abs(float(np.sum((cw / -lam).real)))
        if static > 0:
            part = np.maximum(part, np.abs(cw) / (mag * 2.0 * np.maximum(zeta, 1e-12)) / static)
    sel = (lam.imag > 0) & (zeta < RESONANCE_ZETA_MAX) & (part >= RESONANCE_PARTICIPATION)
    basis.light = (mag[sel] / (2.0 * np.pi), zeta[sel])
    return basis.light


def resonance_rate_hz(f_mesh_hz: float, light: tuple[np.ndarray, np.ndarray]) -> float:
    """Integration rate the dt rule needs for the light modes near a low mesh harmonic (0: none)."""
    rate = 0.0
    for f, zeta in zip(light[0].tolist(), light[1].tolist(), strict=True):  # a few modes: plain floats
        for h in range(1, RESONANCE_HARMONICS + 1):
            if abs(h * f_mesh_hz - f) <= RESONANCE_HALF_WIDTHS * zeta * f:
                # trapezoidal period error (omega dt)^2 / 12 <= RESONANCE_PERIOD_ERROR * zeta
                rate = max(rate, 2.0 * math.pi * f / math.sqrt(12.0 * RESONANCE_PERIOD_ERROR * zeta))
    return rate


def rule_steps_per_mesh(
    f_mesh_hz: float,
    contact_loss: bool,
    steps_per_mesh: int = DEFAULT_STEPS_PER_MESH,
    contact_loss_rate_hz: float | None = CONTACT_LOSS_RATE_HZ,
    resonance_rate: float = 0.0,
) -> int:
    """Steps per mesh period of the default dt rule (docs/solver.md, "Default dt rule").

    ``steps_per_mesh``; while the teeth separate (free flight or back-side contact) at least
    ``contact_loss_rate_hz / f_mesh``; near a resonance of a light mode with a low mesh harmonic at
    least ``resonance_rate / f_mesh`` (:func:`resonance_rate_hz`). Measured: RMS DTE within 0.5 % of
    the converged value at 25, 125 and 225 C over 1000-20000 rpm (benchmarks/convergence_events.py).
    """
    n = float(steps_per_mesh)
    if f_mesh_hz > 0:
        if contact_loss and contact_loss_rate_hz is not None:
            n = max(n, contact_loss_rate_hz / f_mesh_hz)
        n = max(n, resonance_rate / f_mesh_hz)
    return min(math.ceil(n * (1.0 - 1e-12)), MAX_STEPS_PER_MESH)
