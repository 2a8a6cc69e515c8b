"""One steady-state run at one speed, and a segment of speeds run with continuation.

:func:`steady_run` is the only place of the analysis that calls the simulator's steady-state runner;
:func:`run_segment` visits increasing speeds of one case, each starting from the previous final state,
and stacks a reducer's per-speed output (the unit of work of :mod:`.parallel`).
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gear_rotor_sim.analysis.cases import Case, build_system
from gear_rotor_sim.analysis.parallel import tick
from gear_rotor_sim.solver.dt_rule import CONTACT_LOSS_RATE_HZ


@dataclass(frozen=True)
class RunSettings:
    """Integration window per speed.

    Attributes
    ----------
    n_transient_periods : int
        Mesh periods discarded before sampling (continuation runs).
    n_periods : int
        Mesh periods sampled after the transient.
    steps_per_mesh : int
        Newmark steps per mesh period while the teeth stay in contact (samples are kept at every step).
    first_transient_factor : float
        Transient multiplier for the first speed of a segment (no continuation state yet).
    contact_loss_rate_hz : float or None
        The default dt rule: once the teeth separate, at least this many steps per second with the
        events located (``simulate_steady``); None keeps ``steps_per_mesh`` throughout.
    """

    n_transient_periods: int = 300
    n_periods: int = 200
    steps_per_mesh: int = 32
    first_transient_factor: float = 4.0
    contact_loss_rate_hz: float | None = CONTACT_LOSS_RATE_HZ


def steady_run(
    system: Any,
    speed_rpm: float,
    settings: RunSettings,
    channels: Sequence[str],
    initial_state: Any = None,
    first: bool = False,
) -> tuple[np.ndarray, Any, RunSettings]:
    """Integrate to steady state at one speed and return per-step samples.

    Returns
    -------
    data : numpy.ndarray
        Shape ``(n_periods * spm, len(channels))`` with ``spm = used.steps_per_mesh``; sample ``k`` is
        step ``k + 1`` of the sampled window, so samples ``spm - 1, 2 spm - 1, ...`` are at mesh
        phase 0.
    state : object
        The simulator's final state, passed back as ``initial_state`` for the next speed.
    used : RunSettings
        ``settings`` with the steps per mesh period the dt rule chose for the sampled window.
    """
    from gear_rotor_sim.solver.steady import simulate_steady

    n_tr = settings.n_transient_periods
    if first or initial_state is None:
        n_tr = int(np.ceil(n_tr * settings.first_transient_factor))
    res, state = simulate_steady(
        system,
        float(speed_rpm),
        n_transient_periods=n_tr,
        n_periods=settings.n_periods,
        steps_per_mesh=settings.steps_per_mesh,
        channels=list(channels),
        initial_state=initial_state,
        sample="step",
        contact_loss_rate_hz=settings.contact_loss_rate_hz,
    )
    used = settings
    if res.steps_per_mesh != settings.steps_per_mesh:
        used = dataclasses.replace(settings, steps_per_mesh=res.steps_per_mesh)
    data = np.asarray(res.data, dtype=float)
    expected = (used.n_periods * used.steps_per_mesh, len(channels))
    if data.shape != expected:
        raise RuntimeError(f"simulate_steady returned shape {data.shape}, expected {expected}")
    return data, state, used


def mesh_period_s(system: Any, speed_rpm: float) -> float:
    """Mesh period of the (first) mesh of ``system`` at input speed ``speed_rpm``."""
    teeth = system.meshes[0].pinion_teeth
    return 60.0 / (float(speed_rpm) * teeth)


def run_segment(
    case: Case,
    speeds_rpm: np.ndarray,
    settings: RunSettings,
    channels: Sequence[str],
    reducer: Callable[[np.ndarray, Sequence[str], RunSettings, float], dict],
) -> dict[str, np.ndarray]:
    """Run consecutive speeds of one case with continuation; stack the reducer's outputs.

    Returns
    -------
    dict
        Each reducer key stacked over speeds (first axis), plus ``wall_s`` per speed.
    """
    system = build_system(case)
    state = None
    rows: list[dict] = []
    walls = []
    for i, s in enumerate(np.asarray(speeds_rpm, dtype=float)):
        t0 = time.perf_counter()
        data, state, used = steady_run(system, s, settings, channels, state, first=(i == 0))
        dt = mesh_period_s(system, s) / used.steps_per_mesh
        rows.append(reducer(data, channels, used, dt))
        walls.append(time.perf_counter() - t0)
        tick()
    out = {k: np.stack([r[k] for r in rows]) for k in rows[0]}
    out["wall_s"] = np.asarray(walls)
    return out


SegmentFn = Callable[..., dict]


def split_segments(n: int, n_segments: int) -> list[slice]:
    """Contiguous, nearly equal slices covering ``range(n)`` (no empty slice)."""
    n_segments = max(1, min(n_segments, n))
    bounds = np.linspace(0, n, n_segments + 1).round().astype(int)
    return [slice(int(a), int(b)) for a, b in itertools.pairwise(bounds) if b > a]
