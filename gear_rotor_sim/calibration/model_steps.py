"""Steps per mesh period of the calibration's model runs, from the model's own convergence.

The simulator integrates at ``steps_per_mesh`` steps per mesh period (``solver/dt_rule.py``; more
where the teeth separate). The calibration used a fixed 32 without a reference and 64 against one.
Whether a count is fine enough depends on the operating point: the mesh-stiffness jumps (a pair
entering or leaving contact) fall between step instants by a fraction of a step that repeats with the
beat of the step grid against the tooth count. At 3000 rpm and a 20 kHz output the grid holds 1200
steps per pinion revolution and that error is synchronous with the pinion (lines at its orders,
docs/history/calibration_sessions.md Sec. 8.18); at 4500 rpm / 75 C the grid is not a whole number of steps
per revolution and the same error is *non-synchronous*: the FE paper gearbox's healthy run at 32 steps
holds 17.6 N (20 % of the RMS) at ``bearing2_fx`` that every shaft's synchronous average leaves,
0.43 N at 64 and 0.22 N at 128 (Sec. 8.22, "cause B"; Sec. 8.24). That content decides which signal
the envelope family analyses (the non-synchronous part only where the healthy model is periodic,
``Comparison._choose_envelope_input``) and sits in the expected envelope spectra as if it were
physics.

Rule (:func:`converged_steps_per_mesh`): the healthy model of the record's operating point is run at
``n`` and ``2 n`` steps per mesh period (``n`` from 32, or 64 against a held reference); the count
``n`` is kept if at every envelope channel (the channels measured at a bearing, the envelope
family's inputs) the RMS of the difference between the two runs' non-synchronous parts is at most
``STEP_NOISE_FRACTION`` (1) of the measured noise of that channel; else ``n`` is doubled, up to
``MAX_STEPS_PER_MESH``. The noise is the robust standard deviation (1.4826 x the median absolute
deviation) of the record's non-synchronous part: sparse bearing impacts hardly move it, so the
healthy and the faulty records of one operating point see the same noise. Deterministic, one
criterion for every record, and it costs one or two extra healthy runs per record.

A record made by this simulator (``gear-rotor-sim record``: its MCAP metadata names the generator, and
the recorder runs the default dt rule, 32 steps per mesh period, ``solver.dt_rule``) is calibrated at
that count instead (:func:`recorded_steps`): its non-synchronous part is the recorder's own numerical
residue, not noise, so against it the rule above asks for the finest count it tries (256 on the 2 s
healthy record at 3000 rpm / 25 C), whose numerics differ from the record's by more than the record's
"noise": there the sensor gains and transfer slopes went to their bounds, the order family read 201
and a pinion tooth was claimed (docs/history/calibration_sessions.md Secs. 8.75, 8.76). At the record's
own count the model runs on the record's time grid (``dt = 1 / (k fs)``, ``k`` the same) and reproduces
its means and standard deviations to 4 digits.

What it does not converge, on purpose: the order features of the shaft orders. With the simulator's
own accelerations they converge only as the step (Sec. 8.18: ``node5_ay`` 7.3, 3.5 and 0.22 m/s^2
RMS over the non-carrier pinion orders at 32, 64 and 1024 steps at 3000 rpm), so a criterion on them
in units of the order noise asks for several hundred steps per mesh on every contact record (measured
at 3000 rpm: mean squared difference 64 against 128 steps of 460 order-noise variances at
``node5_ax``); the cure there is the velocity derivative of the reference numerics, not the step.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.features_orders import remove_synchronous

#: largest RMS difference of the healthy model's non-synchronous part between ``n`` and ``2 n`` steps
#: per mesh period, as a fraction of the measured noise of the channel (docs/history/calibration_sessions.md
#: Sec. 8.24). Measured (worst channel) on the 27 table records: 0.006-0.44 at 32 steps (kept), and the 4500
#: rpm / 75 C records 7.5-12.2 at 32 (0.10-0.16 at 64); the FE model's own noise-free record at 3000 rpm
#: (``test_faults_calibrate``, whose only "noise" is its own 32-step numerics) 0.47-0.52. 0.5 sent that
#: record to 64 steps, where the gear tooth reads tooth 6 for 5 (the gear tooth index at 64 steps is
#: itself not converged, Sec. 8.21 item 1); 1 lies a factor 1.9 above 0.52 and 7.5 below 7.5
STEP_NOISE_FRACTION = 1.0
#: finest count the rule asks for (a count that is still not converged there is used and reported)
MAX_STEPS_PER_MESH = 256


@dataclass
class StepChoice:
    """Result of :func:`converged_steps_per_mesh`.

    Attributes
    ----------
    steps_per_mesh : int
        The coarsest count whose comparison with twice as many steps passed (or the largest tried).
    converged : bool
        False if the count at ``MAX_STEPS_PER_MESH`` / 2 still failed.
    checks : list of dict
        One entry per comparison: ``steps`` and ``finer`` counts, the worst ratio (difference RMS over
        noise), its channel, and the ratio of every compared channel.
    """

    steps_per_mesh: int
    converged: bool
    checks: list[dict[str, Any]] = field(default_factory=list)
    #: the count the record names (:func:`recorded_steps`) rather than the convergence rule's
    from_record: bool = False

    def as_dict(self) -> dict[str, Any]:
        out = {
            "steps_per_mesh": int(self.steps_per_mesh),
            "converged": bool(self.converged),
            "fraction_of_noise": STEP_NOISE_FRACTION,
            "checks": self.checks,
        }
        if self.from_record:
            out["source"] = "the record's own (the simulator that made it)"
        return out


def recorded_steps(measurement: Any) -> int | None:
    """Steps per mesh period the record was simulated with, where it names them
    (``Measurement.recorded_steps_per_mesh``: a ``gear-rotor-sim record`` MCAP); None otherwise."""
    n = getattr(measurement, "recorded_steps_per_mesh", None)
    return int(n) if n else None


def robust_noise(x: np.ndarray) -> float:
    """Standard deviation of Gaussian noise from the median absolute deviation (1.4826 MAD)."""
    x = np.asarray(x, dtype=float)
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def step_difference_ratios(
    coarse: np.ndarray,
    fine: np.ndarray,
    noise: Sequence[float],
    channels: Sequence[int],
    fs: float,
    shafts_hz: Sequence[float],
) -> dict[int, float]:
    """Per channel: RMS of the difference between the non-synchronous parts of two model runs (same
    samples, different steps) over the channel's noise. Channels with no measured noise are skipped."""
    out: dict[int, float] = {}
    for c in channels:
        if not noise[c] > 0:
            continue
        a = remove_synchronous(coarse[:, c], fs, shafts_hz)
        b = remove_synchronous(fine[:, c], fs, shafts_hz)
        out[int(c)] = float(np.std(a - b)) / float(noise[c])
    return out


