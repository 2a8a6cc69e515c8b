"""MCAP recording of the simulator's streams (rosbag2 conventions), recovery and datasets.

Importing this package needs no ROS installation: messages are serialised to CDR by
:mod:`.cdr` and described by :mod:`.schemas`.
"""

from gear_rotor_sim.recording.recover import RecoveryReport, recover
from gear_rotor_sim.recording.writer import McapRecorder, RecordingError, qos_profile

__all__ = ["McapRecorder", "RecordingError", "RecoveryReport", "qos_profile", "recover"]
