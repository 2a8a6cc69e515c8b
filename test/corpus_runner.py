"""Runs the malformed-input corpus (test/corpus/) and reports each case's outcome.

``python test/corpus_runner.py`` prints the Markdown tables of docs/robustness.md;
``python -m pytest -q test/test_corpus.py`` checks every case against its expected outcome.

- measurements: ``gear-rotor-sim calibrate FILE --json`` in-process (its exit status and its one
  stderr line); cases expected to load are loaded with ``load_measurement`` and their ``issues``
  reported (calibrating them is not needed to check the input handling);
- setpoints: the payloads a Foxglove client publishes to ``gear-rotor-sim serve`` (a real
  :class:`~gear_rotor_sim.live.server.LiveServer` on a free port, with serve's validator), and the
  numeric ones as ``std_msgs/Float64`` to the ROS simulator node's setpoint callbacks;
- node parameters: the simulator node created with start-up overrides (and started where the
  check belongs to start-up), and runtime ``set_parameters`` on a created node.
"""

from __future__ import annotations

import contextlib
import io
import re
import sys
from pathlib import Path
from typing import Any

import yaml

CORPUS = Path(__file__).resolve().parent / "corpus"


def load_requests() -> dict[str, list[dict]]:
    return yaml.safe_load((CORPUS / "requests.yaml").read_text())


def load_measurement_cases() -> list[dict]:
    return yaml.safe_load((CORPUS / "measurements" / "manifest.yaml").read_text())["cases"]


def matches(case: dict, outcome: str, message: str) -> bool:
    """True when ``outcome`` is the expected one and ``message`` matches the case's expression."""
    expect = case["expect"]
    if expect in ("ok", "accepted") and outcome not in ("ok", "accepted"):
        return False
    if expect in ("error", "refused") and outcome not in ("error", "refused"):
        return False
    pattern = case.get("match")
    return pattern is None or re.search(pattern, message) is not None


# ----------------------------------------------------------------------------------- measurements
def run_measurement(case: dict) -> dict[str, Any]:
    """One measurement case: outcome ('ok'/'error'), message, and calibrate's exit status."""
    from gear_rotor_sim.calibration import calibrate_cli
    from gear_rotor_sim.calibration.measurement import MeasurementError, load_measurement
    from gear_rotor_sim.cli import build_parser

    path = CORPUS / "measurements" / case["file"]
    if case["expect"] == "ok":
        try:
            m = load_measurement(path)
        except (MeasurementError, ValueError) as exc:
            return {"outcome": "error", "message": str(exc), "exit": None}
        return {"outcome": "ok", "message": "; ".join(m.issues), "exit": None}
    args = build_parser("calibrate").parse_args(["calibrate", str(path), "--json"])
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = calibrate_cli.run(args)
    lines = err.getvalue().strip().splitlines()
    message = lines[-1] if lines else ""
    return {"outcome": "error" if code else "ok", "message": message, "exit": code, "stdout": out.getvalue()}


# ----------------------------------------------------------------------------------- setpoints
def run_serve_setpoints(cases: list[dict]) -> list[dict[str, Any]]:
    """Every setpoint case through a LiveServer with ``gear-rotor-sim serve``'s validator."""
    from gear_rotor_sim.live.serve import _Targets
    from gear_rotor_sim.live.server import LiveServer
    from gear_rotor_sim.setpoints import DEFAULT_LIMITS
    from gear_rotor_sim.streams import default_streams

    targets = _Targets(dict(DEFAULT_LIMITS))
    server = LiveServer(default_streams(4), targets.offer, port=0)
    try:
        results = []
        for case in cases:
            reason = server.receive(case["topic"], case["payload"].encode("utf-8"))
            results.append({"outcome": "refused" if reason else "accepted", "message": reason or ""})
        return results
    finally:
        server.stop()


@contextlib.contextmanager
def simulator_node(params: dict[str, Any]):
    """A SimulatorNode created with start-up overrides (rclpy initialised for it alone)."""
    import rclpy

    from gear_rotor_sim.ros.simulator_node import SimulatorNode

    args = ["--ros-args"]
    for name, value in params.items():
        text = yaml.safe_dump(value, default_flow_style=True).strip()
        text = text.removesuffix("\n...").removesuffix("...").strip()
        args += ["-p", f"{name}:={text}"]
    rclpy.init(args=args)
    node = None
    try:
        node = SimulatorNode()
        yield node
    finally:
        if node is not None:
            node.stop()
            node.destroy_node()
        rclpy.shutdown()


def run_node_setpoints(cases: list[dict]) -> list[dict[str, Any]]:
    """The numeric setpoint cases as std_msgs/Float64 to the node's setpoint callbacks."""
    from std_msgs.msg import Float64

    results = []
    with simulator_node({}) as node:
        callbacks = {"speed_rpm": node._on_speed, "temperature_c": node._on_temperature}
        for case in cases:
            kind = case["topic"].rsplit("/", 1)[-1]
            refused = node._state.refused
            callbacks[kind](Float64(data=float(case["value"])))
            if node._state.refused > refused:
                results.append({"outcome": "refused", "message": node._state.last_refusal})
            else:
                results.append({"outcome": "accepted", "message": ""})
    return results


def run_node_parameters(case: dict) -> dict[str, Any]:
    """One start-up parameter case: the node's constructor (and start(), when the case says so)."""
    from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException

    from gear_rotor_sim.ros.params import ParamError

    try:
        with simulator_node(case["params"]) as node:
            if case.get("start"):
                node.start()
    except (ParamError, InvalidParameterValueException, InvalidParameterTypeException) as exc:
        return {"outcome": "refused", "message": str(exc)}
    return {"outcome": "accepted", "message": ""}


