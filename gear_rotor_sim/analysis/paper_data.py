"""The paper's numbers that the reproduction compares with (Sun, Chen, Hu, Lei 2021, Section 4)."""

from __future__ import annotations

from gear_rotor_sim.analysis.bifurcation import Case

#: Fig 7 text: (temperature C, speed rpm, RMS total force of bearing 2, N), bearings A#.
PAPER_FIG7 = (
    (25.0, 1000.0, 1088.0),
    (125.0, 1000.0, 1855.0),
    (225.0, 1000.0, 3434.0),
    (125.0, 14400.0, 3785.0),
    (225.0, 14400.0, 3498.0),
)
#: Fig 8 text at 19000 rpm: (bearing type, temperature C, node, displacement amplitude um).
PAPER_FIG8 = (
    ("A#", 25.0, 9, 9.8),
    ("A#", 125.0, 9, 81.5),
    ("A#", 225.0, 9, 172.7),
    ("A#", 225.0, 1, 172.6),
    ("B#", 225.0, 1, 158.0),
    ("C#", 225.0, 1, 158.0),
)
#: Fig 6 text: chaotic windows (rpm) per panel.
PAPER_CHAOS = {
    "25C": ((13500.0, 14700.0),),
    "225C": ((13000.0, 14200.0),),
    "225C_fixed": ((12100.0, 14300.0),),
}
#: Fig 6 text: motion sequences with increasing speed.
PAPER_SEQUENCE = {
    "25C": "period-1, chaotic, period-2, chaotic, multi-period, chaotic, period-2",
    "225C": "period-1, shortly chaotic (2850 rpm), period-1, chaotic, period-2, chaotic, period-2, period-3",
    "225C_fixed": "larger chaotic ranges than (b); chaotic at 7100 rpm",
}
#: Fig 6 text: single-speed statements (panel, speed rpm, paper's motion).
PAPER_POINTS = (
    ("225C", 2850.0, "chaotic (transient)"),
    ("25C", 7100.0, "period-1"),
    ("225C", 7100.0, "period-1"),
    ("225C_fixed", 7100.0, "chaotic"),
    ("25C", 12850.0, "chaotic"),
    ("225C", 12850.0, "period-2"),
    ("25C", 14500.0, "chaotic"),
    ("225C", 14500.0, "quasi-periodic-2"),
)
PANELS = {
    "25C": Case(25.0, "A#", True),
    "225C": Case(225.0, "A#", True),
    "225C_fixed": Case(225.0, "A#", False),
}
#: Mesh-stiffness scale that turns the potential-energy mean stiffness of the paper's gears into the
#: ISO 6336-1 value c_gamma_alpha b (4.235e8 / 3.155e8 N/m at 25 C, docs/mesh_stiffness.md).
ISO_SCALE = 1.34
#: Its inverse: the mean stiffness a resonance band at the paper's speeds would need (k x 0.745).
INV_ISO_SCALE = 0.75
STIFFNESS_SCALES = (INV_ISO_SCALE, 0.87, 1.0, 1.15, ISO_SCALE)
PANEL_TITLES = {
    "25C": "(a) 25 C",
    "225C": "(b) 225 C, thermal backlash",
    "225C_fixed": "(c) 225 C, no thermal backlash",
}


def rel_error(model: float, paper: float) -> float:
    """Relative error ``(model - paper) / paper``."""
    return (model - paper) / paper
