"""The gear kernel's output rows and its unforced modes (session 24, docs/history/solver_sessions.md).

``NewmarkStepper.run(excitation_rows=False)`` (what the ``Simulator`` passes) writes delta' and the
excitation arrays at the chunk's last step only: the stream, the mesh force, the states and the
carried state must be those of the run that writes every row. The regular step skips the unforced
modes while they are exactly zero; a non-zero amplitude there must still propagate as the free
modal map says, ``z_n = r^n z_0 + c0 (1 - r^n) / (1 - r)``.
"""

from __future__ import annotations

import numpy as np

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator


def _settled(rpm: float) -> tuple[Simulator, tuple[np.ndarray, ...]]:
    sim = Simulator(paper_gearbox(), rpm, 25.0, 20000.0, channels=["dte", "mesh_force", "bearing1_fx"])
    sim.advance(0.1)
    stp = sim._stepper
    carried = (stp.zr, stp.zi, stp.beta_act, stp.ypred, stp.contact)
    return sim, tuple(a.copy() for a in carried)


def _run(sim: Simulator, saved: tuple[np.ndarray, ...], n: int, rows: bool) -> tuple:
    stp = sim._stepper
    for a, s in zip((stp.zr, stp.zi, stp.beta_act, stp.ypred, stp.contact), saved, strict=True):
        a[...] = s
    st = sim._state.copy()
    omega = sim.speed_rpm * 2.0 * np.pi / 60.0
    j = np.arange(-1, n + 1, dtype=float)
    t = st.time + j * sim.dt
    out = stp.run(t, st.angle + omega * (t - st.time), np.full(j.size, omega), st, excitation_rows=rows)
    return out, st, stp.zr.copy(), stp.zi.copy()


def test_last_rows_only_keep_the_stream_at_20000_rpm() -> None:
    sim, saved = _settled(20000.0)
    sim._stepper.locate_events = True  # the event steps (the dt rule locates them once it saw a loss)
    (ch, dte, dted, fm, states, exc), st, zr, zi = _run(sim, saved, 3000, True)
    (ch1, dte1, dted1, fm1, states1, exc1), st1, zr1, zi1 = _run(sim, saved, 3000, False)
    assert np.count_nonzero(states == 0) > 100  # contact loss inside the compared steps
    for a, b in ((ch, ch1), (fm, fm1), (states, states1), (zr, zr1), (zi, zi1)):
        assert np.array_equal(a, b)
    assert dted1.shape[0] == 1 and exc1[0].shape[0] == 1 and exc1[3].shape[0] == 1
    for a, b in ((dte, dte1), (dted, dted1), *zip(exc[:4], exc1[:4], strict=True)):
        assert np.array_equal(a[-1], b[-1])
    for k in ("delta", "delta_dot", "force", "coef", "contact", "x"):
        assert np.array_equal(getattr(st, k), getattr(st1, k)), k


def test_unforced_modes_propagate_when_not_zero() -> None:
    sim, saved = _settled(3000.0)
    gm = sim._stepper.gear
    assert gm is not None
    nf, nmode = gm.n_forced, saved[0].shape[0]
    assert nf < nmode
    rr, ri, c0r, c0i = gm.modal[:4]
    j = nf + (nmode - nf) // 2
    z0 = 1e-9 * (1.0 + 0.5j)
    saved[0][j], saved[1][j] = z0.real, z0.imag
    n = 2000
    _, _, zr, zi = _run(sim, saved, n, False)
    r = complex(rr[j], ri[j])
    c0 = complex(c0r[j], c0i[j])
    expect = r**n * z0 + c0 * (1.0 - r**n) / (1.0 - r)
    assert abs(r**n) < 0.999 or abs(np.angle(r**n)) > 1e-3  # the map moves it: a skipped mode would fail
    assert abs(complex(zr[j], zi[j]) - expect) <= 1e-9 * abs(z0)
    # the motion does not read the unforced modes: the forced ones are those of the run without it
    saved[0][j] = saved[1][j] = 0.0
    _, _, zr0, zi0 = _run(sim, saved, n, False)
    assert np.array_equal(zr[:nf], zr0[:nf]) and np.array_equal(zi[:nf], zi0[:nf])
