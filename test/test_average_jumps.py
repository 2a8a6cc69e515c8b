"""``Simulator(average_table_jumps=True)``: table-jump steps taken whole with the step's average tables.

Truths: the same model at 1024 located steps per mesh period (converged: the errors below shrink
with the step at second order), and the stream's independence of the chunking.
"""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator

CHANNELS = ["dte", "bearing4_fx"]
WINDOW = slice(4000, 6000)  # 0.2-0.3 s at 20 kHz


def _run(rpm: float, steps: int, average: bool, duration: float = 0.3) -> tuple[np.ndarray, int]:
    sim = Simulator(
        paper_gearbox(),
        rpm,
        25.0,
        20000.0,
        channels=CHANNELS,
        steps_per_mesh=steps,
        contact_loss_rate_hz=None,
        locate_events=True,
        average_table_jumps=average,
    )
    data = np.asarray(sim.advance(duration).data)
    return data, sim._stepper.n_substeps


@pytest.fixture(scope="module")
def reference_3000() -> np.ndarray:
    return _run(3000.0, 1024, False)[0][WINDOW]


def _wave(y: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """RMS of the difference in % of the reference's fluctuating RMS, per channel."""
    return 100.0 * np.sqrt(np.mean((y[WINDOW] - ref) ** 2, axis=0)) / ref.std(axis=0)


def test_averaged_jump_steps_converge_like_located_ones(reference_3000):
    """3000 rpm (teeth in contact, 3 table jumps per mesh period): at 64 and 128 steps per mesh period
    the averaged steps' DTE and bearing force are as close to the converged reference as the located
    sub-steps' (measured 0.585 / 0.615 % and 4.08 / 4.15 % at 64 steps), second order (the error falls
    by 2.9 and 4.3 from 64 to 128), with next to no sub-steps."""
    e = {}
    for steps in (64, 128):
        for avg in (False, True):
            y, nsub = _run(3000.0, steps, avg)
            e[(steps, avg)] = _wave(y, reference_3000)
            if avg:
                assert nsub < 20  # located: about 2600 in 0.3 s (one per table jump)
            else:
                assert nsub > 2000
    for steps in (64, 128):
        assert (e[(steps, True)] <= 1.1 * e[(steps, False)]).all(), (
            steps,
            e[(steps, True)],
            e[(steps, False)],
        )
    assert (e[(64, True)] / e[(128, True)] > 2.5).all(), e[(64, True)] / e[(128, True)]
    assert e[(64, True)][0] < 1.0  # the DTE within 1 % of its fluctuating RMS


def test_with_contact_loss_the_rms_holds_and_chunks_do_not_matter():
    """7000 rpm: the teeth separate every mesh period, so jump steps also meet contact changes (the
    full step finds them and falls back to the sub-steps). The RMS DTE at 64 steps stays within 0.5 %
    of 512 steps (located), and two chunks equal one run to round-off."""
    cfg = paper_gearbox()

    def rms(steps: int, avg: bool) -> float:
        sim = Simulator(
            cfg, 7000.0, 25.0, 20000.0, channels=["dte"], steps_per_mesh=steps, contact_loss_rate_hz=None,
            locate_events=True, average_table_jumps=avg,
        )  # fmt: skip
        return float(np.sqrt(np.mean(np.asarray(sim.advance(0.3).data)[WINDOW] ** 2)))

    ref = rms(512, False)
    assert abs(rms(64, True) / ref - 1.0) < 0.005
    kw = dict(channels=["dte", "mesh_force"], locate_events=True, average_table_jumps=True)
    a = Simulator(cfg, 7000.0, 25.0, 20000.0, **kw)
    b = Simulator(cfg, 7000.0, 25.0, 20000.0, **kw)
    x = np.concatenate([a.advance(0.05).data, a.advance(0.05).data])
    y = b.advance(0.1).data
    assert a._stepper.n_substeps > 0  # contact changes are still located
    assert np.max(np.abs(x - y) / np.max(np.abs(y), axis=0)) < 1e-12


def test_average_table_jumps_rejects_non_bool():
    with pytest.raises(ValueError, match="average_table_jumps"):
        Simulator(paper_gearbox(), 3000.0, 25.0, 20000.0, average_table_jumps="yes")  # type: ignore[arg-type]
