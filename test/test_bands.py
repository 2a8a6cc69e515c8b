"""The chaotic-window algebra of the reproduction (analysis/bands.py) against intervals worked out by
hand."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.analysis.bands import condense_windows, label_at, main_band, overlap_near


def test_main_band_is_the_widest_window_reaching_the_resonance_range() -> None:
    windows = [(500.0, 1487.0), (6177.0, 6671.0), (10500.0, 11200.0), (16298.0, 19506.0)]
    # reaching above 11000 rpm: 10500-11200 (700 wide) and 16298-19506 (3208 wide)
    assert main_band(windows) == (16298.0, 19506.0)
    # with the threshold above 19506 no window qualifies
    lo, hi = main_band(windows, above_rpm=19600.0)
    assert math.isnan(lo) and math.isnan(hi)
    # a wide low-speed window does not count; one that starts below 11000 rpm and ends above does
    assert main_band([(500.0, 9000.0), (12000.0, 12500.0)]) == (12000.0, 12500.0)
    assert main_band([(9000.0, 12500.0), (15000.0, 15500.0)]) == (9000.0, 12500.0)


@pytest.mark.parametrize(
    ("model", "expected"),
    [
        # 13000-15000 against 13500-14700: intersection 1200, union 2000
        ([(13000.0, 15000.0)], (13000.0, 15000.0, 0.6)),
        # two model windows near the paper's: their hull 13000-16000; intersection 1200, union 3000
        ([(13000.0, 13800.0), (14500.0, 16000.0)], (13000.0, 16000.0, 0.4)),
        # disjoint but within 1500 rpm: 15500-17000 ends above 13500 - 1500 and starts below 14700 + 1500
        ([(15500.0, 17000.0)], (15500.0, 17000.0, 0.0)),
    ],
)
def test_overlap_near_is_the_jaccard_index_of_the_nearby_hull(
    model: list[tuple[float, float]], expected: tuple[float, float, float]
) -> None:
    lo, hi, jac = overlap_near(model, (13500.0, 14700.0))
    assert (lo, hi) == expected[:2]
    assert jac == pytest.approx(expected[2], abs=1e-15)


def test_overlap_near_ignores_windows_beyond_1500_rpm() -> None:
    # 16298 rpm starts more than 1500 rpm above 14700, 11900 rpm ends more than 1500 rpm below 13500
    for model in ([(16298.0, 19506.0), (500.0, 1487.0)], [(11000.0, 11900.0)]):
        lo, hi, jac = overlap_near(model, (13500.0, 14700.0))
        assert math.isnan(lo) and math.isnan(hi) and jac == 0.0
    # 100 rpm closer on either side: near
    assert overlap_near([(11000.0, 12000.0)], (13500.0, 14700.0))[:2] == (11000.0, 12000.0)
    assert overlap_near([(16200.0, 19506.0)], (13500.0, 14700.0))[:2] == (16200.0, 19506.0)


def test_condense_windows_absorbs_runs_shorter_than_the_minimum() -> None:
    speeds = np.arange(500.0, 3001.0, 100.0)  # 100 rpm grid
    windows = [
        ("period-1", 500.0, 1000.0),  # 6 points
        ("chaotic", 1100.0, 1200.0),  # 2 points: absorbed by the run before it
        ("period-1", 1300.0, 2000.0),  # same label as the run it now continues
        ("period-2", 2100.0, 3000.0),  # 10 points
    ]
    assert condense_windows(windows, 3, speeds) == [("period-1", 500.0, 2000.0), ("period-2", 2100.0, 3000.0)]
    # with a minimum of 2 points nothing is absorbed
    assert condense_windows(windows, 2, speeds) == windows


def test_label_at_takes_the_nearest_grid_speed() -> None:
    res = SimpleNamespace(
        speeds_rpm=np.array([1000.0, 2000.0, 3000.0]), labels=lambda: ["period-1", "chaotic", "period-2"]
    )
    assert label_at(res, 2400.0) == "chaotic (2000 rpm)"
    assert label_at(res, 2600.0) == "period-2 (3000 rpm)"
