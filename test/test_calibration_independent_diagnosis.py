"""Calibration on data the model did not make (issue 11).

The records come from ``lumped_gearbox`` (docs/independent_data.md): an eight-DOF lumped model of
the same gearbox with its own mesh-stiffness model (ISO 6336 mean, smoothed pair entry and exit),
no gyroscopic terms, 2-5 % noise and +-3 % gains per channel. Nothing of it is shared with the
finite-element model the calibration fits. Criteria (issue 11 acceptance, on short records to stay
within the test budget): healthy records claim no effect (baseline updates allowed); a damaged
tooth on the GEAR wheel is named first with wheel and tooth; a temperature offset is named with its
value within 25 %; the same diagnosis holds with ``--baseline`` (a healthy record at another speed).

Also: the tilted contact of ``gear_misalignment`` (tangent stiffness and centre-approach offset)
against a direct integration of a line contact tilted about the middle of a Winkler face.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from gear_rotor_sim.calibration.baseline import fit_reference_baseline
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.fit_types import FitSettings
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.faults import tilted_contact_offset, tilted_contact_stiffness_factor

DURATION_S = 0.6  # 30 input revolutions, 18 of the gear at 3000 rpm

# each calibration runs dozens of simulations: 2-4.5 min per test on the shared, loaded machine
pytestmark = pytest.mark.slow


def _record(root: Path, tag: str, speed: float, temp: float, faults: list[str], seed: int) -> Path:
    from lumped_gearbox import make_record, write_record

    rec = make_record(speed, temp, faults, duration_s=DURATION_S, seed=seed)
    return write_record(root / f"{tag}.csv", rec)


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory, shared_records: dict[str, Path]) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("independent")
    # the pinion-tooth, healthy 2000 rpm and healthy 3000 rpm / 25 C records are the session's
    # (conftest.SHARED_RECORDS: the same speeds, faults, seeds and length as made here), calibrated once for
    # this file and others
    return {
        **shared_records,
        "healthy_25": shared_records["healthy_3000"],
        "healthy_125": _record(root, "healthy_125", 3000.0, 125.0, [], 2),
        "gear_tooth": _record(
            root, "gear_tooth", 3000.0, 25.0, ["tooth_damage:wheel=gear,tooth=5,depth=0.4"], 3
        ),
        "temperature": _record(root, "temperature", 3000.0, 25.0, ["temperature_offset:offset_c=60"], 4),
        "wear": _record(root, "wear", 3000.0, 25.0, ["tooth_wear:wear_depth_m=20e-6"], 6),
    }


def _calibrate(path: Path, **kw):
    return Calibrator(load_measurement(path), **kw).run()


@pytest.mark.acceptance
@pytest.mark.parametrize("which", ["healthy_25", "healthy_125"])
def test_healthy_independent_records_claim_no_effect(records, which: str, request) -> None:
    # healthy_25 is calibrated once per session (conftest.healthy_3000_calibration: the same record and call)
    shared = which == "healthy_25"
    r = request.getfixturevalue("healthy_3000_calibration") if shared else _calibrate(records[which])
    assert r.effects == [], [(e.label, e.parameters) for e in r.effects]
    d = r.as_dict()
    assert "baseline_updates" in d and d["baseline"]["source"] == "measurement"
    assert np.isfinite(r.error_before) and np.isfinite(r.error_after)


@pytest.mark.acceptance
def test_gear_tooth_damage_named_first_with_wheel_and_tooth(records) -> None:
    # the first effect is what is asserted: the search stops there (Secs. 8.74, 8.81: the same effect,
    # depth, errors and mesh scale as the full search, 168 model runs instead of 219)
    r = _calibrate(records["gear_tooth"], fit_settings=FitSettings(max_effects=1))
    assert r.effects, r.conclusion
    first = r.effects[0]
    assert first.label == "tooth_damage@gear", [(e.label, e.parameters) for e in r.effects]
    assert first.parameters["tooth"] == 5 and first.parameters["wheel"] == "gear"
    # without a reference the depth is read from the sideband energy ratios
    # (docs/history/calibration_sessions.md Sec. 8.10; measured 0.436 for 0.4, +9 %; from the absolute
    # features 0.228)
    assert abs(first.parameters["depth"] - 0.4) <= 0.25 * 0.4, first.parameters
    assert r.error_after <= 0.5 * r.error_before
    # with the depth known, the absolute size of the signature gives the mesh stiffness scale:
    # independent truth, the ratio of the two models' mean mesh stiffnesses (1.342; measured 1.309)
    _assert_mesh_scale_is_the_ratio_of_the_two_models(r)


@pytest.mark.acceptance
def test_pinion_tooth_depth_from_the_sideband_ratios_without_a_reference(pinion_tooth_calibration) -> None:
    """Pinion tooth 7, depth 0.4 (docs/history/calibration_sessions.md Sec. 8.10; measured 0.451, +13 %, mesh
    x1.306; from the absolute features 0.275). ``_calibrate(records["pinion_tooth"])``, run once per session
    (``conftest.pinion_tooth_calibration``)."""
    r = pinion_tooth_calibration
    assert r.effects and r.effects[0].label == "tooth_damage@pinion", [
        (e.label, e.parameters) for e in r.effects
    ]
    first = r.effects[0]
    assert first.parameters["tooth"] == 7
    assert abs(first.parameters["depth"] - 0.4) <= 0.25 * 0.4, first.parameters
    assert r.error_after <= 0.5 * r.error_before
    _assert_mesh_scale_is_the_ratio_of_the_two_models(r)


def _assert_mesh_scale_is_the_ratio_of_the_two_models(r) -> None:
    from gear_rotor_sim.gears import paper_gear_pair
    from gear_rotor_sim.materials import carbon_steel
    from lumped_gearbox.params import Gearbox, springs

    truth = (
        springs(Gearbox(), 25.0).mesh_mean / paper_gear_pair(carbon_steel()).mesh_stiffness_table(25.0).mean
    )
    mesh = [b for b in r.baseline_updates if b.name == "mesh_stiffness_damping"]
    assert mesh and abs(mesh[0].parameters["stiffness_scale"] - truth) <= 0.15 * truth, (
        [(b.label, b.parameters) for b in r.baseline_updates],
        truth,
    )


@pytest.mark.acceptance
def test_temperature_offset_from_the_static_content(records) -> None:
    truth = json.loads(records["temperature"].with_suffix(".truth.json").read_text())
    # the first effect is what is asserted: the search stops there (Sec. 8.81: the same offset, status and
    # confidence as the full search, 22 model runs instead of 141)
    r = _calibrate(records["temperature"], fit_settings=FitSettings(max_effects=1))
    assert r.effects and r.effects[0].name == "temperature_offset", [
        (e.label, e.parameters) for e in r.effects
    ]
    fitted = r.effects[0].parameters["offset_c"]
    assert abs(fitted - 60.0) <= 0.25 * 60.0, (fitted, truth)
    assert r.effects[0].status == "found" and r.effects[0].confidence > 0.9


@pytest.fixture(scope="module")
def reference(reference_2000):
    """Baseline of the machine fitted on its healthy 2000 rpm record (``--baseline``), once per session
    (``conftest.reference_2000``: ``fit_reference_baseline`` of ``records["healthy_2000"]``)."""
    return reference_2000


@pytest.fixture(scope="module")
def converged_reference(records):
    """The same reference fitted with the exact modal map (``ResidualSettings(reference_exact_map=True)``,
    off by default: docs/history/calibration_sessions.md Sec. 8.27)."""
    from gear_rotor_sim.calibration.residual import ResidualSettings

    return fit_reference_baseline(
        load_measurement(records["healthy_2000"]),
        source=str(records["healthy_2000"]),
        settings=ResidualSettings(reference_exact_map=True),
    )


@pytest.mark.acceptance
def test_reference_mesh_stiffness_scale_is_converged_in_the_integration_step(
    records, converged_reference
) -> None:
    """The reference's mesh stiffness scale must not be a property of the integrator. With Newmark's map
    the period error ``(omega dt)^2 / 12`` lowers the mesh-coupled modes and the fit raised the mesh
    stiffness to put them back (2 s benchmark record: x1.309 / 1.199 / 1.121 / 1.107 at 32 / 64 / 128 /
    256 steps per mesh). With the exact modal map (``ResidualSettings.reference_exact_map``, off by
    default; docs/history/calibration_sessions.md Sec. 8.27) its scale at 64 steps must agree with an
    independent integrator's at a fine step, Newmark at 128 steps, within 3 % (measured on this 0.6 s record:
    x1.109 and x1.121; Newmark at 64 steps, the default reference, x1.211).

    What the scale is not: the two models' mean mesh-stiffness ratio (ISO 6336 ``c_gamma b`` 423 MN/m
    against the potential-energy TVMS mean 316 MN/m, 1.342), which a damaged tooth's static ``F / k``
    needs; fitted on the healthy record's dynamics it is a compromise of carriers and resonances (x1.11).
    So the tooth depth against a reference is read from the DTE comb, not from this scale (the test
    below)."""
    from gear_rotor_sim.calibration.residual import ResidualSettings

    newmark = fit_reference_baseline(
        load_measurement(records["healthy_2000"]),
        source=str(records["healthy_2000"]),
        settings=ResidualSettings(reference_exact_map=False),
        steps_per_mesh=128,
    )

    def mesh_scale(ref) -> float:
        mesh = [e for e in ref.effects if e.name == "mesh_stiffness_damping"]
        assert mesh, [e.label for e in ref.effects]
        return float(mesh[0].stiffness_scale)

    exact, fine = mesh_scale(converged_reference), mesh_scale(newmark)
    assert abs(exact - fine) <= 0.03 * fine, (exact, fine)
    # the model-form floor of the carriers is a fraction, carried as such to other speeds
    assert 0.05 <= converged_reference.carrier_tolerance <= 0.5


@pytest.mark.acceptance
@pytest.mark.parametrize(("which", "wheel", "tooth"), [("gear_tooth", "gear", 5)])
def test_diagnosis_against_the_converged_reference_reads_the_depth_from_the_dte_comb(
    records, converged_reference, which, wheel, tooth
) -> None:
    """A damaged tooth at 3000 rpm against the converged 2000 rpm reference: named first with wheel and
    tooth, the depth read from the DTE comb within 25 % of the truth (docs/history/calibration_sessions.md
    Sec. 8.27). Against the converged reference the absolute features read the depth about 30 % low on the 2 s
    benchmark records (they follow the reference's dynamic mesh scale, x1.11, as ``F / k``; the static
    ratio of the two models is 1.342), so the DTE comb must be the reading and must be closer to the
    truth than the absolute one.

    The gear tooth only since session 25 (Sec. 8.72): the pinion tooth's DTE-comb depth is checked on the
    session's pinion record without a reference (test_calibration_dte_depth.py, within 10 %) and against a
    held reference with the converged numerics on the FE model's own record (the same file, within 5 %)."""
    from gear_rotor_sim.calibration.residual import ResidualSettings

    reference = converged_reference
    r = _calibrate(
        records[which], settings=ResidualSettings(reference_exact_map=True), **reference.calibrator_kwargs()
    )
    d = r.as_dict()
    assert d["baseline"]["source"] == str(records["healthy_2000"])
    assert d["baseline"]["reference"]["operating_point"]["speed_rpm"] == 2000.0
    assert r.effects and r.effects[0].label == f"tooth_damage@{wheel}", [
        (e.label, e.parameters) for e in r.effects
    ]
    assert r.effects[0].parameters["tooth"] == tooth
    depth = r.effects[0].parameters["depth"]
    assert abs(depth - 0.4) <= 0.25 * 0.4, r.effects[0].parameters
    dte = [n for n in r.notes if "depth from the DTE comb" in n]
    assert dte, r.notes
    absolute = float(dte[0].rsplit("from the absolute features ", 1)[1].split()[0].rstrip(";,"))
    assert abs(depth - 0.4) < abs(absolute - 0.4), (depth, absolute)
    assert r.error_after <= 0.5 * r.error_before
    # the held baseline is reported, not re-fitted
    assert [b.label for b in r.baseline_updates if b.effect is not None] == [
        e.label for e in reference.effects
    ]


