"""The streaming simulator's misaligned gear: the axial force from its own mesh force
(faults/misalignment_stream.py).

Truths used: the static limit (the order-1 line of the axial bearing reactions on the tilted wheel's
shaft is ``F0 angle / 2`` with ``F0 = T / r_b`` computed by hand: far below the axial modes the
bearings carry the axial mesh force), the calibration's fixed-point pass (``with_mesh_force``: least
squares over whole hunting periods of a separate run, another estimator of the same quantity), zero
tilt (no axial force), the equality of the library effect and the timed fault of constant severity
(docs/faults.md), the independence of the stream from how ``advance`` is called.
"""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.faults import GearMisalignment
from gear_rotor_sim.faults.misalignment_force import (
    simulate_mesh_force,
    wheel_hz,
    wheel_orders,
    with_mesh_force,
)
from gear_rotor_sim.faults.misalignment_stream import STREAM_BINS, STREAM_MEMORY_S, SynchronousMeshForce
from gear_rotor_sim.faults.spec import parse_faults
from gear_rotor_sim.faults.timed import timed_effects
from gear_rotor_sim.simulator import Simulator

FS = 20000.0
ANGLE, PHASE = 1e-3, 0.2
#: the gear shaft's bearings of the paper gearbox (nodes 10 and 18) and the pinion shaft's
GEAR_SHAFT_FZ = ["bearing3_fz", "bearing4_fz"]


@pytest.fixture(scope="module")
def cfg():
    return paper_gearbox()


def _f0(cfg) -> float:
    """Static mesh force ``T / r_b`` by hand: the load torque over the gear's base radius
    ``m z cos(alpha) / 2``."""
    m = cfg.meshes[0]
    return cfg.load.torque_nm / (m.module_m * m.gear_teeth * np.cos(m.pressure_angle_rad) / 2.0)


def _calibration_orders(cfg, speed_rpm: float) -> np.ndarray:
    run = simulate_mesh_force(cfg, speed_rpm, 25.0, min_window_s=0.3)
    (e1,) = with_mesh_force(cfg, (GearMisalignment(angle_rad=ANGLE, phase_rad=PHASE),), speed_rpm, FS, run)
    return np.asarray(e1.mesh_force_orders)


