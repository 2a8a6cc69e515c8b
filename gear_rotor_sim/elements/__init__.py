"""Finite elements of the gear-rotor-bearing model (Sec 3): shaft, rigid disc, bearing, gear mesh."""

from gear_rotor_sim.elements.bearing import BEARING_TYPES, Bearing, BearingProperties
from gear_rotor_sim.elements.disc import GearDisc
from gear_rotor_sim.elements.shaft import ShaftElement, cowper_shear_coefficient

__all__ = [
    "BEARING_TYPES",
    "Bearing",
    "BearingProperties",
    "GearDisc",
    "ShaftElement",
    "cowper_shear_coefficient",
]
