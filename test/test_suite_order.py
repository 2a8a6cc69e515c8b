"""The test session's order of the shared-calibration group (test/conftest.py, ``shared_group_order``):
the tests that calibrate the shared pinion-tooth record again run right after its calibration, every other
test keeps its place (docs/history/calibration_sessions.md Sec. 8.74)."""

from __future__ import annotations

from pathlib import Path

from conftest import PINION_TOOTH_AGAIN, shared_group_order

ROOT = Path(__file__).resolve().parents[1]


def test_again_tests_first_in_the_group_and_other_tests_in_place() -> None:
    trace, reversed_sign = PINION_TOOTH_AGAIN
    ids = [
        "test/test_a.py::test_x",  # not in the group
        "test/test_calibration_claim_check.py::test_true_pinion",  # reads the pinion calibration
        "test/test_calibration_crack.py::test_crack",  # in the group, not the pinion
        "test/test_b.py::test_y",
        reversed_sign,
        "test/test_calibration_residual_trace.py::test_cardan",
        trace,
    ]
    shared = [False, True, True, False, True, True, True]
    pinion = [False, True, False, False, True, False, True]
    got = [ids[i] for i in shared_group_order(ids, shared, pinion)]
    assert got == [
        "test/test_a.py::test_x",
        trace,
        reversed_sign,
        "test/test_b.py::test_y",
        "test/test_calibration_claim_check.py::test_true_pinion",
        "test/test_calibration_crack.py::test_crack",
        "test/test_calibration_residual_trace.py::test_cardan",
    ]
    # nothing in the group: the collection's order
    assert shared_group_order(ids[:1] + ids[3:4], [False, False], [False, False]) == [0, 1]


def test_the_listed_tests_exist_and_read_the_shared_pinion_calibration() -> None:
    """A renamed test would silently drop out of the order: each listed one is defined in its file and asks
    for ``pinion_tooth_calibration``."""
    for nodeid in PINION_TOOTH_AGAIN:
        file, name = nodeid.split("::")
        text = (ROOT / file).read_text(encoding="utf-8")
        head = text.split(f"def {name}(", 1)
        assert len(head) == 2, nodeid
        assert "pinion_tooth_calibration" in head[1].split(")", 1)[0], nodeid
