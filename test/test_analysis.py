"""Analyses against independent truths: known tones, known periodic/chaotic systems, known RMS values."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from roundoff import roundoff

from gear_rotor_sim.analysis import bifurcation as bif
from gear_rotor_sim.analysis.bifurcation import BifurcationResult, Case, RunSettings, run_bifurcation
from gear_rotor_sim.analysis.classify import (
    chaotic_windows,
    classify_motion,
    cluster_count,
    zero_one_test,
)
from gear_rotor_sim.analysis.parallel import tick
from gear_rotor_sim.analysis.poincare import phase_portrait, poincare_at_times, poincare_samples
from gear_rotor_sim.analysis.signals import (
    amplitude_spectrum,
    envelope_spectrum,
    order_spectrum,
    synchronous_average,
)
from gear_rotor_sim.analysis.sweep import SweepResult, reduce_sweep, run_sweep


def _logistic(r: float, n: int, x0: float = 0.3, burn: int = 1000) -> np.ndarray:
    x, out = x0, np.empty(n)
    for i in range(burn + n):
        x = r * x * (1.0 - x)
        if i >= burn:
            out[i - burn] = x
    return out


# --------------------------------------------------------------------------------------------- signals
@pytest.mark.parametrize("window", ["rectangular", "hann", "hamming", "blackman", "flattop"])
def test_amplitude_spectrum_pure_tone_on_bin(window: str) -> None:
    fs, n = 10_000.0, 4000
    f0 = 25 * fs / n  # on a bin
    t = np.arange(n) / fs
    spec = amplitude_spectrum(0.7 + 2.5 * np.cos(2 * np.pi * f0 * t + 0.4), fs, window=window)
    f, a = spec.peak()
    assert f == pytest.approx(f0)
    assert a == pytest.approx(2.5, rel=1e-6)
    assert spec.at(0.0) <= roundoff(0.7 + 2.5, n)  # mean removed (to the round-off of the samples)


def test_flattop_amplitude_between_bins() -> None:
    fs, n = 10_000.0, 4096
    f0 = 100.5 * fs / n  # worst case, half a bin off
    t = np.arange(n) / fs
    _, a = amplitude_spectrum(1.3 * np.sin(2 * np.pi * f0 * t), fs, window="flattop").peak()
    assert a == pytest.approx(1.3, rel=5e-3)


def test_order_spectrum_tracks_a_speed_ramp() -> None:
    fs = 20_000.0
    t = np.arange(int(2.0 * fs)) / fs
    speed = 600.0 + 1800.0 * t / t[-1]  # rpm, ramp 600 -> 2400
    rev = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) / 60.0 / fs)])
    x = 0.8 * np.cos(2 * np.pi * 29 * rev) + 0.3 * np.cos(2 * np.pi * 3 * rev)
    spec = order_spectrum(x, fs, speed, samples_per_rev=128)
    assert spec.unit == "order"
    assert spec.peak(20, 40) == pytest.approx((29.0, 0.8), rel=1e-2)
    assert spec.peak(1, 10) == pytest.approx((3.0, 0.3), rel=1e-2)
    # a plain spectrum smears the swept tone: the peak is far below 0.8
    assert amplitude_spectrum(x, fs).peak(100, 2000)[1] < 0.3


def test_envelope_spectrum_recovers_modulation() -> None:
    fs, n = 50_000.0, 50_000
    t = np.arange(n) / fs
    x = (1.0 + 0.4 * np.cos(2 * np.pi * 37.0 * t)) * np.cos(2 * np.pi * 5000.0 * t)
    spec = envelope_spectrum(x, fs, band_hz=(3000.0, 7000.0))
    assert spec.peak(5, 500) == pytest.approx((37.0, 0.4), rel=2e-2)


def test_synchronous_average_removes_asynchronous_part() -> None:
    rng = np.random.default_rng(1)
    fs, rpm = 10_000.0, 1200.0
    t = np.arange(int(10.0 * fs)) / fs
    sync = np.cos(2 * np.pi * (rpm / 60) * 4 * t)
    x = sync + 0.5 * np.sin(2 * np.pi * 97.3 * t) + 0.5 * rng.standard_normal(t.size)
    avg = synchronous_average(x, fs, rpm, samples_per_rev=100)
    truth = np.cos(2 * np.pi * 4 * np.arange(100) / 100)
    assert np.max(np.abs(avg - truth)) < 0.1


# --------------------------------------------------------------------------------------------- Poincare
def test_period_two_signal_has_two_poincare_points() -> None:
    spp = 32
    k = np.arange(spp * 300)
    phase = 2 * np.pi * k / spp
    x = np.cos(phase) + 0.4 * np.cos(phase / 2 + 0.3)  # subharmonic: period 2 of the forcing
    pp = phase_portrait(x, fs := 1000.0, spp, offset=5)
    assert cluster_count(np.column_stack([pp.px, pp.pv]), [np.ptp(x), np.ptp(pp.v)], 1e-3) == 2
    m = classify_motion(np.column_stack([pp.px, pp.pv]), [np.ptp(x), np.ptp(pp.v)])
    assert (m.label, m.period) == ("period-2", 2)
    # velocity from the central difference matches the analytic derivative
    v_true = fs * 2 * np.pi / spp * (-np.sin(phase) - 0.2 * np.sin(phase / 2 + 0.3))
    assert np.max(np.abs(pp.v[1:-1] - v_true[1:-1])) < 0.01 * np.ptp(v_true)


def test_poincare_at_times_matches_integer_sampling() -> None:
    t = np.linspace(0, 1, 1001)
    x = np.sin(2 * np.pi * 7 * t)
    p = poincare_at_times(t, x, 0.1, 0.0)
    assert p.size == 11
    # sampling times equal to grid times up to their round-off, times the slope 2 pi 7 of x
    np.testing.assert_allclose(p, poincare_samples(x, 100), rtol=0, atol=roundoff(2 * np.pi * 7, t.size))


# --------------------------------------------------------------------------------------------- classification
def test_zero_one_test_on_the_logistic_map() -> None:
    assert zero_one_test(_logistic(3.97, 1000)) > 0.9  # chaotic
    assert abs(zero_one_test(_logistic(3.5, 1000))) < 0.1  # period 4
    n = np.arange(1000)
    qp = np.sin(2 * np.pi * 0.5 * (np.sqrt(5) - 1) * n) + 0.4 * np.cos(2 * np.pi * np.sqrt(2) * n)
    assert abs(zero_one_test(qp)) < 0.1


@pytest.mark.parametrize(("r", "label"), [(3.2, "period-2"), (3.5, "period-4"), (3.97, "chaotic")])
def test_classify_logistic_map(r: float, label: str) -> None:
    assert classify_motion(_logistic(r, 300)).label == label


def test_classify_quasi_periodic_circle() -> None:
    n = np.arange(300)
    theta = 2 * np.pi * 0.5 * (np.sqrt(5) - 1) * n  # irrational rotation: points fill a closed curve
    m = classify_motion(np.column_stack([np.cos(theta), np.sin(theta)]))
    assert m.label == "quasi-periodic"
    assert m.n_distinct > 50


def test_chaotic_windows_merge_isolated_gaps() -> None:
    s = np.arange(10) * 100.0
    labels = [
        "period-1",
        "chaotic",
        "chaotic",
        "period-2",
        "chaotic",
        "period-1",
        "period-1",
        "chaotic",
        "x",
        "x",
    ]
    assert chaotic_windows(s, labels, merge_gap=1) == [(100.0, 400.0), (700.0, 700.0)]
    assert chaotic_windows(s, labels, merge_gap=0) == [(100.0, 200.0), (400.0, 400.0), (700.0, 700.0)]


# ----------------------------------------------------------------------------------------- sweep machinery
def _duffing_segment(case, speeds, settings, channels, reducer):  # type: ignore[no-untyped-def]
    """Reference segment runner: Ueda's forced Duffing oscillator x'' + 0.05 x' + x^3 = B cos t.

    ``speed / 1000`` is the forcing amplitude B. B = 7.5 is Ueda's chaotic attractor; B = 0.3 gives
    a period-1 response. RK4, ``steps_per_mesh`` steps per forcing period; continuation of the state.
    """
    spm = settings.steps_per_mesh
    h = 2 * np.pi / spm
    state = np.array([1.0, 0.0])
    rows = []
    for i, speed in enumerate(speeds):
        b = speed / 1000.0
        n_tr = settings.n_transient_periods * (settings.first_transient_factor if i == 0 else 1)
        n_tot = int(n_tr + settings.n_periods) * spm
        x = np.empty(n_tot)

        def f(t: float, y: np.ndarray, b: float = b) -> np.ndarray:
            return np.array([y[1], -0.05 * y[1] - y[0] ** 3 + b * np.cos(t)])

        y = state
        for k in range(n_tot):
            t = k * h
            x[k] = y[0]
            k1 = f(t, y)
            k2 = f(t + h / 2, y + h / 2 * k1)
            k3 = f(t + h / 2, y + h / 2 * k2)
            k4 = f(t + h, y + h * k3)
            y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        state = y
        data = x[-settings.n_periods * spm :, None].repeat(len(channels), axis=1)
        rows.append(reducer(data, channels, settings, h))
        tick()  # the progress line of execute_tasks
    out = {k: np.stack([r[k] for r in rows]) for k in rows[0]}
    out["wall_s"] = np.zeros(len(speeds))
    return out


SETTINGS = RunSettings(n_transient_periods=100, n_periods=200, steps_per_mesh=48, first_transient_factor=2.0)


def _check_duffing(res: BifurcationResult) -> None:
    labels = dict(zip(res.speeds_rpm, res.labels(), strict=True))
    assert labels[300.0] == "period-1"
    assert labels[7500.0] == "chaotic"


def test_bifurcation_local_processes_and_npz(tmp_path: Path) -> None:
    res = run_bifurcation(
        Case(25.0), [7500.0, 300.0], SETTINGS, workers=2, progress=True, segment_fn=_duffing_segment
    )
    assert res.section.shape == (2, SETTINGS.n_periods)
    np.testing.assert_array_equal(res.speeds_rpm, [300.0, 7500.0])
    _check_duffing(res)
    back = BifurcationResult.load(res.save(tmp_path / "b.npz"))
    np.testing.assert_array_equal(back.section, res.section)
    assert back.case == res.case and back.settings == res.settings
    assert back.labels() == res.labels()


def test_bifurcation_on_a_local_dask_cluster() -> None:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
    ) as cluster:
        res = run_bifurcation(
            Case(225.0, thermal_backlash=False),
            [300.0, 7500.0],
            SETTINGS,
            workers=2,
            scheduler=cluster.scheduler_address,
            progress=False,
            segment_fn=_duffing_segment,
        )
    assert res.meta["scheduler"] == cluster.scheduler_address
    _check_duffing(res)


def test_reduce_sweep_known_rms_and_amplitude() -> None:
    settings = RunSettings(1, 10, 40)
    n = settings.n_periods * settings.steps_per_mesh
    phase = 2 * np.pi * np.arange(n) / settings.steps_per_mesh
    channels = ["dte", "bearing1_fx", "bearing1_fy", "bearing1_fz", "node1_x", "node1_y", "node1_z"]
    data = np.column_stack(
        [
            1e-6 * np.cos(phase),
            300.0 + 400.0 * np.cos(phase),  # RMS sqrt(300^2 + 400^2/2)
            500.0 * np.sin(phase),  # RMS 500/sqrt(2)
            np.full(n, -1800.0),  # RMS 1800
            3e-6 * np.cos(phase),
            3e-6 * np.sin(phase),  # circle of radius 3 um
            np.full(n, 80e-6),  # axial offset 80 um
        ]
    )
    out = reduce_sweep(
        data, channels, settings, 1e-5, orbit_nodes=(1,), orbit_periods=2, orbit_samples_per_mesh=40
    )
    rms = np.array([np.sqrt(300.0**2 + 400.0**2 / 2), 500.0 / np.sqrt(2), 1800.0])
    np.testing.assert_allclose(out["bearing_rms"][0], rms, rtol=1e-9)
    assert out["bearing_total_rms"][0] == pytest.approx(np.sqrt(np.sum(rms**2)), rel=1e-9)
    np.testing.assert_allclose(out["bearing_mean"][0], [300.0, 0.0, -1800.0], atol=roundoff(1800.0, n))
    assert out["node_amp_max"][0] == pytest.approx(np.hypot(3e-6, 80e-6), rel=1e-9)
    np.testing.assert_allclose(out["node_pp"][0], [6e-6, 6e-6, 0.0], rtol=0, atol=roundoff(80e-6, n))
    assert out["orbit"].shape == (1, 2 * settings.steps_per_mesh, 2)


def _sweep_segment(case, speeds, settings, channels, reducer):  # type: ignore[no-untyped-def]
    """Reference runner for the sweep: bearing force = T * speed (N), node z = T um; deterministic."""
    n = settings.n_periods * settings.steps_per_mesh
    rows = []
    for s in speeds:
        data = np.zeros((n, len(channels)))
        data[:, channels.index("bearing2_fz")] = case.temperature_c * s
        data[:, channels.index("node9_z")] = case.temperature_c * 1e-6
        rows.append(reducer(data, channels, settings, 1e-5))
    out = {k: np.stack([r[k] for r in rows]) for k in rows[0]}
    out["wall_s"] = np.zeros(len(speeds))
    return out


def test_sweep_grid_order_and_cache(tmp_path: Path) -> None:
    from gear_rotor_sim.analysis.sweep import grid_cases

    cases = grid_cases([25.0, 225.0], ["A#", "C#"])
    res = run_sweep(
        cases, [3.0, 1.0, 2.0], RunSettings(1, 4, 8), workers=1, progress=False, segment_fn=_sweep_segment
    )
    i = res.index(225.0, "C#")
    np.testing.assert_allclose(res.data["bearing_total_rms"][i, :, 1], 225.0 * np.array([1.0, 2.0, 3.0]))
    assert res.get("node_amp_max", i, 2.0)[8] == pytest.approx(225e-6)
    np.testing.assert_allclose(res.force_shares(i, 2.0), [0.0, 0.0, 1.0])
    back = SweepResult.load(res.save(tmp_path / "s.npz"))
    assert back.cases == cases
    np.testing.assert_array_equal(back.data["node_amp_max"], res.data["node_amp_max"])
    with pytest.raises(KeyError, match="not in sweep"):
        res.index(125.0)


# ----------------------------------------------------------------------------------- mesh stiffness scale
def test_mesh_stiffness_scale_static_deflection_and_damping_ratio() -> None:
    """Static mesh force = T2 / r_b2 (hand formula) at every scale; deflection ~ 1/scale; zeta kept."""
    from gear_rotor_sim.system import static_solution

    r_b2 = 49 * 3e-3 / 2 * np.cos(np.radians(20.0))
    force = 200.0 / r_b2  # N, load torque 200 N m on the 49-tooth gear
    base = bif.build_system(Case(25.0))
    scaled = bif.build_system(Case(25.0, overrides=(("mesh_stiffness_scale", 1.34),)))
    m0, m1 = base.meshes[0], scaled.meshes[0]
    assert m1.mean_stiffness == pytest.approx(1.34 * m0.mean_stiffness, rel=1e-12)
    np.testing.assert_allclose(m1.table_stiffness, 1.34 * m0.table_stiffness, rtol=1e-12)
    ph = np.array([0.05, 0.4, 0.9])
    np.testing.assert_allclose(m1.stiffness(ph), 1.34 * m0.stiffness(ph), rtol=1e-12)
    assert m1.damping / np.sqrt(m1.mean_stiffness) == pytest.approx(m0.damping / np.sqrt(m0.mean_stiffness))
    defl = []
    for s in (base, scaled):
        m = s.meshes[0]
        d = float(m.line_of_action @ static_solution(s)) - m.half_backlash
        assert m.mean_stiffness * d == pytest.approx(force, rel=0.02)
        defl.append(d)
    assert defl[1] / defl[0] == pytest.approx(1 / 1.34, rel=0.02)
    with pytest.raises(ValueError, match="mesh_stiffness_scale"):
        bif.scale_mesh_stiffness(base, -1.0)
    with pytest.raises(ValueError, match="overrides"):
        bif.build_config(Case(25.0, overrides=(("stiffness_scale", 1.0),)))


def test_band_vs_scale_figure(tmp_path: Path) -> None:
    from gear_rotor_sim.analysis.figures import plot_band_vs_scale

    rows = [
        {
            "panel": "25C",
            "scale": s,
            "lo": 16000 * s**0.5,
            "hi": 19000 * s**0.5,
            "pred_lo": 16000 * s**0.5,
            "pred_hi": 19000 * s**0.5,
        }
        for s in (0.75, 1.0)
    ] + [{"panel": "25C", "scale": 1.34, "lo": np.nan, "hi": np.nan, "pred_lo": 18500, "pred_hi": 22000}]
    png = plot_band_vs_scale(rows, tmp_path / "b.png", {"25C": (13500.0, 14700.0)})
    assert png.read_bytes()[:4] == b"\x89PNG"


# ----------------------------------------------------------------------------------- CLI bad input
@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["figures", "bifurcation", "--from", "/nonexistent/b.npz", "--out", "x.png"], "does not exist"),
        (["figures", "bifurcation", "--bearing", "Z#", "--out", "x.png"], "--bearing"),
        (["figures", "bifurcation", "--periods", "5", "--out", "x.png"], "--periods"),
        (["figures", "bifurcation", "--steps-per-mesh", "2", "--out", "x.png"], "--steps-per-mesh"),
        (["figures", "bifurcation", "--workers", "0", "--out", "x.png"], "--workers"),
        (["figures", "bifurcation", "--out", "x.pdf"], ".png"),
        (["figures", "orbit", "--speed", "-3", "--out", "x.png"], "--speed"),
        (["figures", "spectrum", "--speed", "1000", "--channel", "nope", "--out", "x.png"], "--channel"),
        (["figures", "phase", "--speed", "1000", "--temperature", "900", "--out", "x.png"], "material range"),
        (["sweep", "--bearings", "Q#", "--out", "s.npz"], "bearings"),
        (["sweep", "--orbit-nodes", "99", "--out", "s.npz"], "--orbit-nodes"),
        (["sweep", "--orbit-nodes", "x", "--out", "s.npz"], "--orbit-nodes"),
    ],
)
def test_cli_bad_input_is_one_clear_line(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from gear_rotor_sim import cli

    argv = [str(tmp_path / a) if a in ("x.png", "x.pdf", "s.npz") else a for a in argv]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert f"gear-rotor-sim {argv[0]}: error:" in err and message in err
    assert "Traceback" not in err


def test_cli_from_a_file_of_the_wrong_kind(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from gear_rotor_sim import cli

    res = run_bifurcation(
        Case(25.0), [300.0], SETTINGS, workers=1, progress=False, segment_fn=_duffing_segment
    )
    path = res.save(tmp_path / "b.npz")
    png = tmp_path / "f.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\n")
    assert cli.main(["figures", "bearing-force", "--from", str(path), "--out", str(tmp_path / "y.png")]) == 2
    assert "not a saved sweep result" in capsys.readouterr().err
    assert cli.main(["figures", "bifurcation", "--from", str(png), "--out", str(tmp_path / "y.png")]) == 2
    assert "not a .npz archive" in capsys.readouterr().err


def test_run_options_keep_the_dt_rule_unless_fixed_steps() -> None:
    import argparse

    from gear_rotor_sim.analysis.sweep_cli import add_run_arguments, settings_from
    from gear_rotor_sim.solver.dt_rule import CONTACT_LOSS_RATE_HZ

    parser = argparse.ArgumentParser()
    add_run_arguments(parser)
    assert settings_from(parser.parse_args([])).contact_loss_rate_hz == CONTACT_LOSS_RATE_HZ
    fixed = settings_from(parser.parse_args(["--fixed-steps", "--steps-per-mesh", "48"]))
    assert fixed.contact_loss_rate_hz is None and fixed.steps_per_mesh == 48
