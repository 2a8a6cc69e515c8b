"""Sensor models between the simulated machine and what a monitoring system measures.

``housing``: accelerometers on the bearing housings (single-DOF housing mode driven by the bearing
force); ``noise``: the accelerometer's broadband noise.
"""

from gear_rotor_sim.sensors.housing import HousingAccelerometers, HousingSensor, housing_channels
from gear_rotor_sim.sensors.noise import SensorNoise

__all__ = ["HousingAccelerometers", "HousingSensor", "SensorNoise", "housing_channels"]