@pytest.mark.acceptance
def test_diagnosis_against_a_healthy_baseline_at_another_speed(records, reference) -> None:
    # the first effect is what is asserted: the search stops there (Sec. 8.81: the same tooth, depth, errors
    # and held baseline as the full search, 67 model runs instead of 76)
    fit = FitSettings(max_effects=1)
    r = _calibrate(records["gear_tooth"], **reference.calibrator_kwargs(), fit_settings=fit)
    d = r.as_dict()
    assert d["baseline"]["source"] == str(records["healthy_2000"])
    assert d["baseline"]["reference"]["operating_point"]["speed_rpm"] == 2000.0
    assert r.effects and r.effects[0].label == "tooth_damage@gear", [
        (e.label, e.parameters) for e in r.effects
    ]
    assert r.effects[0].parameters["tooth"] == 5
    # the default reference (64 Newmark steps, mesh x1.21 / x1.0): the absolute depth (Sec. 8.27)
    assert abs(r.effects[0].parameters["depth"] - 0.4) <= 0.25 * 0.4, r.effects[0].parameters
    # the held baseline is reported, not re-fitted
    assert [b.label for b in r.baseline_updates if b.effect is not None] == [
        e.label for e in reference.effects
    ]


@pytest.mark.acceptance
def test_temperature_offset_against_a_healthy_baseline_at_another_speed(records, reference) -> None:
    """The 2000 rpm / 25 C baseline held on a record running 60 C hotter than declared: the
    reference's bearing scale (lateral, ~0.5) must not change the static axial load per degree
    (before the bearing set left k_axial alone: +111 C for +60 C on the 2 s record)."""
    # the first effect is what is asserted: the search stops there (Sec. 8.81: the same offset, errors and
    # held baseline as the full search, 23 model runs instead of 71)
    fit = FitSettings(max_effects=1)
    r = _calibrate(records["temperature"], **reference.calibrator_kwargs(), fit_settings=fit)
    assert r.effects and r.effects[0].name == "temperature_offset", [
        (e.label, e.parameters) for e in r.effects
    ]
    assert abs(r.effects[0].parameters["offset_c"] - 60.0) <= 0.25 * 60.0, r.effects[0].parameters


