"""lumped_gearbox: an independent lumped-parameter simulator of the Sun et al. (2021) gearbox.

It shares no code with ``gear_rotor_sim`` (a test checks the import graph) and exists to make test
records that the finite-element model did not make (issue 11, docs/independent_data.md).
"""

from lumped_gearbox.faults import FAULT_NAMES, make_fault, parse_fault
from lumped_gearbox.params import Gearbox, springs, thermal_axial_load, thermal_half_backlash
from lumped_gearbox.record import CONTACT_RPM, RATTLE_RPM, Record, make_record, write_record
from lumped_gearbox.simulate import CHANNELS, build, run

__all__ = [
    "CHANNELS",
    "CONTACT_RPM",
    "FAULT_NAMES",
    "RATTLE_RPM",
    "Gearbox",
    "Record",
    "build",
    "make_fault",
    "make_record",
    "parse_fault",
    "run",
    "springs",
    "thermal_axial_load",
    "thermal_half_backlash",
    "write_record",
]
