"""Validation of runtime setpoints (speed, temperature), shared by the ROS node and the live server.

Pure Python (no ROS): :func:`check_setpoint` is what the simulator node applies to
``/gear_rotor/setpoint/*`` messages and what ``gear-rotor-sim serve`` applies to the same topics
published by a Foxglove client, so both refuse exactly the same values with the same reason.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

#: Setpoint kinds, i.e. the user-facing names of the two controlled quantities.
SETPOINT_KINDS: tuple[str, ...] = ("speed_rpm", "temperature_c")

#: Default limits (the node's ``limits.*`` parameters): the material table of the paper's model
#: covers 25..325 C; speeds above 30000 rpm are refused.
DEFAULT_LIMITS: dict[str, float] = {
    "limits.speed_rpm_max": 30000.0,
    "limits.temperature_c_min": 25.0,
    "limits.temperature_c_max": 325.0,
}


def check_setpoint(kind: str, value: float, values: Mapping[str, Any]) -> str | None:
    """Why a speed or temperature setpoint is refused, or None when it is valid.

    Parameters
    ----------
    kind : {"speed_rpm", "temperature_c"}
        The controlled quantity.
    value : float
        The requested target (rpm or C).
    values : mapping
        Holds the limits ``limits.speed_rpm_max``, ``limits.temperature_c_min`` and
        ``limits.temperature_c_max`` (the node's parameters, or :data:`DEFAULT_LIMITS`).

    Returns
    -------
    str or None
        A one-line reason naming the setpoint, the value and the allowed range; None if accepted.
    """
    if kind not in SETPOINT_KINDS:
        return f"setpoint kind {kind!r} is not one of {list(SETPOINT_KINDS)}"
    if not math.isfinite(value):
        return f"{kind} setpoint {value} is not finite"
    if kind == "speed_rpm":
        hi = float(values["limits.speed_rpm_max"])
        if value < 0.0:
            return f"speed_rpm setpoint {value} is negative"
        if value > hi:
            return f"speed_rpm setpoint {value} is above limits.speed_rpm_max = {hi}"
        return None
    lo = float(values["limits.temperature_c_min"])
    hi = float(values["limits.temperature_c_max"])
    if not lo <= value <= hi:
        return f"temperature_c setpoint {value} is outside [{lo}, {hi}] (limits.temperature_c_min/max)"
    return None