@pytest.mark.acceptance
def test_healthy_record_at_another_speed_and_temperature_claims_nothing_against_the_baseline(
    records, reference
) -> None:
    """The 2000 rpm / 25 C baseline held on a healthy 3000 rpm / 125 C record: no effect."""
    r = _calibrate(records["healthy_125"], **reference.calibrator_kwargs())
    assert r.effects == [], [(e.label, e.parameters) for e in r.effects]
    assert r.as_dict()["baseline"]["source"] == str(records["healthy_2000"])


@pytest.mark.acceptance
def test_wear_from_the_dte_mean_against_a_healthy_baseline_at_another_speed(records, reference) -> None:
    """20 um of flank wear at 3000 rpm against the 2000 rpm reference: the reference fixes the mesh
    stiffness (hence the static deflection F/k), the record's DTE mean then gives the depth
    (candidates_wear_reference.py). Measured on this 0.6 s record: 18.8 um (-6 %), error 5.14 -> 2.85;
    the ranking alone fitted 9.9 um on the 2 s benchmark record (docs/history/calibration_sessions.md
    Sec. 8.12)."""
    r = _calibrate(records["wear"], **reference.calibrator_kwargs())
    assert r.effects and r.effects[0].name == "tooth_wear", [(e.label, e.parameters) for e in r.effects]
    assert abs(r.effects[0].parameters["wear_depth_m"] - 20e-6) <= 0.25 * 20e-6, r.effects[0].parameters
    assert r.effects[0].status == "found"
    assert r.error_after < r.error_before


