"""The malformed-input corpus (test/corpus/): every case gets its expected outcome.

Measurements go through ``gear-rotor-sim calibrate`` (exit status 2 and one stderr line naming the
file, column/field and time) or load with the expected ``issues``; setpoints through a live server
with ``gear-rotor-sim serve``'s validator and through the ROS node's callbacks; node parameters at
start-up and at runtime. The expected outcomes are written by hand in the manifests
(test/corpus/measurements/manifest.yaml, test/corpus/requests.yaml), independent of the code.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from corpus_runner import (
    load_measurement_cases,
    load_requests,
    matches,
    run_measurement,
    run_node_parameters,
    run_node_runtime,
    run_node_setpoints,
    run_serve_options,
    run_serve_setpoints,
)

MEASUREMENTS = load_measurement_cases()
REQUESTS = load_requests()


def test_corpus_size():
    """At least 25 malformed measurements and 20 malformed setpoints/parameters (issue 14)."""
    assert sum(c["expect"] == "error" for c in MEASUREMENTS) >= 25
    requests = REQUESTS["setpoints"] + REQUESTS["node_parameters"] + REQUESTS["node_runtime"]
    assert sum(c["expect"] == "refused" for c in requests) >= 20


@pytest.mark.parametrize("case", MEASUREMENTS, ids=[c["case"] for c in MEASUREMENTS])
def test_measurement(case):
    r = run_measurement(case)
    assert matches(case, r["outcome"], r["message"]), r
    if case["expect"] == "error":
        assert r["exit"] == 2 and "\n" not in r["message"] and r["stdout"] == ""
        assert case["file"].split(".")[0] in r["message"]  # the file is named


@pytest.mark.parametrize(
    "case", REQUESTS["serve_options"], ids=[c["case"] for c in REQUESTS["serve_options"]]
)
def test_serve_options(case):
    r = run_serve_options(case)
    assert matches(case, r["outcome"], r["message"]) and r["exit"] == 2, r


def test_serve_setpoints():
    cases = REQUESTS["setpoints"]
    for case, r in zip(cases, run_serve_setpoints(cases), strict=True):
        assert matches(case, r["outcome"], r["message"]), (case["case"], r)


try:
    import rclpy  # noqa: F401
    from std_msgs.msg import Float64  # noqa: F401

    HAVE_ROS = True
except ImportError:  # pragma: no cover - CI has rclpy (scripts/setup_env.sh)
    HAVE_ROS = False
ros = pytest.mark.skipif(not HAVE_ROS, reason="rclpy not importable; run scripts/setup_env.sh")


@ros
@pytest.mark.ros
def test_node_setpoints():
    cases = [c for c in REQUESTS["setpoints"] if "value" in c]
    for case, r in zip(cases, run_node_setpoints(cases), strict=True):
        assert matches(case, r["outcome"], r["message"]), (case["case"], r)


@ros
@pytest.mark.ros
@pytest.mark.parametrize(
    "case", REQUESTS["node_parameters"], ids=[c["case"] for c in REQUESTS["node_parameters"]]
)
def test_node_parameters(case):
    r = run_node_parameters(case)
    assert matches(case, r["outcome"], r["message"]), r


@ros
@pytest.mark.ros
@pytest.mark.parametrize("case", REQUESTS["node_runtime"], ids=[c["case"] for c in REQUESTS["node_runtime"]])
def test_node_runtime(case):
    r = run_node_runtime(case)
    assert matches(case, r["outcome"], r["message"]), r


def test_isolated_spike_is_interpolated_and_nothing_else_changes(tmp_path):
    """Truth: on a straight line, linear interpolation between the spike's neighbours restores the
    line exactly; every other sample is returned bit for bit (after the um -> m conversion)."""
    from corpus_runner import CORPUS

    from gear_rotor_sim.calibration.measurement import load_csv

    fs, n = 1000.0, 300
    t = np.arange(n) / fs
    line = 0.2 + 3.0 * t  # um
    wave = line + 0.4 * np.sin(2 * np.pi * 37.0 * t)
    dte = wave.copy()
    dte[150] = line[150] + 5.0e3  # isolated spike, ~1e4 robust scales
    dte[149], dte[151] = line[149], line[151]  # neighbours on the line
    rows = "\n".join(f"{float(a)!r},{float(b)!r}" for a, b in zip(t, dte, strict=True))
    (tmp_path / "s.csv").write_text("time_s,dte\n" + rows + "\n")
    side = yaml.safe_load((CORPUS / "measurements" / "clean.yaml").read_text())
    side["channels"] = side["channels"][:1]
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(side))
    m = load_csv(tmp_path / "s.csv")
    x = m.channel("dte")
    assert x[150] == pytest.approx(line[150] * 1e-6, rel=1e-12)
    keep = np.arange(n) != 150
    assert np.array_equal(x[keep], dte[keep] * 1e-6)
    assert any("1 isolated spike(s)" in s and "t = 0.15 s" in s for s in m.issues), m.issues


def test_calibrate_reports_a_non_finite_error_with_exit_3(monkeypatch, capsys):
    """A calibration whose error is not finite never exits 0 with a silent null."""
    from gear_rotor_sim.calibration import calibrate_cli, fit
    from gear_rotor_sim.cli import build_parser

    class NonFinite:
        error_before = math.nan
        error_after = math.inf

    monkeypatch.setattr(fit.Calibrator, "__init__", lambda self, *a, **k: None)
    monkeypatch.setattr(fit.Calibrator, "run", lambda self: NonFinite())
    path = next(c for c in MEASUREMENTS if c["case"] == "clean")["file"]
    from corpus_runner import CORPUS

    args = build_parser("calibrate").parse_args(["calibrate", str(CORPUS / "measurements" / path)])
    assert calibrate_cli.run(args) == 3
    err = capsys.readouterr().err
    assert "non-finite error (before nan, after inf)" in err and "clean.csv" in err
