"""gear_rotor_sim: digital twin of a gear-rotor-bearing system with steady-state temperature effects.

The physics core (materials, elements, system, solver, simulator) imports no ROS. ROS 2 code lives in
``gear_rotor_sim.ros`` only.
"""

__version__ = "0.1.0"
