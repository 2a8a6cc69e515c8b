"""Model accelerations as the time derivative of the simulated velocities.

The FE mesh stiffness is piecewise smooth: it jumps where a tooth pair enters or leaves contact
(``docs/mesh_stiffness.md``), so the mesh force, and with it every acceleration ``M^-1 (F - K x - C v)``,
jumps there too. The simulator forms its output channels at the integration step instants and
decimates them with an anti-aliasing FIR (``docs/solver.md``, "dt rule and decimation"); a jump
between two step instants is then placed at the next one, an error of up to one step in its time.
With about 41-69 steps per mesh period (the dt rule in contact at 3000 rpm) the pattern of these
errors repeats once per pinion revolution (1200 or 2000 steps per revolution against 29 teeth), so it
puts numerical lines at every pinion order between the mesh harmonics: measured on the paper gearbox
at 3000 rpm, 25 C, the RMS over the non-carrier pinion orders 1-99 of ``node5_ay`` is 7.3 m/s^2 at
32 steps per mesh period, 5.9 with the mesh events located, 0.22 m/s^2 at 1024 steps (the
error falls as the step, i.e. it is numerical); the independent record's noise on those orders is
0.07 m/s^2. Displacements, velocities and forces through springs are continuous at the jumps and
their located samples converge at the integration's order (``bearing2_fx``: 1.35 N at 32 steps,
0.07 N located).

So the calibration simulates the velocity ``node<k>_v<d>`` (continuous; its located samples are
accurate) and differentiates the decimated velocity with a Kaiser-windowed ideal differentiator
(``h_k = (-1)^k / (k dt)``, 129 taps, beta 10: relative error of the frequency response below
2.2e-4 from 0 to 0.45 of the output rate, i.e. over the decimator's passband, 0.4 of it). Measured
against 2048 steps per mesh period (direct accelerations), on the non-carrier orders 1-99 at
3000 rpm: 0.09 / 0.27 m/s^2 (``node5_ax`` / ``node5_ay``, 64 steps located) against 1.45 / 3.47 for
the direct accelerations at the same step.
"""

from __future__ import annotations

import re

import numpy as np

_ACCEL_RE = re.compile(r"^node(\d+)_a(x|y|z|theta_x|theta_y|theta_z)$")

#: half length of the differentiator (samples): the simulated window is extended by this at each end
MARGIN = 64
#: Kaiser window parameter of the differentiator
BETA = 10.0


def velocity_of(channel: str) -> str | None:
    """The velocity channel whose derivative is ``channel`` (``node5_ax`` -> ``node5_vx``), or None."""
    m = _ACCEL_RE.match(channel)
    return f"node{m.group(1)}_v{m.group(2)}" if m else None


def differentiator(sample_rate_hz: float) -> np.ndarray:
    """Taps (2 MARGIN + 1) of the band-limited differentiator at ``sample_rate_hz`` (per second)."""
    k = np.arange(-MARGIN, MARGIN + 1)
    h = np.zeros(k.size)
    nz = k != 0
    h[nz] = np.cos(np.pi * k[nz]) / k[nz]
    return h * np.kaiser(k.size, BETA) * float(sample_rate_hz)


def differentiate(v: np.ndarray, sample_rate_hz: float) -> np.ndarray:
    """Time derivative of the band-limited signal ``v`` (n,); the first and last ``MARGIN`` samples of
    the result lack history and are to be discarded (the window is simulated that much longer)."""
    return np.convolve(np.asarray(v, dtype=float), differentiator(sample_rate_hz), mode="same")
