"""The server's configuration: its limits (spec 14.1), and the psySpec file it runs (spec 12).

The psySpec itself (`load_config`, `parse_config`, `ServerConfig`, `name_problem`, …) is read by
`openair.protocol.psyspec`, role-neutral, so that the applications beside the core (the ontology
tools) read a system's modules without importing the server (issue #17); the server's modules
import those names from here, where its configuration is.
"""

from __future__ import annotations

from dataclasses import dataclass

from openair.protocol.framing import FrameLimits
from openair.protocol.psyspec import (
    AIRCENTRAL,
    DEFAULT_MAXCOUNT,
    DEFAULT_WB_PRIORITY,
    SYSTEM_COMPONENTS,
    ConfigError,
    ModuleConfig,
    ServerConfig,
    StreamConfig,
    WhiteboardConfig,
    default_config,
    load_config,
    name_problem,
    parse_config,
)
from openair.protocol.xmlsafe import XmlLimits

__all__ = [
    "AIRCENTRAL",
    "DEFAULT_MAXCOUNT",
    "DEFAULT_WB_PRIORITY",
    "SYSTEM_COMPONENTS",
    "ConfigError",
    "ModuleConfig",
    "ServerConfig",
    "ServerLimits",
    "StreamConfig",
    "WhiteboardConfig",
    "default_config",
    "load_config",
    "name_problem",
    "parse_config",
]

MIB = 1024 * 1024


@dataclass(frozen=True, slots=True, kw_only=True)
class ServerLimits:
    """The server's limits (spec 14.1); `advertised()` gives them as CAPABILITIES names them."""

    max_frame_xml: int = 16 * MIB  # OA-LIM-1
    max_frame_binary: int = 64 * MIB  # OA-LIM-2
    max_xml_depth: int = 64  # OA-LIM-3
    max_in_flight: int = 256  # OA-LIM-5
    max_queue: int = 10_000  # OA-DELIV-8
    delivery_retries: int = 2  # OA-DELIV-15: retries of a failed delivery (OA-DELIV-7)
    retry_deadline_ms: int = 1_000  # OA-DELIV-15: a retry starts this soon after the failure
    ack_deadline_ms: int = 10_000  # OA-DELIV-11: a delivery unanswered this long has failed
    max_triggers: int = 1024  # OA-LIM-6
    max_type_bytes: int = 255  # OA-TYPE-4
    max_type_segments: int = 32  # OA-TYPE-4
    frame_deadline_ms: int = 30_000  # OA-FRAME-12
    stream_push_buffer: int = 100  # OA-STREAM-8: samples buffered per push subscriber
    max_wait_ms: int = 60_000  # OA-STREAM-7: a longer WAIT_FOR_* timeout is clipped to this
    # Byte budgets (issue #19): what one peer can make the server hold, counted in bytes.
    max_queue_bytes: int = 64 * MIB  # OA-LIM-8: per module delivery queue
    max_wakeup_results: int = 1_000  # OA-LIM-9: retrieved messages per wakeup
    max_wakeup_result_bytes: int = 4 * MIB  # OA-LIM-9: their content bytes per wakeup
    max_history_bytes: int = 256 * MIB  # OA-LIM-10: stored copies per whiteboard
    max_connections: int = 1_024  # OA-LIM-11: open connections in total
    max_connections_per_peer: int = 256  # OA-LIM-11: from one peer address
    max_partial_bytes: int = 256 * MIB  # OA-LIM-12: unfinished frames, all connections
    frame_total_deadline_ms: int = 120_000  # OA-LIM-13: one whole frame, first byte to last
    max_held_bytes: int = 1024 * MIB  # OA-LIM-14: stored copies and queued deliveries in all
    module_retention_ms: int = 3_600_000  # OA-LIM-15: counters of a module gone this long go
    stream_push_buffer_bytes: int = 16 * MIB  # OA-LIM-16: payload per subscriber and stream
    max_created_streams: int = 64  # OA-LIM-17: streams created at run time
    max_created_stream_bytes: int = 64 * MIB  # OA-LIM-17: maxsize of one created at run time

    def __post_init__(self) -> None:
        for name in self.__slots__:
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"limit {name} must be a positive integer, not {value!r}")

    def advertised(self) -> tuple[tuple[str, int], ...]:
        """Return the limits under their spec 14.1 names, in table order (OA-LIM-4)."""
        return (
            ("max-frame-xml", self.max_frame_xml),
            ("max-frame-binary", self.max_frame_binary),
            ("max-xml-depth", self.max_xml_depth),
            ("max-in-flight", self.max_in_flight),
            ("max-queue", self.max_queue),
            ("delivery-retries", self.delivery_retries),
            ("retry-deadline-ms", self.retry_deadline_ms),
            ("ack-deadline-ms", self.ack_deadline_ms),
            ("max-triggers", self.max_triggers),
            ("max-type-bytes", self.max_type_bytes),
            ("max-type-segments", self.max_type_segments),
            ("frame-deadline-ms", self.frame_deadline_ms),
            ("max-queue-bytes", self.max_queue_bytes),
            ("max-wakeup-results", self.max_wakeup_results),
            ("max-wakeup-result-bytes", self.max_wakeup_result_bytes),
            ("max-history-bytes", self.max_history_bytes),
            ("max-connections", self.max_connections),
            ("max-connections-per-peer", self.max_connections_per_peer),
            ("max-partial-bytes", self.max_partial_bytes),
            ("frame-total-deadline-ms", self.frame_total_deadline_ms),
            ("max-held-bytes", self.max_held_bytes),
            ("module-retention-ms", self.module_retention_ms),
            ("stream-push-buffer-bytes", self.stream_push_buffer_bytes),
            ("max-created-streams", self.max_created_streams),
            ("max-created-stream-bytes", self.max_created_stream_bytes),
        )

    def frame_limits(self) -> FrameLimits:
        """Return the frame reader's limits (OA-LIM-1, OA-LIM-2)."""
        return FrameLimits(max_xml=self.max_frame_xml, max_binary=self.max_frame_binary)

    def xml_limits(self) -> XmlLimits:
        """Return the XML parser's limits (OA-LIM-1, OA-LIM-3)."""
        return XmlLimits(max_bytes=self.max_frame_xml, max_depth=self.max_xml_depth)
