"""The gear kernel's transmission-error sin/cos by rotation (``gear_kernel._te_sin_cos``) against
NumPy's sin/cos of the same argument, at round-off."""

from __future__ import annotations

import numpy as np

from gear_rotor_sim.solver.gear_kernel import TE_ANCHOR_STEPS, _te_sin_cos


def test_rotated_sin_cos_equal_direct_evaluation() -> None:
    rng = np.random.default_rng(3)
    n = 5 * TE_ANCHOR_STEPS + 17
    # two meshes: a speed ramp (phase steps 0.002..0.04 of a cycle, wrapping at 1) and one with a
    # few steps larger than 0.25 rad (taken directly)
    steps = np.stack([np.linspace(0.002, 0.04, n), rng.uniform(0.0, 0.06, n)], axis=1)
    steps[::37, 1] = 0.3
    cyc = np.cumsum(steps, axis=0) + np.array([0.9, 0.1])
    phase = np.ascontiguousarray(cyc - np.floor(cyc))
    mesh_par = np.zeros((2, 6))
    mesh_par[:, 5] = (0.3, -1.2)
    out = np.empty((n, 4))
    _te_sin_cos(phase, mesh_par, out)
    arg = 2.0 * np.pi * phase + mesh_par[:, 5]
    assert np.abs(out[:, :2] - np.sin(arg)).max() < 1e-13  # |sin| <= 1: an absolute bound is relative
    assert np.abs(out[:, 2:] - np.cos(arg)).max() < 1e-13
