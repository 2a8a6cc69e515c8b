"""A damaged tooth in contact: its index at the mesh, its bearing path (docs/history/calibration_sessions.md
Sec. 8.35).

``candidates_tooth_path.tooth_index_at_mesh`` (opt-in) decides where the named tooth and its
neighbours are compared at the channels at the mesh; ``contact_tooth_path`` (opt-in) where the rule of
``fault_path.py`` (a damaged tooth's signature at the radial bearing channels times a fitted factor)
applies in contact: only with a channel at the mesh, the order family and the teeth in contact.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration.candidates_tooth_path import contact_tooth_path, tooth_index_at_mesh
from gear_rotor_sim.calibration.fit import FitSettings

NAMES = ["dte", "bearing2_fx", "bearing2_fy", "bearing2_fz", "node5_ax", "node5_ay"]


def _cal(names=NAMES, families=("order", "envelope", "static"), contact_loss=0.0, on=True):
    return SimpleNamespace(
        fit=FitSettings(tooth_path_in_contact=on, tooth_index_at_mesh=on),
        cmp=SimpleNamespace(names=list(names), families=list(families)),
        base_contact_loss=contact_loss,
    )


def test_contact_path_is_the_radial_bearing_channels_with_a_dte() -> None:
    """The radial bearing forces only: not the DTE (it names the tooth), not the axial force (its
    quasi-static path), not the shaft-node accelerations."""
    mask = contact_tooth_path(_cal())
    assert mask is not None
    assert [n for n, m in zip(NAMES, mask, strict=True) if m] == ["bearing2_fx", "bearing2_fy"]


@pytest.mark.parametrize(
    "kw",
    [
        {"names": [n for n in NAMES if n != "dte"]},  # nothing measures the mesh: the tooth has no namer
        {"families": ("envelope", "static")},  # no order features (no speed)
        {"contact_loss": 0.3},  # the teeth separate: features_rattle.py sets the path
        {"on": False},  # the setting off: the model's path as before
        {"names": ["dte", "node5_ax"]},  # no bearing channel
    ],
)
def test_contact_path_not_applied(kw: dict) -> None:
    assert contact_tooth_path(_cal(**kw)) is None


def test_contact_path_is_a_boolean_mask_over_the_channels() -> None:
    mask = contact_tooth_path(_cal())
    assert isinstance(mask, np.ndarray) and mask.dtype == bool and mask.size == len(NAMES)


def test_both_contact_rules_are_opt_in() -> None:
    """Opt-in (Sec. 8.35): the contact path loses the x0.6 pinion tooth and the FE model's own tooth
    record; the index at the mesh was measured on a few rows only."""
    f = FitSettings()
    assert f.tooth_index_at_mesh is False
    assert f.tooth_path_in_contact is False


def test_index_at_the_mesh_where_a_dte_is_recorded_in_contact() -> None:
    assert tooth_index_at_mesh(_cal())
    assert tooth_index_at_mesh(_cal(names=["dte", "node5_ax"]))  # no bearing channel needed


@pytest.mark.parametrize(
    "kw",
    [
        {"names": [n for n in NAMES if n != "dte"]},
        {"families": ("envelope", "static")},
        {"contact_loss": 0.3},
        {"on": False},
    ],
)
def test_index_not_at_the_mesh(kw: dict) -> None:
    assert not tooth_index_at_mesh(_cal(**kw))
