"""Test-session isolation from other ROS 2 traffic on the host.

The node tests publish and subscribe on the project's real topic names. Two test runs on one
machine (or a test run next to a running ``simulator_node``) would otherwise discover each other
over DDS and mix their messages: a test that compares a stream with the simulator then reads the
other run's samples. Unless the caller chose a domain, each test session gets its own
``ROS_DOMAIN_ID`` (derived from its process id; 1-100, all valid with the default port mapping)
and discovery is kept to this host. Set before any test module imports rclpy; child processes
(``ros2 run``, ``ros2 bag``) inherit it.
"""

from __future__ import annotations

import os

if "ROS_DOMAIN_ID" not in os.environ:
    os.environ["ROS_DOMAIN_ID"] = str(1 + os.getpid() % 100)
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
