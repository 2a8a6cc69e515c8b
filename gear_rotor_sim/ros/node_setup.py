"""What the simulator node builds from its parameters at start: streams, model, recorder, live view.

Each function takes the node's parameter values (``dict`` of the declared parameters, as
:func:`~gear_rotor_sim.ros.params.declare` returns them) and raises
:class:`~gear_rotor_sim.ros.params.ParamError` naming the parameter when it cannot be honoured; the
node (:mod:`.simulator_node`) owns the objects returned.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from gear_rotor_sim.ros.node_faults import FAULTS_TOPIC, NodeFaults
from gear_rotor_sim.ros.params import STREAM_NAMES, ParamError
from gear_rotor_sim.streams import StreamSpec, default_streams


def select_streams(v: dict[str, Any]) -> list[StreamSpec]:
    """The published streams of the ``publish.*`` and ``frame_ids.*`` parameters."""
    bearings = [int(b) for b in v["publish.bearings"]]
    specs = default_streams(
        n_bearings=max(bearings) if bearings else 0,
        displacement_nodes=tuple(int(n) for n in v["publish.displacement_nodes"]),
        displacement_dofs=tuple(v["publish.displacement_dofs"]),
        acceleration_nodes=tuple(int(n) for n in v["publish.acceleration_nodes"]),
        has_mesh=bool(v["publish.dte"]),
    )
    out = []
    for spec in specs:
        channels = spec.channels
        if spec.name == "bearing_forces":
            if not bearings:
                continue
            channels = tuple(f"bearing{k}_f{d}" for k in bearings for d in "xyz")
        out.append(StreamSpec(spec.name, channels, str(v[f"frame_ids.{spec.name}"])))
    housing = [int(b) for b in v["publish.housing_bearings"]]
    if housing:
        from gear_rotor_sim.sensors.housing import housing_channels

        name = "housing_accelerations"
        out.append(StreamSpec(name, housing_channels(housing), str(v[f"frame_ids.{name}"])))
    return out


def housing_model(v: dict[str, Any], streams: list[StreamSpec]) -> Any:
    """Streaming housing accelerometers of the housing stream (docs/faults.md), or None."""
    spec = next((s for s in streams if s.name == "housing_accelerations"), None)
    if spec is None:
        return None
    from gear_rotor_sim.sensors.housing import HousingAccelerometers
    from gear_rotor_sim.sensors.noise import SensorNoise

    seed = int(v["noise.seed"]) + STREAM_NAMES.index(spec.name) + 1000
    fs = float(v["output_sample_rate_hz"])
    return HousingAccelerometers(spec.channels, fs, noise=SensorNoise(seed=seed))


@dataclass
class NodeModel:
    """The running model of the node: rig, faults, streams (per-mesh DTE on a multi-stage rig),
    housing accelerometers (or None) and the simulator."""

    cfg: Any
    faults: NodeFaults
    streams: list[StreamSpec]
    housing: Any
    sim: Any


def replay_setting(v: dict[str, Any]) -> bool | str:
    """``Simulator(periodic_replay=...)`` from the parameters ``periodic_replay`` and
    ``periodic_replay_faults`` (docs/solver.md, "Periodic replay at steady state")."""
    if not v["periodic_replay"]:
        return False
    return "faults" if v["periodic_replay_faults"] else True


def build_model(v: dict[str, Any], streams: list[StreamSpec]) -> NodeModel:
    """Load ``model`` (with ``bearing_type``) and ``faults_file``, check the requested channels and
    build the simulator at the initial operating point.

    Raises
    ------
    ParamError
        When the model, a bearing type, or a requested channel does not exist, the faults file is
        invalid, or the simulator refuses the initial operating point; the message names the parameter.
    """
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.simulator import Simulator

    try:
        cfg = load_config(str(v["model"]))
        if v["bearing_type"]:
            cfg = cfg.with_bearing_type(str(v["bearing_type"]))
    except ValueError as exc:
        raise ParamError(f"model/bearing_type: {exc}") from exc
    from gear_rotor_sim.faults.spec import FaultError, load_faults

    faults_file = str(v["faults_file"]).strip()
    try:
        initial = load_faults(faults_file, cfg) if faults_file else ()
    except FaultError as exc:
        raise ParamError(f"faults_file: {faults_file}: {exc}") from exc
    faults = NodeFaults(cfg, initial)
    if len(cfg.meshes) > 1:  # a multi-stage rig: the DTE stream carries every mesh's DTE and force
        per_mesh = default_streams(0, n_meshes=len(cfg.meshes))[0].channels
        streams = [StreamSpec(sp.name, per_mesh, sp.frame_id) if sp.name == "dte" else sp for sp in streams]
    available = {name for name, _unit in Simulator.available_channels(cfg)}
    housing = housing_model(v, streams)
    channels = [c for s in streams if s.name != "housing_accelerations" for c in s.channels]
    channels += list(housing.sources) if housing is not None else []
    missing = [c for c in channels if c not in available]
    if missing:
        raise ParamError(
            f"publish.*: channels {missing} do not exist in model {v['model']!r} "
            f"({len(cfg.bearings)} bearings, {cfg.n_nodes} nodes)"
        )
    try:
        sim = Simulator(
            cfg,
            speed_rpm=float(v["speed_rpm"]),
            temperature_c=float(v["temperature_c"]),
            output_rate_hz=float(v["output_sample_rate_hz"]),
            channels=list(dict.fromkeys(channels)),
            steps_per_mesh=int(v["steps_per_mesh"]),
            contact_loss_rate_hz=float(v["contact_loss_rate_hz"]) or None,
            event_average=bool(v["event_average"]),
            periodic_replay=replay_setting(v),
            speed_ramp_rpm_per_s=float(v["speed_ramp_rpm_per_s"]),
            temperature_ramp_c_per_s=float(v["temperature_ramp_c_per_s"]),
            effects=faults.effects(),
        )
    except ValueError as exc:
        raise ParamError(f"simulator refused the parameters: {exc}") from exc
    return NodeModel(cfg, faults, streams, housing, sim)


def open_recorder(
    v: dict[str, Any], streams: list[StreamSpec], cfg: Any, path: str, flush_period_s: float
) -> Any:
    """The MCAP recorder of ``recording.*``: the streams with the QoS the node offers, the fault
    truth topic, and the rig in the file's metadata (``calibrate`` reads it)."""
    from gear_rotor_sim.recording.writer import McapRecorder, RecordingError, qos_profile
    from gear_rotor_sim.system import drivetrain_metadata

    reliable = v["stream_qos.reliability"] == "reliable"
    offered = dict(qos_profile("reliable" if reliable else "sensor_data"))
    offered["depth"] = int(v["stream_qos.depth"])
    offered["durability"] = v["stream_qos.durability"]
    from gear_rotor_sim.recording import schemas
    from gear_rotor_sim.recording.record_cli import latched_qos

    try:
        rec = McapRecorder(
            path,
            streams,
            qos=offered,
            flush_period_s=flush_period_s,
            # the rig (calibrate reads it when no sidecar names the gearbox), per-shaft speed
            # ratios and mesh orders
            custom_data={
                "config": str(v["model"]),
                "bearing_type": str(v["bearing_type"] or "null"),
                **drivetrain_metadata(cfg),
            },
        )
        rec.add_topic(FAULTS_TOPIC, schemas.FAULT_STATE, qos=latched_qos())
        return rec
    except (OSError, ValueError, RecordingError) as exc:
        raise ParamError(f"recording.path: cannot record to {path!r}: {exc}") from exc


def open_live(
    streams: list[StreamSpec], cfg: Any, port: int, on_setpoint: Callable[[str, float], str | None]
) -> Any:
    """The Foxglove WebSocket server of ``foxglove_port`` (docs/live.md); ``on_setpoint(kind, value)``
    returns the refusal reason or None."""
    from gear_rotor_sim.live.server import LiveServer

    teeth = cfg.gears[0].teeth if cfg.gears else 1
    try:
        return LiveServer(streams, on_setpoint, port=port, pinion_teeth=teeth)
    except (OSError, RuntimeError, ValueError) as exc:
        raise ParamError(f"foxglove_port: cannot serve on port {port}: {exc}") from exc
