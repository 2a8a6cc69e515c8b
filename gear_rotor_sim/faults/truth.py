"""Ground truth of injected faults: what the node publishes on ``/gear_rotor/faults`` and what the
recordings and the dataset manifest store.

One record per fault: the request as given (``spec``: the flat YAML entry) plus its state at a time
``t``: ``active`` (``t >= onset_s``), ``severity_name`` and ``severity`` (current value),
``final_severity`` and the effect's ``label`` (``tooth_damage@gear``, ``outer_race_defect@bearing2``).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from gear_rotor_sim.faults.spec import FaultSpec, parse_faults


def fault_truth(spec: FaultSpec, t: float) -> dict[str, Any]:
    """Ground-truth record of one fault at simulated time ``t`` (s)."""
    sev = float(spec.severity_at(t))
    return {
        "type": spec.type,
        "label": spec.effect().label,
        "location": dict(spec.location),
        "parameters": dict(spec.parameters),
        "onset_s": spec.onset_s,
        "growth": None if spec.growth is None else spec.growth.as_dict(),
        "severity_name": spec.severity_name,
        "severity": sev,
        "final_severity": spec.final_severity,
        "active": bool(t >= spec.onset_s),
        "spec": spec.as_dict(),
    }


def truth(faults: Sequence[FaultSpec], t: float) -> list[dict[str, Any]]:
    """Ground truth of a fault list at ``t``."""
    return [fault_truth(f, t) for f in faults]


def truth_json(faults: Sequence[FaultSpec]) -> str:
    """The fault list as JSON (its flat entries): the metadata record and the manifest store this."""
    return json.dumps([f.as_dict() for f in faults], sort_keys=True)


def faults_from_json(text: str) -> tuple[FaultSpec, ...]:
    """Inverse of :func:`truth_json`."""
    return parse_faults(json.loads(text) if text else [])


def fault_fields(record: dict[str, Any]) -> dict[str, Any]:
    """``gear_rotor_msgs/msg/Fault`` fields of a truth record (:func:`fault_truth`)."""
    loc = record["location"]
    return {
        "type": record["type"],
        "label": record["label"],
        "wheel": str(loc.get("wheel", "")),
        "tooth": int(loc.get("tooth", 0)),
        "mesh": int(loc.get("mesh", 0)),
        "bearing": int(loc.get("bearing", 0)),
        "node": int(loc.get("node", 0)),
        "onset_s": float(record["onset_s"]),
        "severity_name": record["severity_name"],
        "severity": float(record["severity"]),
        "final_severity": float(record["final_severity"]),
        "active": bool(record["active"]),
        "spec_json": json.dumps(record["spec"], sort_keys=True),
    }


def fault_state_fields(faults: Sequence[FaultSpec], t: float, frame_id: str = "gearbox") -> dict[str, Any]:
    """``gear_rotor_msgs/msg/FaultState`` fields at simulated time ``t`` (s)."""
    ns = max(0, round(t * 1e9))
    return {
        "stamp_sec": ns // 1_000_000_000,
        "stamp_nanosec": ns % 1_000_000_000,
        "frame_id": frame_id,
        "faults": [fault_fields(r) for r in truth(faults, t)],
    }
