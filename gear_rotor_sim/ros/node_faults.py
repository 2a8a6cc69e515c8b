"""Faults on demand in the simulator node: the ``~/set_faults`` service and the ground-truth topic.

* Faults at start-up from the ``faults_file`` parameter (a YAML fault list, docs/faults.md).
* At run time: service ``~/set_faults`` (``gear_rotor_msgs/srv/SetFaults``) with the same YAML
  text; the list *replaces* the faults in force (``""`` clears them). A bad request is refused with
  the field named (``success: false``) and nothing changes; the stream never stops.
* Ground truth: ``/gear_rotor/faults`` (``gear_rotor_msgs/msg/FaultState``), reliable, transient
  local, keep last 1 (a late subscriber gets the state in force), published when the list changes,
  at the onset of a fault and while a fault grows (once per chunk); the node's recording stores it.

``onset_s`` is simulated time on the stream's clock; a fault whose onset has passed applies from the
next chunk. The stepping thread hands the new list to the simulator between two chunks
(``Simulator.set_effects``), as it does with setpoints.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import Any

from gear_rotor_msgs.msg import Fault, FaultState
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from gear_rotor_sim.faults.spec import FaultError, FaultSpec, load_faults
from gear_rotor_sim.faults.timed import timed_effects
from gear_rotor_sim.faults.truth import fault_state_fields, truth

FAULTS_TOPIC = "/gear_rotor/faults"
#: Latched: reliable, transient local, keep last 1.
FAULTS_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)


def fault_state_msg(fields: dict[str, Any]) -> FaultState:
    """``FaultState`` from :func:`gear_rotor_sim.faults.truth.fault_state_fields`."""
    msg = FaultState()
    msg.header.stamp.sec = int(fields["stamp_sec"])
    msg.header.stamp.nanosec = int(fields["stamp_nanosec"])
    msg.header.frame_id = fields["frame_id"]
    msg.faults = [Fault(**f) for f in fields["faults"]]
    return msg


def summary(faults: Sequence[FaultSpec]) -> str:
    if not faults:
        return "no faults in force"
    return "faults in force: " + ", ".join(
        f"{f.effect().label} {f.severity_name}={f.initial_severity:g} from {f.onset_s:g} s" for f in faults
    )


class NodeFaults:
    """The node's fault list: requests (executor thread), application (stepping thread), truth.

    Parameters
    ----------
    cfg : RigConfig
        The node's rig (locations are checked against it).
    initial : sequence of FaultSpec
        Faults from the ``faults_file`` parameter.
    """

    def __init__(self, cfg: Any, initial: Sequence[FaultSpec] = ()) -> None:
        self.cfg = cfg
        self.faults: tuple[FaultSpec, ...] = tuple(initial)
        self._pending: tuple[FaultSpec, ...] | None = None
        self._lock = threading.Lock()
        self._last_truth: list | None = None
        self._last_generation = -1
        #: Counts the lists handed to the simulator; a block carries the list and count it was
        #: integrated with (the output thread publishes the truth of that block, not the newest list).
        self.generation = 0
        self.accepted = 0
        self.refused = 0

    def effects(self) -> tuple:
        return timed_effects(self.faults)

    def request(self, text: str) -> tuple[bool, str]:
        """Validate a YAML fault list; on success it replaces the list at the next chunk."""
        try:
            faults = load_faults(text if text.strip() else "[]", self.cfg)
        except FaultError as exc:
            with self._lock:
                self.refused += 1
            return False, f"refused, faults unchanged: {exc}"
        with self._lock:
            self._pending = faults
            self.accepted += 1
        return True, summary(faults)

    def apply_pending(self, sim: Any) -> bool:
        """Hand a pending list to the simulator (stepping thread); True if it changed."""
        with self._lock:
            pending, self._pending = self._pending, None
        if pending is None:
            return False
        sim.set_effects(timed_effects(pending))
        self.faults = pending
        self.generation += 1  # publish the new state
        return True

    def state_if_changed(
        self, t: float, faults: Sequence[FaultSpec] | None = None, generation: int | None = None
    ) -> dict[str, Any] | None:
        """``FaultState`` fields at ``t`` when the truth differs from the last published one, or the
        list was replaced since. ``faults``, ``generation``: the list (and :attr:`generation`) in
        force for the block that starts at ``t`` (default: the current ones); the simulator node's
        stepping thread runs up to two blocks ahead of the thread that publishes the truth."""
        faults = self.faults if faults is None else tuple(faults)
        generation = self.generation if generation is None else generation
        now = truth(faults, t)
        if now == self._last_truth and generation == self._last_generation:
            return None
        self._last_truth = now
        self._last_generation = generation
        return fault_state_fields(faults, t)