def run_node_runtime(case: dict) -> dict[str, Any]:
    """One runtime change (ros2 param set) on a created node."""
    from rclpy.parameter import Parameter

    with simulator_node({}) as node:
        params = [Parameter(name, value=value) for name, value in case["set"].items()]
        results = node.set_parameters(params)
    bad = [r for r in results if not r.successful]
    return {"outcome": "refused" if bad else "accepted", "message": bad[0].reason if bad else ""}


def run_serve_options(case: dict) -> dict[str, Any]:
    """``gear-rotor-sim serve`` with the case's options, in-process: exit status and stderr line."""
    from gear_rotor_sim.cli import build_parser
    from gear_rotor_sim.live import serve

    args = build_parser("serve").parse_args(["serve", *case["args"]])
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = serve.run(args)
    lines = err.getvalue().strip().splitlines()
    return {"outcome": "refused" if code else "accepted", "message": lines[-1] if lines else "", "exit": code}


# ----------------------------------------------------------------------------------- report
def _row(cells: list[str]) -> str:
    root = str(CORPUS.parent.parent) + "/"  # paths relative to the repository root
    return "| " + " | ".join(c.replace(root, "").replace("|", "\\|").replace("\n", " ") for c in cells) + " |"


def main() -> int:
    lines = ["### Measurements (`gear-rotor-sim calibrate FILE --json`)", ""]
    lines += [
        _row(["case", "expected", "exit", "result (stderr line, or issues when loaded)", "as expected"])
    ]
    lines += [_row(["---"] * 5)]
    failures = 0
    for case in load_measurement_cases():
        r = run_measurement(case)
        ok = matches(case, r["outcome"], r["message"])
        failures += not ok
        message = r["message"].split(": ", 1)[-1] if r["outcome"] == "error" else (r["message"] or "(none)")
        exit_code = "-" if r["exit"] is None else str(r["exit"])
        lines.append(_row([case["case"], case["expect"], exit_code, message[:220], "yes" if ok else "NO"]))
    requests = load_requests()
    serve = run_serve_setpoints(requests["setpoints"])
    numeric = [c for c in requests["setpoints"] if "value" in c]
    node = dict(zip([c["case"] for c in numeric], run_node_setpoints(numeric), strict=True))
    lines += ["", "### Setpoints (`gear-rotor-sim serve` client messages; the node's Float64 callbacks)", ""]
    lines += [
        _row(["case", "topic", "payload", "expected", "serve", "node", "as expected"]),
        _row(["---"] * 7),
    ]
    for case, r in zip(requests["setpoints"], serve, strict=True):
        n = node.get(case["case"])
        ok = matches(case, r["outcome"], r["message"]) and (
            n is None or matches(case, n["outcome"], n["message"])
        )
        failures += not ok
        serve_text = r["outcome"] + (f": {r['message']}" if r["message"] else "")
        node_text = "n/a (typed Float64)" if n is None else n["outcome"]
        lines.append(
            _row(
                [
                    case["case"],
                    case["topic"].rsplit("/", 1)[-1],
                    f"`{case['payload']}`",
                    case["expect"],
                    serve_text,
                    node_text,
                    "yes" if ok else "NO",
                ]
            )
        )
    lines += ["", "### Node parameters at start-up (`--ros-args -p NAME:=VALUE`)", ""]
    lines += [_row(["case", "parameters", "expected", "result", "as expected"]), _row(["---"] * 5)]
    for case in requests["node_parameters"]:
        r = run_node_parameters(case)
        ok = matches(case, r["outcome"], r["message"])
        failures += not ok
        params = ", ".join(f"{k}:={v!r}" for k, v in case["params"].items())
        lines.append(
            _row(
                [
                    case["case"],
                    params,
                    case["expect"],
                    f"{r['outcome']}: {r['message']}"[:220],
                    "yes" if ok else "NO",
                ]
            )
        )
    lines += ["", "### Node parameters at runtime (`ros2 param set`)", ""]
    lines += [_row(["case", "change", "expected", "result", "as expected"]), _row(["---"] * 5)]
    for case in requests["node_runtime"]:
        r = run_node_runtime(case)
        ok = matches(case, r["outcome"], r["message"])
        failures += not ok
        change = ", ".join(f"{k}:={v!r}" for k, v in case["set"].items())
        lines.append(
            _row(
                [
                    case["case"],
                    change,
                    case["expect"],
                    f"{r['outcome']}: {r['message']}"[:220],
                    "yes" if ok else "NO",
                ]
            )
        )
    lines += ["", "### `gear-rotor-sim serve` options", ""]
    lines += [_row(["case", "options", "expected", "exit", "stderr", "as expected"]), _row(["---"] * 6)]
    for case in requests["serve_options"]:
        r = run_serve_options(case)
        ok = matches(case, r["outcome"], r["message"]) and r["exit"] == (
            2 if case["expect"] == "refused" else 0
        )
        failures += not ok
        lines.append(
            _row(
                [
                    case["case"],
                    f"`{' '.join(case['args'])}`",
                    case["expect"],
                    str(r["exit"]),
                    r["message"],
                    "yes" if ok else "NO",
                ]
            )
        )
    print("\n".join(lines))
    print(f"\n{failures} case(s) not as expected", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
