"""Localised rolling-bearing defects of bearing 2 as force pulses between race and housing.

Kinematics of a deep-groove ball bearing with the inner ring on the shaft and the outer ring in the
housing (own derivation from rolling without slip): with ``r = d cos(alpha) / D`` the cage turns at
``w_c = w (1 - r) / 2``; a point of the outer race is passed by ``n`` balls per cage turn
(``n w_c``), a point of the inner race by ``n (w - w_c)``, and a ball spins at
``w (D / 2d) (1 - r^2)`` relative to the cage, striking a race each half of its spin turn.

A ball crossing a spall of width ``w_s`` unloads and strikes the far edge: one half-sine pulse of
the transit time ``w_s / v`` (``v`` the rolling speed of the contact over the defective surface),
peak ``force_n * q``, where ``q = max(cos psi, 0)^1.5`` is the Hertz ball-load factor at the angle
``psi`` of the impact from the load direction (zero internal clearance). The pulse pushes the housing
radially outward at the impact position. Pulses are averaged over each sample interval (10 points),
so a pulse shorter than a sample keeps its impulse. Intervals between impacts scatter by 1 % (random
slip, Antoni & Randall 2002).
"""

from __future__ import annotations

import math

import numpy as np

from lumped_gearbox.speed_profile import relative_speed, time_at

# SKF 6206 (30 mm bore): 9 balls of 9.525 mm on a 46 mm pitch circle (catalogue values)
N_BALLS = 9
BALL_D = 9.525e-3
PITCH_D = 46.0e-3
SPALL_WIDTH = 0.4e-3
SLIP = 0.01


def kinematics(speed_rpm: float) -> dict[str, float]:
    """Impact rates (Hz) and contact rolling speeds (m/s) of each defect kind."""
    w = speed_rpm * 2.0 * math.pi / 60.0
    r = BALL_D / PITCH_D
    wc = 0.5 * w * (1.0 - r)
    spin = w * PITCH_D / (2.0 * BALL_D) * (1.0 - r * r)
    return {
        "outer_rate": N_BALLS * wc / (2 * math.pi),
        "inner_rate": N_BALLS * (w - wc) / (2 * math.pi),
        "ball_rate": 2.0 * spin / (2 * math.pi),
        "outer_speed": wc * 0.5 * (PITCH_D + BALL_D),
        "inner_speed": (w - wc) * 0.5 * (PITCH_D - BALL_D),
        "ball_speed": spin * 0.5 * BALL_D,
        "cage": wc,
        "shaft": w,
    }


def defect_forces(
    kind: str,
    force_n: float,
    defect_angle_rad: float,
    speed_rpm: float,
    t: np.ndarray,
    load_angle_rad: float,
    seed: int = 0,
    profile: np.ndarray | None = None,
) -> np.ndarray:
    """Force on the housing of bearing 2, ``(len(t), 2)`` (x, y), N, for one defect.

    With a varying input speed (``profile``, ``speed_profile.py``) the impacts fall at the same
    increments of the true shaft angle: each impact's constant-speed time is mapped to the time the
    varying shaft reaches that angle, and its pulse is shortened in proportion to the speed there.
    """
    kin = kinematics(speed_rpm)
    rate = kin[f"{kind}_rate"]
    tau = SPALL_WIDTH / kin[f"{kind}_speed"]
    fs = 1.0 / float(t[1] - t[0])
    rng = np.random.default_rng(seed)
    varying = profile is not None and profile[0] != 0.0
    # a varying speed reaches the record's end at up to 1.25 x the nominal angle (speed_profile.py's ranges)
    n_imp = math.ceil((t[-1] + 1.0 / fs) * rate * (1.25 if varying else 1.0)) + 2
    gaps = (1.0 + SLIP * rng.standard_normal(n_imp)) / rate
    times = np.cumsum(gaps) - gaps[0] * 0.5
    if not varying:
        times = times[times < t[-1] + 1.0 / fs]
    if kind == "outer":
        angles = np.full(times.size, defect_angle_rad)
    elif kind == "inner":
        angles = kin["shaft"] * times + defect_angle_rad
    else:
        angles = kin["cage"] * times + defect_angle_rad
    widths = np.full(times.size, tau)
    if varying:
        # the constant-speed time of each impact is its shaft angle over w0: the true time reaches it
        times = time_at(profile, times)
        widths = tau / relative_speed(profile, times)
        keep = times < t[-1] + 1.0 / fs
        times, angles, widths = times[keep], angles[keep], widths[keep]
    q = np.maximum(np.cos(angles - load_angle_rad), 0.0) ** 1.5
    out = np.zeros((t.size, 2))
    sub = (np.arange(10) + 0.5) / 10.0 / fs  # 10 points per sample interval
    for tk, ak, qk, wk in zip(times, angles, q, widths, strict=True):
        if qk <= 0.0:
            continue
        i0 = max(0, math.floor((tk - t[0]) * fs) - 1)  # t need not start at 0 (daq.py starts before it)
        i1 = min(t.size, math.ceil((tk + wk - t[0]) * fs) + 1)
        if i0 >= i1:
            continue
        ts = t[i0:i1, None] - 0.5 / fs + sub[None, :] - tk
        pulse = np.where((ts >= 0) & (ts <= wk), np.sin(math.pi * ts / wk), 0.0).mean(axis=1)
        f = force_n * qk * pulse
        out[i0:i1, 0] += f * math.cos(ak)
        out[i0:i1, 1] += f * math.sin(ak)
    return out
