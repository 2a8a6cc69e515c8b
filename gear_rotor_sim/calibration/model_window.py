"""How much of the model to simulate per candidate evaluation: whole hunting periods of the mesh.

Every feature of the calibration (``residual.py``) is an average over the record: order coefficients
of the time-synchronous average of each shaft, Welch-averaged envelope spectra, channel means. For a
single-mesh gearbox at constant speed the model's response to any library effect (a damaged tooth on
either wheel, eccentricity, unbalance, wear, ...) is periodic in the *hunting period*

    T_h = lcm(z_p, z_g) / f_mesh,

the time after which the same pinion tooth meets the same gear tooth again (29/49 teeth: 29 gear
and 49 pinion revolutions; 0.3675 s at 8000 rpm, 0.98 s at 3000 rpm). Over a whole number of hunting
periods every shaft turns a whole number of revolutions, so the synchronous average of one shaft
cancels the other shaft's orders *exactly*, and the mean and the averaged envelope spectrum are the
averages over one full cycle. Simulating more than that adds nothing but the same cycle again (plus
the leakage of a partial cycle at the record's end); simulating less biases the averages.

Measured (``docs/independent_data.md``, "Calibration cost"): at 8000 rpm, where the teeth separate
35-38 % of the time, the FE model's features over each of three consecutive hunting periods agree
with those over the full 2 s record to a mean squared difference of 0.02-0.04 of the measured
feature variance (largest single order 1.1 variances, static means <= 1.5 sigma: the full record's
partial last cycle), healthy and with a damaged pinion tooth: the rattling response is periodic in
the hunting period. So the calibration simulates ``k T_h`` (``k`` the smallest integer with
``k T_h >= min_window_s``) instead of the record length, and the measured channel means are taken
over whole hunting periods as well.

Rigs with several meshes or without a mesh (the CWRU bearing rig) and records shorter than the window
keep the full record.
"""

from __future__ import annotations

import math
from typing import Any

#: Shortest model window (s): at least a few envelope segments (0.1 s each, half overlapping) and a
#: few revolutions of the slowest shaft.
MIN_WINDOW_S = 0.3


def hunting_period_s(cfg: Any, speed_rpm: float) -> float | None:
    """Hunting period ``lcm(z_p, z_g) / f_mesh`` (s) of a single-mesh rig at ``speed_rpm`` (input
    shaft); None for rigs with no mesh or several meshes."""
    meshes = getattr(cfg, "meshes", ())
    if len(meshes) != 1 or not speed_rpm > 0:
        return None
    m = meshes[0]
    zp, zg = int(m.pinion_teeth), int(m.gear_teeth)
    if zp <= 0 or zg <= 0:
        return None
    from gear_rotor_sim.system import shaft_speed_ratios

    ratios = [abs(float(r)) for r in shaft_speed_ratios(cfg)]
    pin_shaft = cfg.shaft_of_node(cfg.gear(m.pinion).node0)
    f_mesh = zp * ratios[pin_shaft] * speed_rpm / 60.0
    return math.lcm(zp, zg) / f_mesh


def model_window_samples(
    cfg: Any, speed_rpm: float, sample_rate_hz: float, n_samples: int, min_window_s: float = MIN_WINDOW_S
) -> int:
    """Samples of the model to simulate: ``k`` whole hunting periods (``k T_h >= min_window_s``) plus a
    quarter revolution of the slowest shaft (so that the last whole revolution of every shaft is
    inside the window), at most ``n_samples`` (the record)."""
    th = hunting_period_s(cfg, speed_rpm)
    if th is None:
        return int(n_samples)
    from gear_rotor_sim.system import shaft_rates_hz

    f_slow = min(shaft_rates_hz(cfg, speed_rpm))
    k = max(1, math.ceil(min_window_s / th - 1e-9))
    n = math.ceil((k * th + 0.25 / f_slow) * sample_rate_hz)
    return int(min(n, n_samples))


def whole_periods_samples(cfg: Any, speed_rpm: float, sample_rate_hz: float, n_samples: int) -> int:
    """Samples of the largest whole number of hunting periods within ``n_samples`` (all of them if the
    record is shorter than one period or the rig has no single mesh)."""
    th = hunting_period_s(cfg, speed_rpm)
    if th is None:
        return int(n_samples)
    k = math.floor(n_samples / (th * sample_rate_hz))
    return round(k * th * sample_rate_hz) if k >= 1 else int(n_samples)
