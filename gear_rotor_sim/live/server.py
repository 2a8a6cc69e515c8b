"""The Foxglove WebSocket side of the live view: channels, client setpoints, status messages.

:class:`LiveServer` owns one Foxglove WebSocket server (``foxglove-sdk``, subprotocol
``foxglove.sdk.v1``, the protocol the Foxglove app speaks) on its own SDK context, advertises the
channels of :mod:`gear_rotor_sim.live.messages` (CDR streams and indicators, JSON status and
setpoints), and turns each :class:`SampleBlock` it is given
into one message per stream plus the indicators and the DTE spectrum of the most recent window.
It does no physics and owns no simulator: ``gear-rotor-sim serve`` (:mod:`.serve`) and the ROS node
(parameter ``foxglove_port``) hand it their blocks.

Client setpoints (capability ``clientPublish``, encoding ``json``) are parsed here and handed to
the owner's ``on_setpoint(kind, value) -> reason | None`` callback, which applies the shared
validation (:func:`gear_rotor_sim.setpoints.check_setpoint`). A refused or unreadable setpoint is
logged with its reason and reported to every client as a warning status; it never stops a stream.
The callbacks run on the SDK's thread and only parse, validate and store.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from gear_rotor_sim.blocks import SampleBlock
from gear_rotor_sim.indicators import amplitude_spectrum, compute_indicators
from gear_rotor_sim.live import messages
from gear_rotor_sim.streams import StreamSpec

LOG = logging.getLogger("gear_rotor_sim.live")

#: The Foxglove app's default WebSocket port.
DEFAULT_PORT = 8765
#: Window of the indicators and the spectrum, simulated seconds (the monitor node's default).
DEFAULT_WINDOW_S = 0.5
#: Highest frequency sent in the DTE spectrum, Hz (above the 3rd mesh harmonic up to ~7000 rpm).
DEFAULT_SPECTRUM_MAX_HZ = 5000.0

SetpointHandler = Callable[[str, float], "str | None"]


class _Listener:
    """Foxglove ``ServerListener``: maps client channels to setpoint topics and forwards messages."""

    def __init__(self, server: LiveServer) -> None:
        self._server = server
        self._topics: dict[tuple[int, int], str] = {}
        self._lock = threading.Lock()

    def on_subscribe(self, client: Any, channel: Any) -> None:
        return None

    def on_unsubscribe(self, client: Any, channel: Any) -> None:
        return None

    def on_client_advertise(self, client: Any, channel: Any) -> None:
        with self._lock:
            self._topics[(client.id, channel.id)] = channel.topic
        if channel.topic not in messages.SETPOINT_TOPICS.values():
            self._server.refuse(
                f"client channel {channel.topic!r} is not a setpoint topic; "
                f"publish to one of {sorted(messages.SETPOINT_TOPICS.values())}"
            )
        elif channel.encoding != "json":
            self._server.refuse(f"{channel.topic}: encoding {channel.encoding!r} is not supported (json)")

    def on_client_unadvertise(self, client: Any, client_channel_id: int) -> None:
        with self._lock:
            self._topics.pop((client.id, client_channel_id), None)

    def on_message_data(self, client: Any, client_channel_id: int, data: bytes) -> None:
        with self._lock:
            topic = self._topics.get((client.id, client_channel_id), "")
        try:
            self._server.receive(topic, bytes(data))
        except Exception as exc:  # never let a client message take the server thread down
            LOG.exception("setpoint handling failed: %s", exc)


class LiveServer:
    """A Foxglove WebSocket server publishing the simulator's streams; see the module docstring.

    Parameters
    ----------
    streams : sequence of StreamSpec
        The sample streams (topics ``/gear_rotor/<name>``), as the node publishes them.
    on_setpoint : callable
        ``on_setpoint(kind, value) -> reason or None``: validates and stores a client setpoint
        (``kind`` is ``speed_rpm`` or ``temperature_c``); a returned reason means refused.
    port : int
        TCP port; 0 picks a free one (see :attr:`port`). Default 8765.
    host : str
        Address to bind; default ``127.0.0.1`` (this machine only).
    pinion_teeth : int
        Mesh order of the indicators (the pinion on the input shaft).
    window_s : float
        Window of the indicators and the spectrum, simulated seconds.
    spectrum_max_hz : float
        Highest frequency of the published DTE spectrum, Hz.
    """

    def __init__(
        self,
        streams: Sequence[StreamSpec],
        on_setpoint: SetpointHandler,
        port: int = DEFAULT_PORT,
        host: str = "127.0.0.1",
        pinion_teeth: int = 29,
        window_s: float = DEFAULT_WINDOW_S,
        spectrum_max_hz: float = DEFAULT_SPECTRUM_MAX_HZ,
        name: str = "gear_rotor_sim",
    ) -> None:
        import foxglove
        from foxglove.websocket import Capability

        if not 0 <= int(port) <= 65535:
            raise ValueError(f"port: {port} is outside 0..65535 (0 picks a free port)")
        if not window_s > 0:
            raise ValueError(f"window_s: {window_s} must be > 0")
        self.streams = list(streams)
        self._on_setpoint = on_setpoint
        self.pinion_teeth = int(pinion_teeth)
        self.window_s = float(window_s)
        self.spectrum_max_hz = float(spectrum_max_hz)
        self.accepted = 0
        self.refused = 0
        self.last_refusal = ""
        self._count_lock = threading.Lock()
        self._context = foxglove.Context()

        def cdr_channel(topic: str, schema: messages.CdrSchema) -> foxglove.Channel:
            ros2msg = foxglove.Schema(name=schema.name, encoding="ros2msg", data=schema.text.encode())
            return foxglove.Channel(topic, schema=ros2msg, message_encoding="cdr", context=self._context)

        self._channels = {s.name: cdr_channel(s.topic, messages.chunk_schema(s)) for s in self.streams}
        self._dte = next((s for s in self.streams if "dte" in s.channels), None)
        self._indicators = self._spectrum = None
        if self._dte is not None:
            self._indicators = cdr_channel(messages.INDICATORS_TOPIC, messages.INDICATORS_SCHEMA)
            self._spectrum = cdr_channel(messages.SPECTRUM_TOPIC, messages.SPECTRUM_SCHEMA)
        self._status = foxglove.Channel(
            messages.STATUS_TOPIC, schema=messages.STATUS_SCHEMA, context=self._context
        )
        self._sequence = {s.name: 0 for s in self.streams}
        self._window: list[SampleBlock] = []
        self._listener = _Listener(self)
        self._server = foxglove.start_server(
            name=name,
            host=host,
            port=int(port),
            capabilities=[Capability.ClientPublish, Capability.Time],
            supported_encodings=["json"],
            server_listener=self._listener,
            context=self._context,
        )

    @property
    def port(self) -> int:
        """The TCP port the server listens on."""
        return int(self._server.port)

    # ------------------------------------------------------------------------------- setpoints
    def receive(self, topic: str, payload: bytes) -> str | None:
        """Handle one client message on ``topic``; returns the refusal reason or None if accepted."""
        kind = next((k for k, t in messages.SETPOINT_TOPICS.items() if t == topic), None)
        if kind is None:
            return self.refuse(
                f"message on {topic or 'an unadvertised channel'!r} ignored: not a setpoint topic "
                f"({sorted(messages.SETPOINT_TOPICS.values())})"
            )
        try:
            value = messages.parse_setpoint(topic, payload)
        except messages.SetpointError as exc:
            return self.refuse(str(exc))
        reason = self._on_setpoint(kind, value)
        if reason is not None:
            return self.refuse(reason)
        with self._count_lock:
            self.accepted += 1
        LOG.info("setpoint accepted: %s = %g", kind, value)
        return None

    def refuse(self, reason: str) -> str:
        """Count, log and report a refused client message to every client (warning status)."""
        from foxglove import StatusLevel

        with self._count_lock:
            self.refused += 1
            self.last_refusal = reason
        LOG.warning("setpoint refused, running state unchanged: %s", reason)
        self._server.publish_status(
            f"setpoint refused, running state unchanged: {reason}", StatusLevel.Warning, "setpoint"
        )
        return reason

    # ------------------------------------------------------------------------------- publishing
    def publish(self, block: SampleBlock) -> None:
        """Publish one block: a message per stream, then the window's indicators and spectrum."""
        log_time = round(block.t0 * 1e9)
        for spec in self.streams:
            seq = self._sequence[spec.name]
            self._channels[spec.name].log(messages.chunk_message(block, spec, seq), log_time=log_time)
            self._sequence[spec.name] = seq + 1
        self._server.broadcast_time(round((block.t0 + block.n_samples / block.sample_rate_hz) * 1e9))
        if self._dte is not None:
            self._publish_window(block.select(self._dte.channels))

    def _publish_window(self, block: SampleBlock) -> None:
        need = round(self.window_s * block.sample_rate_hz)
        if self._window and (
            self._window[-1].first_index + self._window[-1].n_samples != block.first_index
            or self._window[-1].sample_rate_hz != block.sample_rate_hz
        ):
            self._window = []  # not contiguous: indicators only over contiguous samples
        self._window.append(block)
        while self._window and sum(b.n_samples for b in self._window[1:]) >= need:
            self._window.pop(0)
        have = sum(b.n_samples for b in self._window)
        if have < need:
            return
        win = SampleBlock.concatenate(self._window)
        data = win.data[-need:]
        t0 = win.t0 + (win.n_samples - need) / win.sample_rate_hz
        speed = float(block.speed_rpm[-1]) if block.speed_rpm.size else 0.0
        ind = compute_indicators(data, win.sample_rate_hz, speed, self.pinion_teeth)
        assert self._indicators is not None and self._spectrum is not None
        log_time = round(t0 * 1e9)
        frame = self._dte.frame_id
        self._indicators.log(
            messages.indicators_message(ind, t0, frame, self._dte.topic, list(win.channels), speed),
            log_time=log_time,
        )
        k = win.channels.index("dte")
        freqs, amp = amplitude_spectrum(data[:, k], win.sample_rate_hz)
        keep = freqs <= self.spectrum_max_hz
        self._spectrum.log(
            messages.spectrum_message(
                freqs[keep],
                amp[keep, 0],
                t0,
                frame,
                self._dte.topic,
                "dte",
                win.units[k],
                need / win.sample_rate_hz,
                speed,
                float(ind.mesh_frequency_hz),
            ),
            log_time=log_time,
        )

    def publish_status(self, fields: dict[str, float], t: float) -> None:
        """Publish ``/gear_rotor/status`` (``fields``: :data:`messages.STATUS_FIELDS`)."""
        with self._count_lock:
            msg = messages.status_message(
                fields, t, self.accepted, self.refused, self.last_refusal, time.time()
            )
        self._status.log(msg, log_time=round(t * 1e9))

    def stop(self) -> None:
        """Stop the server (clients are disconnected); idempotent."""
        self._server.stop()
