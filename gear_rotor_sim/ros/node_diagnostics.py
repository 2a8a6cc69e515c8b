"""The simulator node's ``/diagnostics`` message: simulation health and setpoint refusals."""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from gear_rotor_sim.ros.node_runtime import SharedState


def diagnostic_statuses(
    node_name: str, st: SharedState, rtf: float, requested_rtf: float, recording: str
) -> list[DiagnosticStatus]:
    """The two statuses of one report: ``<node>: simulation`` and ``<node>: setpoints``.

    Reads ``st`` under its lock and resets its count of refusals since the last report.

    Parameters
    ----------
    node_name : str
        Prefix of the status names.
    st : SharedState
        The node's shared state.
    rtf : float
        Achieved real-time factor (:func:`~gear_rotor_sim.ros.node_runtime.achieved_rtf`).
    requested_rtf : float
        The ``real_time_factor`` parameter; below 90 % of it a running simulation reports WARN.
    recording : str
        Recording status ("off", "recording to ...", "failed: ...", "finalised").
    """
    with st.lock:
        sim_kv = {
            "achieved_real_time_factor": f"{rtf:.4g}",
            "requested_real_time_factor": f"{requested_rtf:.4g}",
            "sim_time_s": f"{st.sim_time:.6f}",
            "speed_rpm": f"{st.speed:.3f}",
            "target_speed_rpm": f"{st.target_speed:.3f}",
            "temperature_c": f"{st.temperature:.3f}",
            "target_temperature_c": f"{st.target_temperature:.3f}",
            "contact_loss_fraction": f"{st.contact_loss:.6f}",
            "back_side_contact_fraction": f"{st.back_side_contact:.6f}",
            "solver_steps_last_chunk": str(st.solver_steps),
            "chunk_wall_time_s": f"{st.chunk_wall_s:.6f}",
            "mesh_solve_failures": str(st.mesh_solve_failures),
            "chunks_published": str(st.chunks),
            "samples_published": str(st.samples),
            "late_chunks": str(st.late_chunks),
            "solver_health": st.health_message,
            "recording": recording,
        }
        level, message = st.health_level, st.health_message
        sp_level = DiagnosticStatus.WARN if st.refused_since_diag else DiagnosticStatus.OK
        sp_message = (
            f"{st.refused_since_diag} setpoint(s) refused since last report; last: {st.last_refusal}"
            if st.refused_since_diag
            else "ok"
        )
        sp_kv = {
            "accepted_total": str(st.accepted),
            "refused_total": str(st.refused),
            "refused_since_last_report": str(st.refused_since_diag),
            "last_refusal": st.last_refusal,
        }
        st.refused_since_diag = 0
    if level == DiagnosticStatus.OK and st.chunks > 1 and rtf < 0.9 * requested_rtf:
        level = DiagnosticStatus.WARN
        message = f"cannot keep real_time_factor {requested_rtf:g}: achieved {rtf:.3g}"
    elif level == DiagnosticStatus.OK:
        message = f"running, achieved real-time factor {rtf:.3g}"
    return [
        _status(level, f"{node_name}: simulation", message, sim_kv),
        _status(sp_level, f"{node_name}: setpoints", sp_message, sp_kv),
    ]


def _status(level: bytes, name: str, message: str, values: dict[str, str]) -> DiagnosticStatus:
    return DiagnosticStatus(
        level=level,
        name=name,
        message=message,
        hardware_id="gear_rotor_sim",
        values=[KeyValue(key=k, value=val) for k, val in values.items()],
    )
