"""Calibration data contract, loaders, validation, and the effect library's physics (fast checks).

Truths are independent of the code under test: hand-written files, unit definitions (1 g =
9.80665 m/s^2), the CWRU README's defect multiples, closed-form rotating forces.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml
from roundoff import roundoff

from gear_rotor_sim.calibration.measurement import (
    MeasurementError,
    load_csv,
    load_mat,
    load_mcap,
    load_measurement,
)
from gear_rotor_sim.faults import (
    BEARING_6205,
    BearingDefect,
    BearingGeometry,
    MassUnbalance,
    ShaftMisalignment,
    load_zone,
    mesh_wear_profile,
    tooth_share,
    wear_profile,
)
from gear_rotor_sim.gears import paper_gear_pair
from gear_rotor_sim.materials import carbon_steel

SIDECAR = {
    "sample_rate_hz": 1000,
    "operating_point": {"speed_rpm": 3000, "temperature_c": 25, "output_torque_nm": 200},
    "gearbox": "paper_sun2021",
    "channels": [
        {"column": "dte", "quantity": "dynamic_transmission_error", "unit": "um"},
        {"column": "bearing2_fx", "quantity": "bearing_force", "bearing": 2, "direction": "x", "unit": "kN"},
        {"column": "gear1_ay", "quantity": "acceleration", "node": 5, "direction": "y", "unit": "g"},
    ],
}


def _write(
    tmp: Path,
    rows: np.ndarray,
    header: str = "time_s,dte,bearing2_fx,gear1_ay",
    sidecar: dict | None = None,
    name: str = "run",
) -> Path:
    csv = tmp / f"{name}.csv"
    lines = [header] + [",".join("nan" if not np.isfinite(v) else repr(float(v)) for v in r) for r in rows]
    csv.write_text("\n".join(lines) + "\n")
    (tmp / f"{name}.yaml").write_text(yaml.safe_dump(sidecar if sidecar is not None else SIDECAR))
    return csv


def _rows(n: int = 50) -> np.ndarray:
    t = np.arange(n) / 1000.0
    return np.column_stack([t, np.sin(t), 2.0 * np.ones(n), np.ones(n)])


def test_csv_contract_units_and_channel_mapping(tmp_path: Path) -> None:
    m = load_measurement(_write(tmp_path, _rows()))
    assert m.sample_rate_hz == 1000.0
    assert m.operating_point.speed_rpm == 3000.0 and m.operating_point.output_torque_nm == 200.0
    assert m.model_channels == ["dte", "bearing2_fx", "node5_ay"]
    np.testing.assert_allclose(m.channel("bearing2_fx"), 2000.0)  # kN -> N
    np.testing.assert_allclose(m.channel("gear1_ay"), 9.80665)  # g -> m/s^2
    np.testing.assert_allclose(m.channel("dte"), 1e-6 * np.sin(np.arange(50) / 1000.0))
    blk = m.as_block()
    assert blk.units == ("m", "N", "m/s^2") and blk.channels[2] == "node5_ay"
    assert m.issues == []


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["channels"][0].update(quantity="strain"), "unknown quantity"),
        (lambda d: d["channels"][1].update(column="bearing9_fx"), "missing from the CSV header"),
        (lambda d: d["channels"][2].update(unit="furlong/s^2"), "not understood"),
        (lambda d: d["channels"][1].update(unit="m"), "needs force"),
        (lambda d: d["channels"][1].pop("bearing"), "bearing: required"),
        (lambda d: d["operating_point"].pop("speed_rpm"), "speed_rpm: missing"),
        (lambda d: d.update(colour="red"), "unknown key"),
    ],
)
def test_sidecar_validation_errors(tmp_path: Path, change, message: str) -> None:
    d = yaml.safe_load(yaml.safe_dump(SIDECAR))
    change(d)
    with pytest.raises(MeasurementError, match=message):
        load_csv(_write(tmp_path, _rows(), sidecar=d))


def test_non_monotonic_time_is_an_error(tmp_path: Path) -> None:
    rows = _rows()
    rows[10, 0] = rows[8, 0]
    with pytest.raises(MeasurementError, match="not strictly increasing at row"):
        load_csv(_write(tmp_path, rows))


def test_nan_runs_and_gaps_reported_never_interpolated(tmp_path: Path) -> None:
    rows = _rows(100)
    rows[20:23, 2] = np.nan  # a NaN run of 3 samples in bearing2_fx
    rows[60:, 0] += 0.010  # a 10 ms gap in time after sample 59: sample 60 is at t = 0.070
    path = _write(tmp_path, rows)
    with pytest.raises(MeasurementError, match=r"NaN run.*longest 3"):
        load_csv(path)
    m = load_csv(path, nan_policy="longest_segment")
    # clean segments: 0..19 (20), 23..59 (37), 60..99 (40) -> the last one is kept, untouched
    assert m.n_samples == 40
    assert math.isclose(m.t0, 0.070, abs_tol=1e-12)
    assert any("NaN run" in s for s in m.issues) and any("gap in time_s" in s for s in m.issues)
    np.testing.assert_allclose(m.channel("bearing2_fx"), 2000.0)


def test_header_must_start_with_time(tmp_path: Path) -> None:
    with pytest.raises(MeasurementError, match="first column must be 'time_s'"):
        load_csv(_write(tmp_path, _rows(), header="t,dte,bearing2_fx,gear1_ay"))


def test_sample_rate_must_match_time_column(tmp_path: Path) -> None:
    d = yaml.safe_load(yaml.safe_dump(SIDECAR))
    d["sample_rate_hz"] = 2000
    with pytest.raises(MeasurementError, match="disagrees with sample_rate_hz"):
        load_csv(_write(tmp_path, _rows(), sidecar=d))


def test_mat_through_mapping(tmp_path: Path) -> None:
    from scipy.io import savemat

    x = np.linspace(-1, 1, 3000)
    savemat(
        tmp_path / "rec.mat",
        {"X042_DE_time": x[:, None], "X042_FE_time": x[:, None], "X042RPM": np.array([[1750]])},
    )
    mapping = {
        "sample_rate_hz": 12000,
        "operating_point": {"speed_rpm": {"key": "X*RPM"}, "temperature_c": 25},
        "gearbox": "cwru_rig",
        "channels": [
            {
                "key": "X*_DE_time",
                "quantity": "housing_acceleration",
                "bearing": 1,
                "direction": "y",
                "unit": "g",
            }
        ],
        "files": {"rec.mat": {"sample_rate_hz": 48000}},
    }
    m = load_mat(tmp_path / "rec.mat", mapping)
    assert m.sample_rate_hz == 48000.0 and m.operating_point.speed_rpm == 1750.0
    assert m.model_channels == ["bearing1_housing_ay"] and m.channels[0].column == "X042_DE_time"
    np.testing.assert_allclose(m.data[:, 0], 9.80665 * x)
    bad = dict(mapping, channels=[dict(mapping["channels"][0], key="X*_time")])
    with pytest.raises(MeasurementError, match="matches"):
        load_mat(tmp_path / "rec.mat", bad)


def test_mcap_recording_of_our_streams(tmp_path: Path) -> None:
    from mcap_ros2.writer import Writer

    from gear_rotor_sim.recording.schemas import VIBRATION_CHUNK, full_definition

    path = tmp_path / "rec.mcap"
    fs, n_chunk = 2000.0, 100
    with open(path, "wb") as fh:
        w = Writer(fh)
        schema = w.register_msgdef(VIBRATION_CHUNK, full_definition(VIBRATION_CHUNK))
        for k in range(5):
            if k == 3:
                continue  # a lost chunk: must be reported as a gap, not interpolated
            i0 = k * n_chunk
            t = (i0 + np.arange(n_chunk)) / fs
            data = np.column_stack([1e-6 * np.sin(2 * np.pi * 50 * t), 100 + t])
            w.write_message(
                "/gear_rotor/dte",
                schema,
                {
                    "header": {"stamp": {"sec": 0, "nanosec": int(i0 / fs * 1e9)}, "frame_id": "gear_mesh"},
                    "sequence": k,
                    "first_sample_index": i0,
                    "sample_rate_hz": fs,
                    "speed_rpm": 3000.0,
                    "temperature_c": 75.0,
                    "channel_names": ["dte", "mesh_force"],
                    "units": ["m", "N"],
                    "layout": {
                        "dim": [
                            {"label": "sample", "size": n_chunk, "stride": 2 * n_chunk},
                            {"label": "channel", "size": 2, "stride": 2},
                        ],
                        "data_offset": 0,
                    },
                    "data": data.ravel().tolist(),
                },
                log_time=int(i0 / fs * 1e9),
                publish_time=int(i0 / fs * 1e9),
                sequence=k,
            )
        w.finish()
    with pytest.raises(MeasurementError, match="discontinuity"):
        load_mcap(path)
    m = load_mcap(path, nan_policy="longest_segment")
    assert m.model_channels == ["dte", "mesh_force"]
    assert m.operating_point.speed_rpm == 3000.0 and m.operating_point.temperature_c == 75.0
    assert m.n_samples == 300 and m.t0 == 0.0  # chunks 0-2 kept, chunk 4 after the gap dropped
    t = np.arange(300) / fs
    np.testing.assert_allclose(
        m.channel("dte"),
        1e-6 * np.sin(2 * np.pi * 50 * t),
        rtol=0,
        atol=roundoff(1e-6 * 2 * np.pi * 50 * t[-1]),
    )
    assert any("no sidecar" in s for s in m.issues)


def test_unsupported_file_type(tmp_path: Path) -> None:
    (tmp_path / "x.parquet").write_text("")
    with pytest.raises(MeasurementError, match="unsupported file type"):
        load_measurement(tmp_path / "x.parquet")


# ------------------------------------------------------------------------------------------- effects
def test_bearing_defect_multiples_match_cwru_readme() -> None:
    m = BEARING_6205.multiples()
    assert m["bpfo"] == pytest.approx(3.585, abs=5e-4)
    assert m["bpfi"] == pytest.approx(5.415, abs=5e-4)
    assert m["bsf"] == pytest.approx(2.357, abs=5e-4)
    assert m["ftf"] == pytest.approx(0.398, abs=5e-4)
    f = BEARING_6205.frequencies_hz(1797 / 60.0)
    assert f["bpfi"] == pytest.approx(162.2, abs=0.1)  # README: BPFI predicted 162.2 Hz at 1797 rpm
    with pytest.raises(ValueError):
        BearingGeometry(9, 0.05, 0.04)


def _ctx(
    theta: np.ndarray, omega: float, ndof: int = 24, node_shaft: tuple = (0, 0, 0, 0)
) -> SimpleNamespace:
    system = SimpleNamespace(
        ndof=ndof, shaft_of_node=np.array(node_shaft), bearings=(SimpleNamespace(node0=1),)
    )
    return SimpleNamespace(
        t=theta / omega,
        shaft_angle=theta[:, None],
        shaft_speed=np.full((theta.size, 1), omega),
        system=system,
    )


def test_unbalance_and_misalignment_forces_closed_form() -> None:
    omega = 2 * np.pi * 50.0
    theta = np.linspace(0, 4 * np.pi, 200)
    ctx = _ctx(theta, omega)
    u = MassUnbalance(node=2, unbalance_kg_m=1e-4, phase_rad=0.3)
    f = u.force_amplitudes(ctx)
    np.testing.assert_allclose(f[:, 0], 1e-4 * omega**2 * np.cos(theta + 0.3))
    np.testing.assert_allclose(f[:, 1], 1e-4 * omega**2 * np.sin(theta + 0.3))
    cols = u.external_forces(ctx.system)
    assert cols[6, 0] == 1.0 and cols[7, 1] == 1.0 and cols.sum() == 2.0
    mis = ShaftMisalignment(node=1, offset_m=2e-4, coupling_stiffness_n_per_m=5e5)
    fm = mis.force_amplitudes(ctx)
    np.testing.assert_allclose(np.hypot(fm[:, 0], fm[:, 1]), 100.0)
    # twice per revolution: the x force has period pi in the shaft angle
    np.testing.assert_allclose(fm[:, 0], 100.0 * np.cos(2 * theta))


def test_tooth_share_and_wear_profile() -> None:
    u = (np.arange(29 * 400) + 0.5) / 400.0  # cell centres: no sample exactly on a contact boundary
    eps = 1.6
    total = sum(tooth_share(u, j, 29, eps) for j in range(29))
    # per mesh cycle: 0.6 double contact (2 x 0.5) and 0.4 single contact (1): the shares sum to 1
    np.testing.assert_allclose(total, 1.0)
    one = tooth_share(u, 6, 29, eps)
    assert np.all(one[(u >= 6.6) & (u < 7.0)] == 1.0) and np.all(one[(u >= 6.0) & (u < 6.6)] == 0.5)
    assert np.all(one[(u < 6.0) | (u >= 7.6)] == 0.0)


def test_wear_profile_is_archard_removal_zero_at_the_pitch_point() -> None:
    """Sliding wear (Archard): removal proportional to the sliding distance |s - s_P|, zero at the
    pitch point, 1 at the far end of the path, never negative; the mesh sees the load-share weighted
    mean, which in single contact is the one pair's removal at its position from the involute geometry."""
    s_a, s_p, s_e = 0.010, 0.016, 0.025
    s = np.array([s_a, s_p, s_e, 0.5 * (s_p + s_e), np.nan])
    np.testing.assert_allclose(wear_profile(s, s_p, s_a, s_e), [6 / 9, 0.0, 1.0, 0.5, 0.0], rtol=1e-12)
    with pytest.raises(ValueError, match="pitch_point"):
        wear_profile(s, 0.03, s_a, s_e)
    pair = paper_gear_pair(carbon_steel())
    table = pair.mesh_stiffness_table(25.0, n_points=512)
    w = mesh_wear_profile(table)
    assert np.all(w >= 0.0) and np.all(w <= 1.0 + 1e-12)
    reach = max(pair.contact_end - pair.pitch_point, pair.pitch_point - pair.contact_start)
    single = table.n_pairs == 1
    pos = np.nanmin(table.contact_position[single], axis=1)
    np.testing.assert_allclose(w[single], np.abs(pos - pair.pitch_point) / reach, rtol=1e-12)
    # the pitch point's phase from the geometry (s_P - s_A) / p_b: no removal there
    ph_p = ((pair.pitch_point - pair.contact_start) / pair.base_pitch) % 1.0
    w_p = np.interp(ph_p, table.phase, w, period=1.0)
    assert w_p <= 2.0 * pair.base_pitch / (512 * reach)  # within one grid cell of the slope 1/reach


