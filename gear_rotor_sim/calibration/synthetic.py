"""Synthetic measurements made by the package's own simulator for the calibration's self-test (moved
from ``fit.py`` in session 16, unchanged).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.residual import (
    add_direct_bearing_forces,
)
from gear_rotor_sim.faults import (
    Effect,
)


def synthetic_measurement(
    cfg: Any,
    effects: Sequence[Effect],
    speed_rpm: float,
    temperature_c: float,
    channels: Sequence[str],
    path: str | Any,
    gearbox: str,
    *,
    duration_s: float = 0.3,
    warmup_s: float = 0.15,
    sample_rate_hz: float = 20000.0,
    noise_rms: float = 0.03,
    gain_error: float = 0.03,
    damping_scale: float = 1.2,
    seed: int = 0,
    output_torque_nm: float | None = None,
    steps_per_mesh: int = 32,
) -> Any:
    """Data made by our simulator for the self-test, written as CSV + sidecar (the measurement contract).

    The declared operating point and gearbox are the healthy ones; ``effects`` are injected but not
    declared. Nuisances: the mesh damping ratio times ``damping_scale`` (model mismatch), per-channel
    sensor gains ``1 +- gain_error`` (random sign), white noise of ``noise_rms`` times each channel's
    RMS (about its mean).

    Returns
    -------
    Path
        The CSV file (its ``.yaml`` sidecar next to it).
    """
    from pathlib import Path

    from gear_rotor_sim.blocks import SampleBlock
    from gear_rotor_sim.calibration.measurement import OperatingPoint, write_csv
    from gear_rotor_sim.simulator import Simulator

    data_cfg = cfg.replace(
        meshes=tuple(
            dataclasses.replace(m, damping_ratio=m.damping_ratio * damping_scale) for m in cfg.meshes
        )
    )
    speed, temp = speed_rpm, temperature_c
    for e in effects:
        speed, temp = e.operating_point(speed, temp)
    if output_torque_nm is not None and data_cfg.load is not None:
        data_cfg = data_cfg.replace(load=dataclasses.replace(data_cfg.load, torque_nm=output_torque_nm))
    sim = Simulator(
        data_cfg,
        speed,
        temp,
        sample_rate_hz,
        list(channels),
        steps_per_mesh,
        effects=tuple(effects),
        event_average=False,  # the self-test's records as its tables were measured
        streamed_misalignment=False,  # as the calibration's model runs (residual.ModelRunner)
    )
    i0 = round(warmup_s * sample_rate_hz)
    n = round(duration_s * sample_rate_hz)
    block = sim.advance((i0 + n + 0.5) / sample_rate_hz)
    data = block.data[i0 : i0 + n].copy()
    add_direct_bearing_forces(data, list(channels), effects, data_cfg, temp, speed, sample_rate_hz, i0)
    rng = np.random.default_rng(seed)
    gains = 1.0 + gain_error * rng.choice([-1.0, 1.0], size=data.shape[1])
    data = data * gains + noise_rms * data.std(axis=0) * rng.standard_normal(data.shape)
    out = SampleBlock(i0 / sample_rate_hz, sample_rate_hz, tuple(channels), block.units, data)
    op = OperatingPoint(speed_rpm, temperature_c, output_torque_nm)
    return write_csv(Path(path), out, op, gearbox)
