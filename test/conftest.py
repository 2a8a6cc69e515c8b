"""Test-session isolation from other ROS 2 traffic on the host.

The node tests publish and subscribe on the project's real topic names. Two test runs on one
machine (or a test run next to a running ``simulator_node``) would otherwise discover each other
over DDS and mix their messages: a test that compares a stream with the simulator then reads the
other run's samples. Unless the caller chose a domain, each test session gets its own
``ROS_DOMAIN_ID`` (derived from its process id; 1-100, all valid with the default port mapping)
and discovery is kept to this host. Set before any test module imports rclpy; child processes
(``ros2 run``, ``ros2 bag``) inherit it.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

import pytest

# Under pytest-xdist (``scripts/test.sh`` runs two workers) each worker is a test session of its own:
# a domain this file chose in the controlling process is inherited by the workers and chosen again
# there, so that two workers' node tests do not see each other either.
_OWN = "GEAR_ROTOR_SIM_TEST_ROS_DOMAIN"
if "ROS_DOMAIN_ID" not in os.environ or (
    os.environ.get("PYTEST_XDIST_WORKER") and os.environ.get(_OWN) == os.environ["ROS_DOMAIN_ID"]
):
    os.environ["ROS_DOMAIN_ID"] = os.environ[_OWN] = str(1 + os.getpid() % 100)
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")


# ------------------------------------------------------------------ shared calibrations (test time)
# Calibrations of the same independent record with the same settings, asked for by tests in several
# files, are run once per test session (docs/history/calibration_sessions.md Sec. 8.39). Each test still
# asserts its own criteria on the shared result; the result objects are only read.

#: the session fixtures below that calibrate (or fit a reference on) a shared record
SHARED_CALIBRATIONS = ("pinion_tooth_calibration", "reference_2000", "healthy_3000_calibration")


@functools.cache
def reads_a_shared_calibration(path: Path) -> bool:
    """Whether the test file at ``path`` names one of :data:`SHARED_CALIBRATIONS` (its tests ask for it)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError:
        return False
    return any(name in text for name in SHARED_CALIBRATIONS)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object | None:
    """``--dist loadfile`` (``scripts/test.sh``) with the files that read a shared calibration as one scope.

    Under pytest-xdist each worker is a session of its own and computes the session fixtures it is asked
    for: with plain ``loadfile`` both workers calibrated the shared pinion-tooth record when files reading
    it fell on both (session 24's suite: 100 s and 81 s of set-up). Here every other file stays whole on
    one worker (its module fixtures computed once), and the files of :func:`reads_a_shared_calibration` go
    together to one worker, where each shared calibration runs once and model runs of the same operating
    point come from that process's cache (docs/history/calibration_sessions.md Sec. 8.72). Other ``--dist``
    modes keep xdist's own scheduler."""
    if config.getoption("dist", None) != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    root = config.rootpath

    class SharedCalibrationScheduling(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            file = nodeid.split("::", 1)[0]
            return "shared calibrations" if reads_a_shared_calibration(root / file) else file

    return SharedCalibrationScheduling(config, log)


#: the acceptance tests that calibrate the shared pinion-tooth record again with the same model runs, in
#: the order they run first among the tests of :func:`reads_a_shared_calibration`: the same call with the
#: residual trace switched off, then the record with an accelerometer's sign reversed (read back to the
#: same data). Right after the session's calibration of that record (212 model runs) they take its runs
#: from the runner's cache (``model_runner``: 400 runs, the least recently used dropped). Before session 26
#: the trace's test ran after a dozen other calibrations of the group, which had evicted them: a second
#: calibration of the record with every run cached took 38.1 s CPU against 80.0 s for the first
#: (docs/history/calibration_sessions.md Sec. 8.74). The record with spikes is not here: its repaired data
#: differ from the clean record's; run third in this order, its calibration took 102 s wall against 126 s for
#: the shared one at the same load, few of its runs from the cache.
PINION_TOOTH_AGAIN = (
    "test/test_calibration_residual_trace.py::test_trace_changes_nothing_in_the_calibration",
    "test/test_calibration_undeclared.py::test_a_reversed_accelerometer_is_read_back_and_diagnosed_as_declared",
)


def shared_group_order(nodeids: list[str], reads_shared: list[bool], reads_pinion: list[bool]) -> list[int]:
    """The collection's order with the shared-calibration group's tests rearranged among their own places.

    ``reads_shared[i]``: test ``i`` is in a file of :func:`reads_a_shared_calibration`;
    ``reads_pinion[i]``: it asks for ``pinion_tooth_calibration``. Those places are filled with
    :data:`PINION_TOOTH_AGAIN` (in its order), then the other tests reading the shared pinion calibration,
    then the rest of the group, each in collection order; every other test keeps its place. Returns the
    permutation (indices into ``nodeids``)."""

    def rank(i: int) -> int:
        nid = nodeids[i]
        again = [n for n, want in enumerate(PINION_TOOTH_AGAIN) if nid.endswith(want)]
        if again:
            return again[0]
        return len(PINION_TOOTH_AGAIN) + (0 if reads_pinion[i] else 1)

    slots = [i for i, s in enumerate(reads_shared) if s]
    order = list(range(len(nodeids)))
    for slot, i in zip(slots, sorted(slots, key=rank), strict=True):
        order[slot] = i
    return order


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """:func:`shared_group_order` on the collected tests (after selection and pytest's own ordering). Under
    xdist every worker collects the same order and the scheduler sends a scope's tests in it."""
    order = shared_group_order(
        [it.nodeid for it in items],
        [reads_a_shared_calibration(Path(it.path)) for it in items],
        ["pinion_tooth_calibration" in getattr(it, "fixturenames", ()) for it in items],
    )
    items[:] = [items[i] for i in order]


#: the 0.6 s ``lumped_gearbox`` records shared between test files: (speed rpm, temperature C, faults,
#: seed), as test_calibration_independent_diagnosis.py made them
SHARED_RECORDS = {
    "pinion_tooth": (3000.0, 25.0, ("tooth_damage:wheel=pinion,tooth=7,depth=0.4",), 7),
    "healthy_2000": (2000.0, 25.0, (), 5),
    "healthy_3000": (3000.0, 25.0, (), 1),
}
SHARED_DURATION_S = 0.6


@pytest.fixture(scope="session")
def shared_records(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Paths of :data:`SHARED_RECORDS`, written once per session."""
    from lumped_gearbox import make_record, write_record

    root = tmp_path_factory.mktemp("shared_records")
    return {
        tag: write_record(
            root / f"{tag}.csv", make_record(sp, tc, list(f), duration_s=SHARED_DURATION_S, seed=seed)
        )
        for tag, (sp, tc, f, seed) in SHARED_RECORDS.items()
    }


@pytest.fixture(scope="session")
def pinion_tooth_calibration(shared_records: dict):
    """``Calibrator(load_measurement(record)).run()`` of the shared pinion-tooth record (tooth 7,
    depth 0.4, 3000 rpm, no reference): read by test_calibration_dte_depth.py and
    test_calibration_independent_diagnosis.py."""
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement

    return Calibrator(load_measurement(shared_records["pinion_tooth"])).run()


@pytest.fixture(scope="session")
def reference_2000(shared_records: dict):
    """The machine's baseline fitted on the shared healthy 2000 rpm record (``--baseline``): read by
    test_calibration_independent_diagnosis.py and test_calibration_wear_rattle.py."""
    from gear_rotor_sim.calibration.baseline import fit_reference_baseline
    from gear_rotor_sim.calibration.measurement import load_measurement

    path = shared_records["healthy_2000"]
    return fit_reference_baseline(load_measurement(path), source=str(path))


@pytest.fixture(scope="session")
def healthy_3000_calibration(shared_records: dict):
    """``Calibrator(load_measurement(record)).run()`` of the shared healthy 3000 rpm / 25 C record (seed 1,
    no reference): read by test_calibration_independent_diagnosis.py (it claims nothing) and
    test_calibration_residual_trace.py (the trace's shares against the score's per-channel errors), which
    calibrated a healthy 3000 rpm / 25 C record each (seeds 1 and 41) before session 25 (Sec. 8.72)."""
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement

    return Calibrator(load_measurement(shared_records["healthy_3000"])).run()