def test_synchronous_average_recovers_a_known_series():
    """The binned running average returns the order coefficients of a synthetic force sampled off the
    revolution's grid (the binning's sinc^2 divided out), and drops a line not synchronous with it."""
    avg = SynchronousMeshForce(mesh=0, shaft=1, ratio=-0.5918)
    f_in = 50.0  # input-shaft Hz
    rate = 61234.5  # steps per second, incommensurate with the wheel
    t = np.arange(round(1.5 * rate)) / rate
    ang = 2 * np.pi * f_in * t
    th = avg.ratio * ang
    c = {0: 2900.0, 49: 40 - 25j, 98: 12 + 5j, 147: -200 + 30j, 200: 3.0j}
    x = np.full(t.size, c[0])
    for k, ck in c.items():
        if k:
            x += 2 * np.real(ck * np.exp(1j * k * th))
    x += 30.0 * np.cos(2 * np.pi * 29 * f_in * 1.5 * t)  # between the wheel's orders
    for i in range(15):
        sl = slice(i * t.size // 15, (i + 1) * t.size // 15)
        avg.push(ang[sl], x[sl, None])
        got = avg.update(avg.ratio * f_in, 20000.0, 0.1)
    assert got is not None and got.size == int(0.4 * 20000.0 / abs(avg.ratio * f_in)) + 1
    want = np.zeros(got.size, dtype=complex)
    for k, ck in c.items():
        want[k] = ck
    # the binning (4096 bins, sinc^2 divided out): 0.1 % of the largest order; the off-order line (at
    # order 73.5) leaks into order k as its exponentially weighted average: half its amplitude over
    # 2 pi |k - 73.5| f_wheel STREAM_MEMORY_S (x1.5: the weights are steps of one update interval)
    k = np.arange(got.size)
    leak = 1.5 * 15.0 / (2 * np.pi * np.abs(k - 73.5) * abs(avg.ratio * f_in) * STREAM_MEMORY_S)
    err = np.abs(got - want)
    assert err[0] <= 1e-6 * c[0]
    assert (err[1:] <= 1e-3 * 200.0 + leak[1:]).all(), np.max(err[1:] / (1e-3 * 200.0 + leak[1:]))
    assert err[[49, 98, 147, 200]].max() <= 0.01 * 40.0  # the mesh orders, far from the line
    assert STREAM_BINS >= 8 * (got.size - 1)


def test_steady_stream_matches_the_static_limit_and_the_calibration_pass(cfg):
    """3000 rpm, 1 mrad on the gear: after 1 s the stream's orders equal the calibration's fixed-point
    pass (a separate run, least squares over a hunting period); the axial bearing reactions of the gear
    shaft have the order-1 line ``F0 angle / 2`` (static limit, by hand) and mesh sidebands equal to
    those of a run with the calibration pass's orders."""
    speed = 3000.0
    f0 = _f0(cfg)
    cal = _calibration_orders(cfg, speed)
    e = GearMisalignment(angle_rad=ANGLE, phase_rad=PHASE)
    fg = wheel_hz(cfg, e, speed)
    hunting = 49 / (speed / 60.0)  # 49 pinion revolutions = 29 gear revolutions (29 / 49 teeth)
    n = round(hunting * FS)
    lines = {}
    for name, eff in (
        ("stream", e),
        ("calibration", GearMisalignment(ANGLE, PHASE, mesh_force_orders=tuple(cal))),
    ):
        sim = Simulator(cfg, speed, 25.0, FS, channels=GEAR_SHAFT_FZ, effects=(eff,))
        assert sim.mesh_force_orders == ({"gear_misalignment": ()} if name == "stream" else {})
        sim.advance(1.0)
        if name == "stream":
            got = np.asarray(sim.mesh_force_orders["gear_misalignment"])
            assert got.size == cal.size  # the same passband edge
            assert abs(got[0] - cal[0]) <= 1e-3 * f0  # measured 6e-6
            for m in (1, 2, 3, 4, 5):  # the mesh harmonics: measured within 0.02 %
                assert abs(got[49 * m] - cal[49 * m]) <= 0.01 * abs(cal[49 * m]), m
            # other orders: leakage of lines between the wheel's orders (measured 2.8 N = 0.1 % F0)
            assert np.abs(got - cal).max() <= 3e-3 * f0
        blk = sim.advance(n / FS)
        t = (blk.first_index + np.arange(blk.data.shape[0])) / FS
        lines[name] = wheel_orders(t, blk.data.sum(axis=1), fg, 110)
    s, c = lines["stream"], lines["calibration"]
    # static limit: measured +0.61 % (+0.36 % the mean mesh force above T / r_b: tooth friction)
    assert abs(abs(s[1]) - f0 * ANGLE / 2) <= 0.01 * f0 * ANGLE / 2
    for k in (48, 50, 97, 99):  # the sidebands: in contact ~0.5 % of the order-1 line
        assert abs(s[k]) > 1e-3 * abs(s[1])
        assert abs(s[k] - c[k]) <= 0.01 * abs(c[k]), k  # measured 0.02 %


def test_zero_tilt_gives_no_axial_force_and_no_stream(cfg):
    healthy = Simulator(cfg, 3000.0, 25.0, FS, channels=GEAR_SHAFT_FZ).advance(0.25).data
    sim = Simulator(cfg, 3000.0, 25.0, FS, channels=GEAR_SHAFT_FZ, effects=(GearMisalignment(angle_rad=0.0),))
    data = sim.advance(0.25).data
    assert sim.mesh_force_orders == {}
    np.testing.assert_array_equal(data, healthy)
    tilted = Simulator(cfg, 3000.0, 25.0, FS, channels=GEAR_SHAFT_FZ, effects=(GearMisalignment(ANGLE),))
    assert np.ptp(tilted.advance(0.25).data[:, 0]) > 1e3 * max(np.ptp(healthy[:, 0]), 1e-12)


def test_timed_fault_equals_the_effect_whatever_the_chunking(cfg):
    """``record --faults`` / the node (a TimedEffect at constant severity) equal the library effect in
    the stream, advanced in one call or in odd pieces (to the last bits); the running average survives a new
    fault list holding the same tilted wheel."""
    e = GearMisalignment(angle_rad=ANGLE, phase_rad=PHASE)
    a = Simulator(cfg, 3000.0, 25.0, FS, channels=["bearing3_fz", "mesh_force"], effects=(e,))
    ref = a.advance(0.45).data
    entry = {"type": "gear_misalignment", "member": "gear", "angle_rad": ANGLE, "phase_rad": PHASE}
    timed = timed_effects(parse_faults([entry]))
    b = Simulator(cfg, 3000.0, 25.0, FS, channels=["bearing3_fz", "mesh_force"], effects=timed)
    parts = [b.advance(d).data for d in (0.037, 0.1, 0.0131, 0.2, 0.0999)]
    got = np.vstack(parts)[: ref.shape[0]]
    assert got.shape == ref.shape
    # the chunking alone changes the last bits of the healthy stream (a chunk's matrix products): the
    # bound of test_faults.py's same-process runs, relative to each channel's magnitude
    scale = np.abs(ref).max(axis=0)
    assert (np.abs(got - ref).max(axis=0) <= 1e-12 * scale).all(), np.abs(got - ref).max(axis=0) / scale
    before = b.mesh_force_orders["gear_misalignment"]
    np.testing.assert_allclose(
        before, a.mesh_force_orders["gear_misalignment"], rtol=0, atol=1e-12 * abs(before[0])
    )
    b.set_effects(timed_effects(parse_faults([entry])))
    assert b.mesh_force_orders["gear_misalignment"] == before


def test_ramp_stays_finite_and_converges(cfg):
    """3000 -> 4000 rpm at 2000 rpm/s: the stream stays finite, the orders follow the speed's passband,
    and 1.2 s after the ramp they equal the calibration pass at 4000 rpm."""
    speed1 = 4000.0
    e = GearMisalignment(angle_rad=ANGLE, phase_rad=PHASE)
    sim = Simulator(cfg, 3000.0, 25.0, FS, channels=GEAR_SHAFT_FZ, effects=(e,))
    sim.advance(0.3)
    sim.set_targets(speed_rpm=speed1)
    ramp = sim.advance(0.5).data
    assert np.isfinite(ramp).all()
    tail = sim.advance(1.2).data
    assert np.isfinite(tail).all()
    got = np.asarray(sim.mesh_force_orders["gear_misalignment"])
    cal = _calibration_orders(cfg, speed1)
    f0 = _f0(cfg)
    assert got.size == cal.size
    assert abs(got[0] - cal[0]) <= 1e-3 * f0
    for m in (1, 2, 3):
        assert abs(got[49 * m] - cal[49 * m]) <= 0.02 * abs(cal[49 * m]), m


def test_static_force_until_the_first_update_and_without_the_stream(cfg):
    """Until the first update (0.1 s) the streamed effect is the static law ``F0`` (bit for bit the run
    with ``streamed_misalignment=False``, the calibration's setting); from it on the axial force
    follows the mesh force."""
    e = GearMisalignment(angle_rad=ANGLE, phase_rad=PHASE)
    kw = dict(channels=GEAR_SHAFT_FZ, effects=(e,))
    on = Simulator(cfg, 3000.0, 25.0, FS, **kw).advance(0.3).data
    off_sim = Simulator(cfg, 3000.0, 25.0, FS, streamed_misalignment=False, **kw)
    off = off_sim.advance(0.3).data
    assert off_sim.mesh_force_orders == {}
    first = round(0.1 * FS) - 30  # the decimation filter's half length before the update's effect
    np.testing.assert_array_equal(on[:first], off[:first])
    scale = np.abs(off).max()
    assert np.abs(on[round(0.15 * FS) :] - off[round(0.15 * FS) :]).max() > 1e-3 * scale
    with pytest.raises(ValueError, match="streamed_misalignment"):
        Simulator(cfg, 3000.0, 25.0, FS, streamed_misalignment=1)  # type: ignore[arg-type]