def test_bearing_impulse_rate_load_zone_and_slip() -> None:
    shaft_hz = 30.0
    omega = 2 * np.pi * shaft_hz
    fs = 200000.0
    t = np.arange(int(1.0 * fs)) / fs
    ctx = _ctx(omega * t, omega)
    for kind, key in (("outer", "bpfo"), ("inner", "bpfi"), ("ball", "bsf")):
        d = BearingDefect(
            kind=kind,
            bearing=1,
            force_n=10.0,
            geometry=BEARING_6205,
            slip=0.0,
            pulse_s=1e-4,
            load_angle_rad=-np.pi / 2,
        )
        f = np.hypot(*d.force_amplitudes(ctx).T)
        starts = np.flatnonzero((f[1:] > 0) & (f[:-1] == 0))
        rate = BEARING_6205.multiples()[key] * shaft_hz * (2.0 if kind == "ball" else 1.0)
        if kind == "outer":
            assert starts.size == pytest.approx(rate * 1.0, abs=1.5)
            assert f.max() == pytest.approx(10.0, rel=1e-3)
        else:  # only impacts inside the load zone are seen
            assert 0 < starts.size < rate
    # load zone: full at the load direction, zero opposite
    assert (
        load_zone(np.array([-np.pi / 2]), -np.pi / 2)[0] == 1.0
        and load_zone(np.array([np.pi / 2]), -np.pi / 2)[0] == 0
    )
    slipped = BearingDefect(kind="outer", bearing=1, force_n=10.0, geometry=BEARING_6205, slip=0.02, seed=3)
    f = np.hypot(*slipped.force_amplitudes(ctx).T)
    starts = np.flatnonzero((f[1:] > 0) & (f[:-1] == 0)) / fs
    spacing = np.diff(starts) * BEARING_6205.multiples()["bpfo"] * shaft_hz
    assert 0.01 < np.std(spacing) < 0.03 and abs(np.mean(spacing) - 1) < 0.01
