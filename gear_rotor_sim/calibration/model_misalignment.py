"""Model runs of a misaligned gear whose axial force follows the instantaneous mesh force.

``GearMisalignment``'s axial force is ``F(t) angle cos(theta + phi)`` with ``F(t)`` the mesh force
(``faults/misalignment_force.py``), which enters as the tilted wheel's synchronous part of a previous
run's mesh force: one fixed-point pass (the axial force does not act back on the spur mesh, so the
pass is exact: the second run's mesh force equals the first's to the last bit, measured at 3000 rpm
and 8000 rpm in ``test/test_misalignment_force.py``). :class:`ModelRunner` runs that pass through a
sibling runner with the mesh-force channel alone, over the whole hunting periods of its window and
with its step rule and settling, so the mesh force is the one of the analysed window.

A tilt whose mesh part is neutral (``GearMisalignment.full_contact``: the mesh deflection covers the
tilt across the face) does not change the mesh force at all; the pass then runs the model without it,
so that the two basis runs of the linear amplitude/phase fit (``candidates_misalignment.py``, 10 urad)
share one mesh-force run with each other and with every other full-contact tilt.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.model_window import whole_periods_samples
from gear_rotor_sim.faults import GearMisalignment


def mesh_force_run(
    runner: Any, speed_rpm: float, system: Any
) -> Callable[[Sequence[object], list[str]], tuple[np.ndarray, np.ndarray]]:
    """``mesh_force`` callable of :func:`gear_rotor_sim.faults.misalignment_force.with_mesh_force`
    for a :class:`~gear_rotor_sim.calibration.residual.ModelRunner` at the (effective) input speed
    ``speed_rpm``; ``system`` the assembled model (for ``full_contact``)."""

    def run(effects: Sequence[object], channels: list[str]) -> tuple[np.ndarray, np.ndarray]:
        kept = tuple(e for e in effects if not (isinstance(e, GearMisalignment) and e.full_contact(system)))
        n = whole_periods_samples(runner.cfg, speed_rpm, runner.sample_rate_hz, runner.n_model)
        sibling = dataclasses.replace(
            runner,
            channels=list(channels),
            sensors={},
            n_model=n,
            instantaneous_misalignment=False,
            n_runs=0,
            n_moved=0,
        )
        data = sibling.force_signals(kept)
        runner.n_runs += sibling.n_runs
        i0 = round(runner.start_time * runner.sample_rate_hz)
        # a window moved on past a step-rule switch moves by whole hunting periods: the wheel angles
        # of the nominal times hold (model_settle.py)
        t = (i0 + np.arange(data.shape[0])) / runner.sample_rate_hz
        return t, data

    return run
