"""Streaming simulator: continuity, ramps, decimation, effects hook, bad input (independent truths)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from scipy.signal import freqz
from test_solver import make_system

from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.solver.decimate import design_taps
from gear_rotor_sim.solver.newmark import LinearModel, quantize_speed_rpm
from gear_rotor_sim.system_data import AssembledSystem


def _builder(**kw: object):
    def build(cfg: object, temperature_c: float) -> AssembledSystem:
        if not 0.0 <= temperature_c <= 300.0:
            raise ValueError(f"temperature_c: {temperature_c} is outside the material range 0..300 C")
        return make_system(temperature_c=temperature_c, **kw)  # type: ignore[arg-type]

    return build


def test_two_chunks_equal_one_run() -> None:
    a = Simulator(None, 3000.0, 25.0, 20000.0, system_builder=_builder())
    b = Simulator(None, 3000.0, 25.0, 20000.0, system_builder=_builder())
    x = np.concatenate([a.advance(0.1).data, a.advance(0.1).data])
    y = b.advance(0.2).data
    assert x.shape == y.shape == (4000, 16)
    assert np.max(np.abs(x - y) / (np.max(np.abs(y), axis=0) + 1e-300)) < 1e-12


def test_deferred_blocks_resolved_in_another_thread_equal_advance() -> None:
    """``advance_deferred`` with ``result()`` run in a second thread while the next chunk integrates
    (what the node does) gives the blocks of ``advance``, bit for bit, through a speed ramp that
    changes the decimation factor; index and length are known before the filtering; out-of-order
    resolution is refused."""
    import concurrent.futures

    kw = dict(channels=["dte", "bearing1_fx"], speed_ramp_rpm_per_s=20000.0, system_builder=_builder())
    a = Simulator(None, 2000.0, 25.0, 20000.0, **kw)
    b = Simulator(None, 2000.0, 25.0, 20000.0, **kw)
    durations = (0.02, 0.031, 0.0, 0.05, 0.05, 0.07, 0.05)
    ref, factors = [], set()
    for i, d in enumerate(durations):
        if i == 2:
            a.set_targets(speed_rpm=4000.0)
        ref.append(a.advance(d))
        factors.add(a.last_chunk_stats["decimation"])
    futures, pendings = [], []
    with concurrent.futures.ThreadPoolExecutor(max_workers=1) as pool:
        for i, d in enumerate(durations):
            if i == 2:
                b.set_targets(speed_rpm=4000.0)
            p = b.advance_deferred(d)
            assert (p.first_index, p.n_samples) == (ref[i].first_index, ref[i].n_samples)
            pendings.append(p)
            futures.append(pool.submit(p.result))
        blocks = [f.result() for f in futures]
    assert len(factors) > 1 and b.time_s == a.time_s  # the ramp changed the decimation factor
    for x, y in zip(blocks, ref, strict=True):
        assert x.t0 == y.t0 and x.channels == y.channels
        assert np.array_equal(x.data, y.data)
        assert np.array_equal(x.speed_rpm, y.speed_rpm) and np.array_equal(x.temperature_c, y.temperature_c)
    assert pendings[0].result() is blocks[0]  # resolved once
    late, early = b.advance_deferred(0.01), b.advance_deferred(0.01)
    with pytest.raises(ValueError, match="next one is"):
        early.result()
    assert late.result().n_samples == early.result().n_samples == 200


def test_speed_ramp_has_no_discontinuity() -> None:
    sim = Simulator(
        None,
        2000.0,
        25.0,
        20000.0,
        channels=["dte", "bearing1_fx"],
        speed_ramp_rpm_per_s=20000.0,
        system_builder=_builder(stiffness_amp=0.0, te_amplitude=2e-6, half_backlash=0.0),
    )
    sim.advance(0.05)
    sim.set_targets(speed_rpm=4000.0)
    blk = sim.advance(0.15)
    assert blk.speed_rpm[-1] == pytest.approx(4000.0, rel=1e-9)
    assert sim.last_chunk_stats["decimation"] >= 2
    d = np.diff(blk.channel("dte"))
    # many basis switches (0.25 % speed quanta) and decimation changes happened during the ramp; the
    # largest sample-to-sample step is bounded by the signal's own slope (a steady harmonic of the same
    # amplitude at the top speed: 2 * A * sin(pi f / fs))
    amp = np.max(np.abs(blk.channel("dte") - np.mean(blk.channel("dte"))))
    f_top = 20 * 4000 / 60
    assert np.max(np.abs(d)) < 1.2 * 2 * amp * np.sin(np.pi * f_top / 20000.0)
    # the speed column follows the ramp (symmetric FIR of a linear ramp; the raw-history regrid at a
    # decimation change perturbs it by a fraction of one sample's increment)
    ramp = blk.speed_rpm[(blk.speed_rpm > 2100) & (blk.speed_rpm < 3900)]
    assert np.max(np.abs(np.diff(ramp) - 1.0)) < 0.2


def test_held_set_points_come_out_exactly() -> None:
    """The speed and temperature columns are the set-points themselves wherever they were held over
    the filter's window (not the filter's unit-DC-gain sum, within round-off of them); through a
    speed ramp they follow the ramp (a symmetric FIR passes a linear ramp unchanged)."""
    sim = Simulator(
        None, 3000.0, 25.0, 20000.0, channels=["dte"], speed_ramp_rpm_per_s=20000.0, system_builder=_builder()
    )
    a = sim.advance(0.05)
    assert np.all(a.speed_rpm == 3000.0) and np.all(a.temperature_c == 25.0)
    sim.set_targets(speed_rpm=3100.0)  # a 5 ms ramp from the integration time
    t_ramp = sim._speed.t0
    b = sim.advance(0.2)
    assert np.all(b.temperature_c == 25.0)
    t = b.t0 + np.arange(b.n_samples) / b.sample_rate_hz
    assert np.all(b.speed_rpm[t < t_ramp - 0.002] == 3000.0)
    assert np.all(b.speed_rpm[t > t_ramp + 0.1] == 3100.0)
    mid = (t > t_ramp + 0.002) & (t < t_ramp + 0.003)  # the filter's window inside the ramp
    assert np.count_nonzero(mid) >= 19
    assert np.max(np.abs(b.speed_rpm[mid] - (3000.0 + 20000.0 * (t[mid] - t_ramp)))) < 1e-9 * 3100.0


def test_kept_chunk_arrays_give_the_same_stream_without_new_pages() -> None:
    """The simulator's per-chunk work arrays are kept across chunks (``newmark.ChunkBuffers``): the
    stream is bit for bit the one with arrays allocated per chunk, and at 20000 rpm (chunks of about
    16000-32000 steps) the process maps almost no new pages (measured: 62 minor faults per
    simulated second kept, 5058 allocated per chunk; docs/solver.md, "Session 10")."""
    import resource

    from gear_rotor_sim.examples import paper_gearbox

    kept = Simulator(paper_gearbox(), 20000.0, 25.0, 20000.0, channels=["dte"])
    fresh = Simulator(paper_gearbox(), 20000.0, 25.0, 20000.0, channels=["dte"])
    fresh._chunk_buffers = None  # type: ignore[assignment]
    for _, st in fresh._systems.values():
        st.chunk_buffers = None
    a = np.concatenate([kept.advance(0.1).data, kept.advance(0.1).data])
    b = np.concatenate([fresh.advance(0.1).data, fresh.advance(0.1).data])
    assert np.array_equal(a, b)
    kept.advance(0.2)  # the decimator's store and the kept arrays reach the size of these chunks
    f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    kept.advance(0.2)
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0
    steps = 0.2 * 20000.0 * kept._k
    assert faults < steps / 1000.0  # one new page per 1000 steps at most (allocated per chunk: 1 per 63)


def test_event_average_removes_the_mesh_force_alias_at_20000_rpm() -> None:
    """At 20000 rpm (33.1 steps per mesh period, f_raw = 320 kHz) the end-of-step samples of the mesh
    force fold its 33rd harmonic to 1000 Hz, as large as the mesh line itself (docs/solver.md,
    "Session 10"); with ``event_average`` (the default) the line is gone to a tenth of the mesh line,
    against the same model at 1024 located steps per mesh period (truth: no fold there), through the
    mesh-channel path and the output product alike. Without located events (3000 rpm, contact)
    nothing changes."""
    from gear_rotor_sim.examples import paper_gearbox

    def stream(rpm: float, channels: list[str], **kw: object) -> np.ndarray:
        sim = Simulator(paper_gearbox(), rpm, 25.0, 20000.0, channels=channels, **kw)  # type: ignore[arg-type]
        return np.concatenate([np.asarray(sim.advance(0.1).data) for _ in range(4)])[6000:]

    def line(x: np.ndarray, hz: float) -> float:
        a = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(x.size))) * 4.0 / x.size
        f = np.fft.rfftfreq(x.size, 1.0 / 20000.0)
        return float(a[np.abs(f - hz) <= 12.0].max())

    ref = stream(
        20000.0,
        ["mesh_force"],
        steps_per_mesh=1024,
        contact_loss_rate_hz=None,
        locate_events=True,
        event_average=False,
    )
    mesh_line = line(ref[:, 0], 9666.7)
    assert line(ref[:, 0], 1000.0) < 0.02 * mesh_line
    folded = stream(20000.0, ["mesh_force"], event_average=False)[:, 0]
    assert line(folded, 1000.0) > 0.5 * mesh_line  # end-of-step samples: the fold
    for channels in (["mesh_force"], ["mesh_force", "bearing1_fx"]):
        y = stream(20000.0, channels)[:, 0]  # the default
        assert line(y, 1000.0) < 0.1 * mesh_line
        assert abs(line(y, 9666.7) / mesh_line - 1.0) < 0.05
        assert abs(y.std() / ref[:, 0].std() - 1.0) < 0.05  # 1.57 as it is
    a = stream(3000.0, ["dte", "mesh_force", "bearing1_fx"], event_average=False)
    b = stream(3000.0, ["dte", "mesh_force", "bearing1_fx"])
    assert np.array_equal(a, b)


def test_quasi_static_start_stays_at_static_solution() -> None:
    sys_ = make_system(stiffness_amp=0.0, te_amplitude=0.0, half_backlash=3e-6, load_torque=40.0)
    sim = Simulator(
        None,
        0.0,
        25.0,
        2000.0,
        channels=["dte", "bearing2_fy"],
        system_builder=_builder(stiffness_amp=0.0, te_amplitude=0.0, half_backlash=3e-6, load_torque=40.0),
    )
    blk = sim.advance(0.05)
    mc = sys_.meshes[0]
    free = sys_.free_dofs
    v = mc.line_of_action[free]
    kk = sys_.K[np.ix_(free, free)] + mc.mean_stiffness * np.outer(v, v)
    q = np.linalg.solve(kk, sys_.static_load[free] + mc.mean_stiffness * mc.half_backlash * v)
    assert np.max(np.abs(blk.channel("dte") - v @ q)) < 1e-9 * abs(v @ q)


def test_anti_aliasing_filter_meets_spec() -> None:
    for k in (2, 5, 16):
        h = design_taps(k)
        w, r = freqz(h, worN=1 << 15, fs=float(k))  # frequency in units of the output rate
        db = 20 * np.log10(np.abs(r) + 1e-300)
        assert np.max(db[w >= 0.5]) < -80.0
        assert np.max(np.abs(db[w <= 0.4])) < 0.01
        assert (h.size - 1) % k == 0 and ((h.size - 1) // 2) % 1 == 0


@dataclass
class Unbalance:
    """m e Omega^2 rotating force at one node (input shaft)."""

    node0: int
    me: float
    name: str = "unbalance"

    def external_forces(self, system: AssembledSystem) -> np.ndarray:
        cols = np.zeros((system.ndof, 2))
        cols[6 * self.node0, 0] = 1.0
        cols[6 * self.node0 + 1, 1] = 1.0
        return cols

    def force_amplitudes(self, ctx) -> np.ndarray:
        th = ctx.shaft_angle[:, 0]
        w = ctx.shaft_speed[:, 0]
        return self.me * w[:, None] ** 2 * np.column_stack([np.cos(th), np.sin(th)])


def test_unbalance_effect_matches_harmonic_response() -> None:
    kw = {"with_mesh": False, "damping": 5.0}
    eff = Unbalance(1, 1e-4)
    fout = 5000.0
    rpm = 3000.0
    sim = Simulator(
        None, rpm, 25.0, fout, channels=["node2_x", "node2_y"], effects=(eff,), system_builder=_builder(**kw)
    )
    sim.advance(3.0)
    blk = sim.advance(0.2)
    sys_ = make_system(**kw)
    lin = LinearModel(sys_)
    w = rpm * 2 * np.pi / 60
    om_q = quantize_speed_rpm(rpm) * 2 * np.pi / 60
    h = lin.K - w**2 * lin.M + 1j * w * (lin.C + om_q * lin.G)
    f = eff.me * w**2 * (eff.external_forces(sys_)[sys_.free_dofs] @ np.array([1.0, -1j]))  # cos, sin
    x = np.linalg.solve(h, f)
    p = lin.pos[6 * 1]
    exact = (x[p] * np.exp(1j * w * blk.time)).real
    rel = np.sqrt(np.mean((blk.channel("node2_x") - exact) ** 2)) / np.sqrt(np.mean(exact**2))
    assert rel < 5e-3


def test_bad_input_is_refused_with_field_names() -> None:
    b = _builder()
    with pytest.raises(ValueError, match="speed_rpm"):
        Simulator(None, float("nan"), system_builder=b)
    with pytest.raises(ValueError, match="speed_rpm"):
        Simulator(None, -1.0, system_builder=b)
    with pytest.raises(ValueError, match="temperature_c"):
        Simulator(None, 1000.0, 400.0, system_builder=b)
    with pytest.raises(ValueError, match="output_rate_hz"):
        Simulator(None, 1000.0, 25.0, 1e9, system_builder=b)
    with pytest.raises(ValueError, match="steps_per_mesh"):
        Simulator(None, 1000.0, 25.0, steps_per_mesh=4, system_builder=b)
    with pytest.raises(ValueError, match="channels"):
        Simulator(None, 1000.0, 25.0, channels=["node99_x"], system_builder=b)
    sim = Simulator(None, 1000.0, 25.0, system_builder=b)
    with pytest.raises(ValueError, match="temperature_c"):
        sim.set_targets(temperature_c=-50.0)
    with pytest.raises(ValueError, match="speed_rpm"):
        sim.set_targets(speed_rpm=float("inf"))
    with pytest.raises(ValueError, match="duration"):
        sim.advance(-1.0)
