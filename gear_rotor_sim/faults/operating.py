"""Operating-point effect: the machine runs at another steady temperature than declared."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from gear_rotor_sim.faults.base import Effect, ParameterSpec


@dataclass(frozen=True)
class TemperatureOffset(Effect):
    """The machine's steady temperature differs from the declared one by ``offset_c``.

    Parameters
    ----------
    offset_c : float
        Actual minus declared temperature, degC.
    """

    offset_c: float = 0.0
    name: ClassVar[str] = "temperature_offset"
    signature: ClassVar[str] = (
        "mesh stiffness (E(T)), backlash and thermal profile error change: amplitudes and "
        "phases of all mesh harmonics, shift of the mesh resonances"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("offset_c", "degC", -300.0, 300.0, "scalar", "actual - declared temperature"),
    )

    def operating_point(self, speed_rpm: float, temperature_c: float) -> tuple[float, float]:
        return speed_rpm, temperature_c + self.offset_c