def converged_steps_per_mesh(
    run: Callable[[int], np.ndarray],
    measured: np.ndarray,
    channels: Sequence[int],
    names: Sequence[str],
    fs: float,
    shafts_hz: Sequence[float],
    start: int = 32,
    fraction: float = STEP_NOISE_FRACTION,
    max_steps: int = MAX_STEPS_PER_MESH,
) -> StepChoice:
    """The coarsest step count from ``start`` (doubling) whose healthy model agrees with the model at
    twice the count (module docstring).

    Parameters
    ----------
    run : callable
        ``run(n) -> (samples, channels)`` healthy model outputs at ``n`` steps per mesh period, the
        same samples for every ``n``.
    measured : ndarray
        The record (samples, channels), for the noise of each channel.
    channels : sequence of int
        Channels compared (the envelope family's inputs).
    names : sequence of str
        Channel names (reported).
    fs : float
        Sample rate, Hz.
    shafts_hz : sequence of float
        Shaft rotation frequencies whose synchronous parts are removed.
    start, fraction, max_steps
        First count, tolerance as a fraction of the noise, finest count.
    """
    if start < 1 or max_steps < start:
        raise ValueError(f"steps per mesh: start {start} must be in [1, max_steps = {max_steps}]")
    if not fraction > 0:
        raise ValueError(f"fraction of the noise must be > 0, got {fraction}")
    noise = [
        robust_noise(remove_synchronous(measured[:, c], fs, shafts_hz)) if c in channels else 0.0
        for c in range(measured.shape[1])
    ]
    checks: list[dict[str, Any]] = []
    n = int(start)
    coarse = run(n)
    while 2 * n <= max_steps:
        fine = run(2 * n)
        ratios = step_difference_ratios(coarse, fine, noise, channels, fs, shafts_hz)
        worst = max(ratios, key=lambda c: ratios[c]) if ratios else None
        w = ratios[worst] if worst is not None else 0.0
        checks.append(
            {
                "steps": n,
                "finer": 2 * n,
                "worst_ratio": w,
                "worst_channel": names[worst] if worst is not None else None,
                "ratios": {names[c]: r for c, r in ratios.items()},
            }
        )
        if w <= fraction:
            return StepChoice(n, True, checks)
        n, coarse = 2 * n, fine
    return StepChoice(n, False, checks)
