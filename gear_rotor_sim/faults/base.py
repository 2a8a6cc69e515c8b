"""Base of the fault and effect library: fitted-parameter specs and the Effect protocol's defaults.

An effect is a physical change of the machine that the simulator applies, whoever asked for it
(the node and ``record --faults`` inject it, datasets label with it, the calibration fits it). It
may multiply the mesh stiffness, add to the static transmission error, apply forces (fixed DOF
vectors times per-step amplitudes), modify the configuration or the operating point
(``docs/design.md``, "Effects").
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from gear_rotor_sim.config import RigConfig


@dataclass(frozen=True)
class ParameterSpec:
    """A fitted parameter: name, unit, bounds, and how the fit treats it.

    ``role`` is ``"amplitude"`` (enters linearly through a basis response), ``"phase"`` (paired
    with the amplitude through a cos/sin basis), ``"scalar"`` (nonlinear, fitted on a grid then
    refined) or ``"index"`` (integer, searched exhaustively).
    """

    name: str
    unit: str
    lower: float
    upper: float
    role: str = "scalar"
    description: str = ""


def node_xy_columns(system: Any, node0: int) -> np.ndarray:
    cols = np.zeros((system.ndof, 2))
    cols[6 * node0, 0] = 1.0
    cols[6 * node0 + 1, 1] = 1.0
    return cols


def shaft_index(system: Any, node0: int) -> int:
    return int(np.asarray(system.shaft_of_node)[node0])


@dataclass(frozen=True)
class Effect:
    """Base of the library: parameter bookkeeping and the protocol's neutral defaults."""

    name: ClassVar[str] = "effect"
    signature: ClassVar[str] = ""
    specs: ClassVar[tuple[ParameterSpec, ...]] = ()

    @property
    def label(self) -> str:
        """Name plus the fixed location (e.g. ``outer_race_defect@bearing2``)."""
        return self.name

    def parameters(self) -> dict[str, float]:
        """Current values of the fitted parameters."""
        return {s.name: float(getattr(self, s.name)) for s in self.specs}

    def with_parameters(self, **values: float) -> Effect:
        """Copy with parameters replaced (clipped to bounds; index parameters rounded)."""
        changes: dict[str, Any] = {}
        for s in self.specs:
            if s.name in values:
                v = float(np.clip(values[s.name], s.lower, s.upper))
                changes[s.name] = round(v) if s.role == "index" else v
        return dataclasses.replace(self, **changes)

    def applicable(self, cfg: RigConfig) -> bool:
        """Whether the effect makes sense for the rig (e.g. gear effects need a mesh)."""
        return True

    def main_parameter(self) -> str:
        """The parameter compared with the truth in the self-test (amplitude-like)."""
        return self.specs[0].name

    # Effect protocol (docs/design.md); neutral defaults
    def mesh_stiffness_factor(self, ctx: Any) -> np.ndarray | None:
        return None

    def transmission_error(self, ctx: Any) -> np.ndarray | None:
        return None

    def external_forces(self, system: Any) -> np.ndarray | None:
        return None

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        return None

    def modify_config(self, cfg: RigConfig) -> RigConfig:
        return cfg

    def operating_point(self, speed_rpm: float, temperature_c: float) -> tuple[float, float]:
        """Actual operating point given the declared one (only temperature_offset changes it)."""
        return speed_rpm, temperature_c
