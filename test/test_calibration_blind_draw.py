"""The blind set's draw (benchmarks/calibration_blind.py, history Sec. 8.75): reproducible from its seed and
equal to the committed, pre-registered case file. No record is made and nothing is calibrated."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import calibration_blind as cb  # noqa: E402
import calibration_independent as ci  # noqa: E402

from lumped_gearbox import parse_fault  # noqa: E402


def test_draw_reproduces_the_committed_cases() -> None:
    doc = json.loads((BENCH / "calibration_blind_cases.json").read_text())
    assert doc["draw_seed"] == cb.DRAW_SEED
    assert doc == json.loads(json.dumps(cb.case_document()))
    assert cb.load_cases() == doc["cases"]


@pytest.mark.parametrize("blind_set", [2, 3])
def test_later_sets_reproduce_their_committed_cases(blind_set: int) -> None:
    """Sets 2 and 3 (pre-registered in sessions 27 and 28): each its own seed and file, records that no
    earlier set holds."""
    seed, name, prefix = cb.SETS[blind_set]
    doc = json.loads((BENCH / name).read_text())
    assert doc["draw_seed"] == seed
    assert doc == json.loads(json.dumps(cb.case_document(seed)))
    assert cb.load_cases(cb.case_file(blind_set)) == doc["cases"]
    assert all(c["tag"].startswith(prefix) for c in doc["cases"])
    earlier = {c["seed"] for s in range(1, blind_set) for c in cb.load_cases(cb.case_file(s))}
    assert earlier.isdisjoint(c["seed"] for c in doc["cases"])


def test_an_unregistered_set_is_refused() -> None:
    """A set number not in SETS names the allowed ones."""
    with pytest.raises(ValueError, match=r"blind set 4: allowed \[1, 2, 3\]"):
        cb.case_file(4)


def test_draw_depends_on_its_seed() -> None:
    """Another seed gives another draw (the file check can fail), and the same seed the same one twice."""
    assert cb.draw(cb.DRAW_SEED) == cb.draw(cb.DRAW_SEED)
    assert cb.draw(cb.DRAW_SEED + 1) != cb.draw(cb.DRAW_SEED)


def test_draw_within_the_registered_ranges() -> None:
    """Every family once, the healthy count, severities x0.6-x1.6 of the table's, the operating ranges,
    fresh seeds and a reference at another speed; every fault parses in the generator."""
    cases = cb.draw()
    assert len(cases) == cb.N_CASES
    assert sum(c["fault"] is None for c in cases) == cb.N_HEALTHY
    assert set(cb.FAMILIES) <= {c["family"] for c in cases}
    seeds = [s for c in cases for s in (c["seed"], c["reference"]["seed"])]
    assert len(set(seeds)) == len(seeds) and min(seeds) >= cb.SEED_RANGE[0]
    table = {parse_fault(f).name: parse_fault(f) for f in [*ci.FAULTS, ci.CRACK]}
    for c in cases:
        assert cb.SPEED_RPM[0] <= c["speed_rpm"] <= cb.SPEED_RPM[1]
        assert cb.TEMPERATURE_C[0] <= c["temperature_c"] <= cb.TEMPERATURE_C[1]
        assert abs(c["reference"]["speed_rpm"] - c["speed_rpm"]) >= cb.REFERENCE_GAP_RPM
        if c["fault"] is None:
            continue
        f = parse_fault(c["fault"])
        assert f.name == c["family"]
        ref = table[f.name]
        ratio = getattr(f, f.main) / getattr(ref, ref.main)
        assert ratio == pytest.approx(c["severity_factor"], rel=5e-3)  # three significant digits
        assert cb.SEVERITY[0] * (1 - 5e-3) <= ratio <= cb.SEVERITY[1] * (1 + 5e-3)
        if hasattr(f, "phase_rad") and f.name != "tooth_wear":
            assert -math.pi <= f.phase_rad <= math.pi
