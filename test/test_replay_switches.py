"""Fault switches with ``Simulator(periodic_replay=...)`` as the node makes them (docs/solver.md, "Periodic
replay at steady state", "Faults"; benchmarks/replay_switches.py).

``test_faults_node.py::test_node_signal_equals_library_effects_in_the_simulator`` holds the node
(replay on, faults as ``timed_effects``, a new fault list at a chunk start) to the ``Simulator``
*without* the option at 1e-9 of each channel's peak; session 21's admission of faults into the replay
failed it in CI (0.7-3.4 %). At 3000 rpm a step of the 29-tooth pinion's step grid lands exactly on
the mesh table's jump at phase 0 every 29 mesh periods, and on which side of it the step lies is
decided by the angle's round-off: with an eccentric gear or a misaligned shaft the plain integration
itself moves by 1e-2 of its peak when its start angle moves by 1e-13 rad (``replay_switches.py jump``),
and the replay's periodic angles move it likewise. So ``periodic_replay=True`` integrates a set point
with faults (the node's default, held to the plain integration here), and ``"faults"`` replays them,
held to its own integration (the same periodic angles, serving off).
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from replay_switches import CHUNK_S, FAULTS, chunk_errors, node_like_run

from gear_rotor_sim.simulator_replay import PeriodicReplay

#: The node test's bound, of each channel's peak.
NODE_BOUND = 1e-9
#: Where the replay is exact to round-off: of each channel's fluctuating RMS.
RMS_BOUND = 1e-6
N_CHUNK = int(CHUNK_S * 20000)

#: A mass unbalance, a misaligned shaft (a change), the healthy gearbox (a removal), an eccentric gear
#: (an onset), 3000 rpm; with ``"faults"`` every switch falls inside an engaged replay.
PLAN = [
    (FAULTS["mass_unbalance"], 9),
    (FAULTS["shaft_misalignment"], 9),
    (FAULTS["healthy"], 9),
    (FAULTS["gear_eccentricity"], 4),
]


def _rms_errors(node: np.ndarray, ref: np.ndarray, plan: list) -> np.ndarray:
    """Per interval of ``plan`` and channel: RMS of the difference over the reference's fluctuating RMS
    in that interval."""
    edges = np.cumsum([0] + [c for _, c in plan]) * N_CHUNK
    out = []
    for lo, hi in itertools.pairwise(edges):
        d = node[lo:hi] - ref[lo:hi]
        out.append(np.sqrt(np.mean(d**2, axis=0)) / np.std(ref[lo:hi], axis=0))
    return np.array(out)


def test_node_default_follows_the_plain_integration() -> None:
    """The node's default (``periodic_replay=True``): the faults integrated, the healthy interval
    replayed and the eccentric gear switched on inside it; the stream equals the plain integration
    within the node test's bound in every chunk and within 1e-6 of each channel's fluctuating RMS per
    interval (measured 5.3e-11 of the peak; session 21's admission of faults: 4.3e-2 in the chunk after
    the eccentric gear's switch)."""
    node, plain, info = node_like_run(PLAN)
    ends = np.cumsum([c for _, c in PLAN])
    assert [info[e - 1][1] for e in ends[:-1]] == [False, False, True], info
    assert info[-1][2] == 1
    assert chunk_errors(node, plain, N_CHUNK).max() <= NODE_BOUND
    rms = _rms_errors(node, plain, PLAN)
    assert rms.max() < RMS_BOUND, rms


def test_faults_switched_inside_an_engaged_replay() -> None:
    """``"faults"``: every switch of :data:`PLAN` (a change, a removal, an onset) falls inside an engaged
    replay; the stream follows the same option's integration within 1e-6 of each channel's fluctuating
    RMS per interval."""
    node, ref, info = node_like_run(PLAN, replay="faults", same_reference=True)
    ends = np.cumsum([c for _, c in PLAN])
    assert all(info[e - 1][1] for e in ends[:-1]), info  # served at each switch
    assert info[-1][2] == 3
    rms = _rms_errors(node, ref, PLAN)
    assert rms.max() < RMS_BOUND, rms


def test_a_timed_onset_starts_a_new_history() -> None:
    """``"faults"``: a pinion tooth whose onset falls 0.35 s after its list is applied (the unbalance
    replayed at that time): not eligible before the onset (integrated), a new history from it, engaged
    again later; the stream follows the same option's integration."""
    onset = {**FAULTS["tooth_damage"][0], "onset_s": 1.25}
    plan = [(FAULTS["mass_unbalance"], 9), ([FAULTS["mass_unbalance"][0], onset], 15)]
    node, ref, info = node_like_run(plan, replay="faults", same_reference=True)
    assert info[8][1] and info[8][2] == 1  # served when the list is applied
    k = round(onset["onset_s"] / CHUNK_S)
    assert not any(served for _, served, _ in info[9:k])  # not eligible before the onset
    assert info[-1][1] and info[-1][2] == 2
    assert _rms_errors(node, ref, plan).max() < RMS_BOUND


def test_an_ignored_switch_fails_the_comparison(monkeypatch: pytest.MonkeyPatch) -> None:
    """The comparison can fail: a replay that ignores the switches (``set_effects`` without stopping it,
    ``serve`` without checking the key) keeps serving the previous fault's period, 0.1 or more of the
    peak away from the integration."""
    from gear_rotor_sim.simulator import Simulator

    set_effects = Simulator.set_effects

    def blind_set_effects(self: Simulator, effects: object) -> None:
        rep, self._replay = self._replay, None
        try:
            set_effects(self, effects)
        finally:
            self._replay = rep

    def blind_serve(self: PeriodicReplay, sim: Simulator, n: int) -> tuple | None:
        if not self.active:
            return None
        idx = ((sim._raw - self._base) % self.period_steps + np.arange(n)) % self.period_steps
        return self._rows[idx], self._states[idx]

    monkeypatch.setattr(Simulator, "set_effects", blind_set_effects)
    monkeypatch.setattr(PeriodicReplay, "serve", blind_serve)
    node, ref, info = node_like_run(PLAN[:2], replay="faults", same_reference=True)
    assert info[-1][2] == 1 and info[-1][1]  # still serving the unbalance
    assert chunk_errors(node, ref, N_CHUNK)[-5:].min() > 0.1


@pytest.mark.parametrize("new", ["healthy", "mass_unbalance", "tooth_damage"])
def test_switch_inside_a_replay_at_20000_rpm(new: str) -> None:
    """``"faults"`` at 20000 rpm: a pinion tooth (depth 0.1) replayed, then removed, replaced by an
    unbalance or deepened inside the engaged replay; against the same option's integration within
    1e-6 of each channel's fluctuating RMS over 0.4 s from the switch (measured 2e-13 to 2e-10)."""
    from test_periodic_replay import _rel_diff, _settle
    from test_periodic_replay_effects import _PINION_TOOTH_20K, _pair

    from gear_rotor_sim.faults.spec import parse_faults
    from gear_rotor_sim.faults.timed import timed_effects

    on, off = _pair(20000.0, (_PINION_TOOTH_20K,), "faults")
    _settle(on, off, CHUNK_S)
    specs = {**FAULTS, "tooth_damage": [{**FAULTS["tooth_damage"][0], "depth": 0.15}]}[new]
    x = [on.advance(CHUNK_S).data]
    y = [off.advance(CHUNK_S).data]
    assert on.replay is not None and on.replay.active
    on.set_effects(timed_effects(parse_faults(specs)))
    off.set_effects(timed_effects(parse_faults(specs)))
    assert not on.replay.active
    x += [on.advance(CHUNK_S).data for _ in range(4)]
    y += [off.advance(CHUNK_S).data for _ in range(4)]
    err = _rel_diff(np.concatenate(x[1:]), np.concatenate(y[1:]))
    assert np.all(err < RMS_BOUND), err
