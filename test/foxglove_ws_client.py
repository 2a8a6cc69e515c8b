"""A small client of the Foxglove WebSocket protocol (the Foxglove app's side), for the tests.

Written from the protocol specification (ws-protocol ``docs/spec.md``), independent of the server
code: JSON text frames with an ``op`` field (``serverInfo``, ``advertise``, ``status``, ...), binary
frames with a 1-byte opcode (``0x01`` message data: uint32 subscription id, uint64 log time in ns,
payload; ``0x02`` time: uint64 ns); the client subscribes, advertises its own channels and sends
``0x01`` client message data (uint32 client channel id, payload). All little-endian.

Messages are decoded with the schema the server advertised: ``json`` payloads are parsed (and may be
checked with :func:`validate` against the ``jsonschema``), ``cdr`` payloads are decoded by the
``mcap-ros2-support`` decoder built from the advertised ``ros2msg`` text (an independent reader).
"""

from __future__ import annotations

import collections
import json
import struct
import time
from dataclasses import dataclass, field
from typing import Any

from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
from websockets.sync.client import connect

SUBPROTOCOL = "foxglove.sdk.v1"


@dataclass
class Received:
    topic: str
    log_time_ns: int
    message: Any


@dataclass
class FoxgloveClient:
    """Connects, records advertised channels and statuses, decodes JSON messages of subscriptions."""

    url: str
    server_info: dict = field(default_factory=dict)
    channels: dict[int, dict] = field(default_factory=dict)
    statuses: list[dict] = field(default_factory=list)
    server_time_ns: int | None = None

    def __post_init__(self) -> None:
        self._ws = connect(self.url, subprotocols=[SUBPROTOCOL], max_size=None, open_timeout=10)
        self._subs: dict[int, int] = {}  # subscription id -> channel id
        self._next_sub = 1
        self._next_client_channel = 1
        self._decoders: dict[int, Any] = {}
        self._pending: collections.deque[Received] = collections.deque()  # kept by wait_for

    def close(self) -> None:
        self._ws.close()

    @property
    def subprotocol(self) -> str | None:
        return self._ws.subprotocol

    def topics(self) -> dict[str, dict]:
        return {c["topic"]: c for c in self.channels.values()}

    def _handle(self, frame: str | bytes) -> Received | None:
        if isinstance(frame, str):
            msg = json.loads(frame)
            op = msg.get("op")
            if op == "serverInfo":
                self.server_info = msg
            elif op == "advertise":
                for ch in msg["channels"]:
                    self.channels[int(ch["id"])] = ch
            elif op == "unadvertise":
                for cid in msg["channelIds"]:
                    self.channels.pop(int(cid), None)
            elif op == "status":
                self.statuses.append(msg)
            return None
        opcode = frame[0]
        if opcode == 0x01:
            sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
            channel = self.channels[self._subs[sub_id]]
            payload = frame[13:]
            return Received(channel["topic"], log_time, self._decode(channel, payload))
        if opcode == 0x02:
            (self.server_time_ns,) = struct.unpack_from("<Q", frame, 1)
        return None

    def _decode(self, channel: dict, payload: bytes) -> Any:
        if channel["encoding"] == "json":
            return json.loads(payload.decode("utf-8"))
        if channel["encoding"] != "cdr" or channel.get("schemaEncoding") != "ros2msg":
            raise AssertionError(f"{channel['topic']}: unexpected encoding {channel['encoding']!r}")
        cid = int(channel["id"])
        if cid not in self._decoders:
            schema = Schema(
                id=cid, name=channel["schemaName"], encoding="ros2msg", data=channel["schema"].encode()
            )
            self._decoders[cid] = DecoderFactory().decoder_for("cdr", schema)
        return self._decoders[cid](payload)

    def poll(self, timeout_s: float) -> Received | None:
        """Handle frames until one message of a subscription arrives (None after ``timeout_s``)."""
        if self._pending:
            return self._pending.popleft()
        deadline = time.monotonic() + timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            try:
                frame = self._ws.recv(timeout=left)
            except TimeoutError:
                return None
            got = self._handle(frame)
            if got is not None:
                return got

    def wait_for(self, predicate, timeout_s: float) -> None:
        """Handle frames until ``predicate(self)`` is true (messages received meanwhile are kept for
        :meth:`poll`); AssertionError after ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while not predicate(self):
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"timed out after {timeout_s} s waiting on {self.url}")
            try:
                got = self._handle(self._ws.recv(timeout=left))
            except TimeoutError:
                continue
            if got is not None:
                self._pending.append(got)

    def subscribe(self, topics: list[str]) -> None:
        by_topic = self.topics()
        subs = []
        for t in topics:
            sid = self._next_sub
            self._next_sub += 1
            self._subs[sid] = int(by_topic[t]["id"])
            subs.append({"id": sid, "channelId": int(by_topic[t]["id"])})
        self._ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def advertise(self, topic: str, schema_name: str, schema: dict) -> int:
        cid = self._next_client_channel
        self._next_client_channel += 1
        ch = {
            "id": cid,
            "topic": topic,
            "encoding": "json",
            "schemaName": schema_name,
            "schema": json.dumps(schema),
            "schemaEncoding": "jsonschema",
        }
        self._ws.send(json.dumps({"op": "advertise", "channels": [ch]}))
        time.sleep(0.5)  # the protocol acknowledges no advertisement; a message sent at once may be lost
        return cid

    def publish(self, client_channel_id: int, payload: bytes) -> None:
        self._ws.send(struct.pack("<BI", 0x01, client_channel_id) + payload)


_TYPES = {
    "object": dict,
    "array": list,
    "string": str,
    "integer": int,
    "number": (int, float),
    "boolean": bool,
    "null": type(None),
}


def validate(value: Any, schema: dict, path: str = "$") -> None:
    """Check ``value`` against the JSON-schema subset the server advertises (type, properties,
    required, items, minimum); AssertionError naming the path otherwise."""
    types = schema.get("type")
    if types is not None:
        names = types if isinstance(types, list) else [types]
        ok = any(
            isinstance(value, _TYPES[n]) and not (n in ("integer", "number") and isinstance(value, bool))
            for n in names
        )
        assert ok, f"{path}: {type(value).__name__} is not {names}"
    if isinstance(value, dict):
        for key in schema.get("required", []):
            assert key in value, f"{path}: required field {key!r} missing"
        for key, sub in schema.get("properties", {}).items():
            if key in value:
                validate(value[key], sub, f"{path}.{key}")
    if isinstance(value, list) and "items" in schema:
        for i, v in enumerate(value):
            validate(v, schema["items"], f"{path}[{i}]")
    if "minimum" in schema and isinstance(value, int | float):
        assert value >= schema["minimum"], f"{path}: {value} < {schema['minimum']}"
