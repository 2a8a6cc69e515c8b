"""Simulator + monitor (+ MCAP recording) for installations that have ROS 2 launch (launch_ros).

    ros2 launch gear_rotor_sim gear_rotor_sim.launch.py
    ros2 launch gear_rotor_sim gear_rotor_sim.launch.py record:=true record_path:=/tmp/run.mcap \
        real_time_factor:=1.0 speed_rpm:=3000.0 temperature_c:=25.0

Recording is done by the simulator node itself (parameter ``recording.enabled``), with the same
MCAP writer as the offline ``gear-rotor-sim record``; no ``ros2 bag`` process is needed.
"""

from __future__ import annotations

import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

from launch import LaunchDescription


def generate_launch_description() -> LaunchDescription:
    """Simulator with config/simulator_node.yaml, monitor with config/monitor_node.yaml."""
    share = get_package_share_directory("gear_rotor_sim")
    sim_params = os.path.join(share, "config", "simulator_node.yaml")
    mon_params = os.path.join(share, "config", "monitor_node.yaml")
    args = [
        DeclareLaunchArgument("record", default_value="false", description="record an MCAP file"),
        DeclareLaunchArgument("record_path", default_value="gear_rotor_sim.mcap", description="MCAP path"),
        DeclareLaunchArgument("real_time_factor", default_value="1.0", description="requested RTF"),
        DeclareLaunchArgument("speed_rpm", default_value="3000.0", description="initial speed, rpm"),
        DeclareLaunchArgument("temperature_c", default_value="25.0", description="initial temperature, C"),
        DeclareLaunchArgument(
            "monitor_topic", default_value="/gear_rotor/dte", description="monitored stream"
        ),
    ]
    simulator = Node(
        package="gear_rotor_sim",
        executable="simulator",
        name="gear_rotor_simulator",
        output="screen",
        emulate_tty=True,
        parameters=[
            sim_params,
            {
                "recording.enabled": ParameterValue(LaunchConfiguration("record"), value_type=bool),
                "recording.path": LaunchConfiguration("record_path"),
                "real_time_factor": ParameterValue(LaunchConfiguration("real_time_factor"), value_type=float),
                "speed_rpm": ParameterValue(LaunchConfiguration("speed_rpm"), value_type=float),
                "temperature_c": ParameterValue(LaunchConfiguration("temperature_c"), value_type=float),
            },
        ],
        # SIGINT on Ctrl-C; the node finalises the recording before it exits
        sigterm_timeout="10",
    )
    monitor = Node(
        package="gear_rotor_sim",
        executable="monitor",
        name="gear_rotor_monitor",
        output="screen",
        emulate_tty=True,
        parameters=[mon_params, {"topic": LaunchConfiguration("monitor_topic")}],
    )
    return LaunchDescription([*args, simulator, monitor])