def test_tilted_contact_matches_a_winkler_face_tilted_about_its_middle() -> None:
    """Independent truth: integrate p(y) = k' max(d + gamma y, 0) over the face (-b/2 <= y <= b/2),
    solve for the centre approach d* at the force of the aligned approach delta0, and compare the
    tangent stiffness dF/dd (central difference) and the offset d* - F0 / (dF/dd) with the closed
    forms of ``gear_misalignment`` (full contact up to rho = gamma b / (2 delta0) = 1)."""
    b, kprime, delta0 = 0.02, 1e10, 5e-6
    force = kprime * b * delta0
    y = np.linspace(-0.5 * b, 0.5 * b, 40001)

    def load(d: float, gamma: float) -> float:
        p = kprime * np.maximum(d + gamma * y, 0.0)
        return float(np.sum((p[1:] + p[:-1]) * 0.5 * np.diff(y)))

    for rho in (0.0, 0.5, 1.0, 2.5, 8.0):
        gamma = 2.0 * rho * delta0 / b
        d = brentq(lambda x, g=gamma: load(x, g) - force, -1e-3, 1e-3, xtol=1e-16)
        h = 1e-4 * delta0
        tangent = (load(d + h, gamma) - load(d - h, gamma)) / (2.0 * h)
        factor = tangent / (kprime * b)
        offset = d - force / tangent
        got_f = float(tilted_contact_stiffness_factor(np.array([rho]))[0])
        got_e = delta0 * float(tilted_contact_offset(np.array([rho]))[0])
        assert abs(got_f - factor) <= 2e-3 * factor, (rho, got_f, factor)
        assert abs(got_e - offset) <= 2e-3 * delta0, (rho, got_e, offset)
