"""Baseline parameters at the bounds of their plausible range are named (``calibration/baseline_bounds.py``;
docs/history/calibration_sessions.md Sec. 8.77)."""

from types import SimpleNamespace

from gear_rotor_sim.calibration.baseline_bounds import baseline_bound_notes, bound_side
from gear_rotor_sim.faults import BearingStiffnessDamping, MeshStiffnessDamping

GAINS, SLOPES = (0.8, 1.25), (-0.3, 0.3)


def _set(effect):
    return SimpleNamespace(
        name=effect.name, label=effect.label, effect=effect, parameters=effect.parameters()
    )


def test_bound_side_within_one_percent_of_the_range():
    assert bound_side(0.3, 0.3, 3.0) == "lower"
    assert bound_side(0.3 + 0.0099 * 2.7, 0.3, 3.0) == "lower"
    assert bound_side(0.3 + 0.0101 * 2.7, 0.3, 3.0) is None
    assert bound_side(2.0, 0.3, 2.0) == "upper"
    assert bound_side(1.0, 0.3, 2.0) is None


def test_the_blind_sets_bounds_are_named_and_plausible_values_are_not():
    # blind16 (set 1, session 26): bearing stiffness x0.3, mesh x0.818; blind13: mesh x2.0
    updates = [
        _set(BearingStiffnessDamping(stiffness_scale=0.3, damping_scale=1.06)),
        _set(MeshStiffnessDamping(stiffness_scale=0.818)),
        _set(MeshStiffnessDamping(stiffness_scale=2.0, damping_scale=0.6)),
        SimpleNamespace(
            name="sensor_transfer",
            label="sensor_transfer",
            effect=None,
            parameters={
                "gain_dte": 0.8,
                "transfer_slope_dte": 0.0,
                "gain_node5_ay": 1.02,
                "transfer_slope_node5_ay": -0.3,
                "shaft_order_gain_dte": 0.5,
            },
        ),
    ]
    notes = baseline_bound_notes(updates, GAINS, SLOPES)
    assert len(notes) == 4, notes
    assert "bearing_stiffness_damping stiffness_scale = 0.3, its lower bound" in notes[0]
    assert "mesh_stiffness_damping stiffness_scale = 2, its upper bound" in notes[1]
    assert "gain_dte = 0.8" in notes[2] and "transfer_slope_node5_ay = -0.3" in notes[3]
    assert not baseline_bound_notes([_set(MeshStiffnessDamping(stiffness_scale=1.199))], GAINS, SLOPES)
