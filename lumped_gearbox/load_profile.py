"""An output torque that fluctuates within the record: the driven machine's load (issue 11).

A pump, compressor, conveyor or generator does not hold a constant torque: its load fluctuates slowly (a
few Hz, 5-20 %), or at an order of the driven shaft (a reciprocating compressor: 1x / 2x of the output
shaft). The output torque on the gear is

    T2(t) = T0 [1 + A sin(2 pi f t + phi)]         (``frequency_hz``: a fixed frequency), or
    T2(t) = T0 [1 + A sin(k psi2(t) + phi)]        (``gear_order``: locked to the gear's angle psi2),

with ``T0`` the gearbox's ``output_torque_nm`` (the mean, the torque the sidecar declares) and
``A = amplitude_pct / 100``. The kernel (``model._rhs``) applies ``T2(t)`` to the gear's torsional
equation ``J2 q2'' = T2(t) - F_m rb2`` in place of the constant ``T0``.

Physical derivation. The driven machine acts on the gear through a coupling and the output shaft; where
their torsional mode ``f_c`` lies far above the modulation (a few Hz against hundreds), the torque they
pass on is the machine's times ``1 / (1 - (f / f_c)^2) ~ 1``: quasi-static, so it is applied to the gear
directly (the generator has no output-shaft compliance: the gear carries ``T2`` directly,
docs/independent_data.md "The model"). Below the drivetrain's own torsional mode (the gear and pinion on
the input shaft's torsion spring) the gear's angular acceleration is small, so the mean mesh force over a
mesh period follows ``T2(t) / rb2`` and the bearings' static reactions follow it by the lever rule:
the mesh force, the DTE mean (``F / k``) and the radial bearing-force "means" are modulated at ``f``.
With ``A = 0`` (the default) the kernel runs the constant-torque expressions, bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .faults import check_range

#: allowed ranges (docs/independent_data.md "Load-torque profile"): amplitude in percent of the mean
#: torque, the fixed frequency, the order of the gear shaft
AMPLITUDE_PCT_MAX = 50.0
FREQUENCY_HZ_MAX = 200.0
GEAR_ORDER_MAX = 10.0
#: length of the kernel's load-profile part (model.py: L_TA .. L_TPH): [A, omega, k, phi]
N_LOAD_PROFILE = 4


@dataclass(frozen=True)
class LoadProfile:
    """A sinusoidal fluctuation of the output torque about its mean (module docstring).

    Attributes
    ----------
    amplitude_pct : float
        ``A``, percent of the mean torque (``0 .. 50``).
    frequency_hz : float
        A fixed modulation frequency, Hz (``0 .. 200``); exclusive with ``gear_order``.
    gear_order : float
        Modulation locked to the gear's angle at this order of the gear shaft (``0 .. 10``; 1: once per
        gear revolution); exclusive with ``frequency_hz``.
    phase_rad : float
        ``phi`` at ``t = 0`` (gear angle 0).
    """

    amplitude_pct: float = 0.0
    frequency_hz: float = 0.0
    gear_order: float = 0.0
    phase_rad: float = 0.0

    def __post_init__(self) -> None:
        check_range("load_profile.amplitude_pct", self.amplitude_pct, 0.0, AMPLITUDE_PCT_MAX)
        check_range("load_profile.frequency_hz", self.frequency_hz, 0.0, FREQUENCY_HZ_MAX)
        check_range("load_profile.gear_order", self.gear_order, 0.0, GEAR_ORDER_MAX)
        check_range("load_profile.phase_rad", self.phase_rad, -10.0, 10.0)
        if self.amplitude_pct > 0.0 and (self.frequency_hz > 0.0) == (self.gear_order > 0.0):
            raise ValueError(
                "load_profile.frequency_hz / load_profile.gear_order: exactly one must be > 0 "
                "with an amplitude_pct > 0"
            )

    @property
    def constant(self) -> bool:
        """Whether the torque is the mean one throughout."""
        return self.amplitude_pct == 0.0

    def vector(self) -> np.ndarray:
        """The kernel's ``[A, omega, k, phi]`` (``model.L_TA`` ..): ``T2 / T0 = 1 + A sin(omega t + k psi2 +
        phi)``; all zero for a constant torque (the kernel then runs the constant-torque expression)."""
        p = np.zeros(N_LOAD_PROFILE)
        if self.constant:
            return p
        p[:] = [
            self.amplitude_pct / 100.0,
            2.0 * math.pi * self.frequency_hz,
            self.gear_order,
            self.phase_rad,
        ]
        return p

    def truth(self) -> dict[str, Any]:
        return {
            "amplitude_pct": self.amplitude_pct,
            "frequency_hz": self.frequency_hz,
            "gear_order": self.gear_order,
            "phase_rad": self.phase_rad,
        }


def relative_torque(p: np.ndarray, t: np.ndarray, psi2: np.ndarray) -> np.ndarray:
    """``T2(t) / T0`` of a load-profile vector (:meth:`LoadProfile.vector`) at times ``t`` and gear angles
    ``psi2`` (rad; ``w2 t`` at a constant speed)."""
    t = np.asarray(t, dtype=float)
    if p[0] == 0.0:
        return np.ones_like(t)
    return 1.0 + p[0] * np.sin(p[1] * t + p[2] * np.asarray(psi2, dtype=float) + p[3])
