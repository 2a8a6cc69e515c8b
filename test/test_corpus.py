"""The malformed-input corpus (test/corpus/): every case gets its expected outcome.

Measurements go through ``gear-rotor-sim calibrate`` (exit status 2 and one stderr line naming the
file, column/field and time) or load with the expected ``issues``; setpoints through a live server
with ``gear-rotor-sim serve``'s validator and through the ROS node's callbacks; node parameters at
start-up and at runtime. The expected outcomes are written by hand in the manifests
(test/corpus/measurements/manifest.yaml, test/corpus/requests.yaml), independent of the code.
"""

from __future__ import annotations

import pytest
from corpus_runner import (
    load_measurement_cases,
    load_requests,
    matches,
    run_measurement,
    run_node_parameters,
    run_node_runtime,
    run_node_setpoints,
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
