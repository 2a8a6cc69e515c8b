"""The physics core imports and runs with ROS unavailable (issue 2: no rclpy needed)."""

from __future__ import annotations

import json
import subprocess
import sys

SCRIPT = r"""
import json, sys
for name in ("rclpy", "gear_rotor_msgs", "std_msgs", "rosidl_runtime_py", "ament_index_python"):
    sys.modules[name] = None  # any import of these now raises ImportError
from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.system import GearRotorSystem
from gear_rotor_sim import validation  # the validate command's module
system = GearRotorSystem.from_config(paper_gearbox(), 125.0)
sim = Simulator(paper_gearbox(), speed_rpm=3000.0, temperature_c=125.0, output_rate_hz=10000.0)
block = sim.advance(0.02)
loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("rclpy", "gear_rotor_msgs") and sys.modules[m])
print(json.dumps({"ndof": system.ndof, "samples": block.n_samples, "ros_modules": loaded}))
"""


def test_physics_runs_without_ros() -> None:
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    res = json.loads(out.stdout.strip().splitlines()[-1])
    assert res["ndof"] == 108
    assert res["samples"] == 200  # 0.02 s at 10 kHz
    assert res["ros_modules"] == []
