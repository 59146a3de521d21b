"""The probe at the start of a run: can the suite talk to the target, how fast, and what it offers.

Connect to the main port, PING five times (the median round trip sets every deadline), then ask
GET_CAPABILITIES: `CAPABILITIES` lists the extensions and limits (OA-SESS-23, OA-CAP-1);
`UNKNOWN_COMMAND` (or any other answer) means a legacy server, core only (OA-CAP-2).
"""

from __future__ import annotations

import asyncio
import statistics
import time

from lxml import etree

from openair.protocol.message import Message
from openair_conformance.harness.conn import (
    ConnectionLost,
    DecodeProblem,
    RequesterChannel,
    open_stream,
)
from openair_conformance.harness.trace import Trace
from openair_conformance.model import ServerInfo

__all__ = ["PROBE_NAME", "TargetUnreachable", "parse_capabilities_xml", "probe"]

PROBE_NAME = "ConformanceProbe"
_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)


class TargetUnreachable(Exception):
    """The target cannot be connected to, or does not answer PING."""


async def probe(host: str, port: int, *, timeout: float = 10.0, pings: int = 5) -> ServerInfo:
    """Measure the round-trip time and read the capabilities of the server at host:port."""
    trace = Trace()
    try:
        stream = await open_stream(host, port, label="probe", trace=trace, timeout=timeout)
    except ConnectionLost as exc:
        raise TargetUnreachable(str(exc)) from exc
    channel = RequesterChannel(stream, name=PROBE_NAME, pipelining=False)
    channel.start()
    try:
        rtts = [await _round_trip(channel, "PING", timeout) for _ in range(pings)]
        try:
            reply = await _request(channel, "GET_CAPABILITIES", timeout)
        except TargetUnreachable:
            reply = None  # a server that ignores the command is treated as legacy
    finally:
        await channel.close()
    rtt_ms = statistics.median(rtts) * 1000.0
    if reply is None or reply.type != "CAPABILITIES":
        return ServerInfo(legacy=True, rtt_ms=rtt_ms)
    return _server_info(reply, rtt_ms)


async def _request(channel: RequesterChannel, type: str, timeout: float) -> Message:
    try:
        _, future = await channel.send(Message(type=type, sender=PROBE_NAME, to="CNS"))
        return await asyncio.wait_for(future, timeout)
    except TimeoutError as exc:
        raise TargetUnreachable(f"no reply to {type} within {timeout:.1f} s") from exc
    except (ConnectionLost, DecodeProblem) as exc:
        raise TargetUnreachable(f"{type}: {exc}") from exc


async def _round_trip(channel: RequesterChannel, type: str, timeout: float) -> float:
    started = time.monotonic()
    await _request(channel, type, timeout)
    return time.monotonic() - started


def parse_capabilities_xml(
    content: str,
) -> tuple[str, str, tuple[str, ...], tuple[tuple[str, int], ...]]:
    """Read `<capabilities protocol server>` → (protocol, server, extensions, limits).

    Element and attribute names are compared case-insensitively (OA-MSG-3); limits whose value
    is not an integer are skipped. ValueError if the content is not a capabilities element.
    """
    try:
        wrapper = etree.fromstring(f"<c>{content}</c>".encode(), _PARSER)
    except etree.XMLSyntaxError as exc:
        raise ValueError(f"CAPABILITIES content is not XML: {exc}") from exc
    roots = [el for el in wrapper if isinstance(el.tag, str)]
    if len(roots) != 1 or str(roots[0].tag).lower() != "capabilities":
        raise ValueError("CAPABILITIES content is not one <capabilities> element")
    root = roots[0]
    attrs = {str(k).lower(): str(v) for k, v in root.attrib.items()}
    extensions: list[str] = []
    limits: list[tuple[str, int]] = []
    for child in root:
        if not isinstance(child.tag, str):
            continue
        child_attrs = {str(k).lower(): str(v) for k, v in child.attrib.items()}
        tag = str(child.tag).lower()
        if tag == "extension" and child_attrs.get("name"):
            extensions.append(child_attrs["name"])
        elif tag == "limit" and child_attrs.get("name"):
            try:
                limits.append((child_attrs["name"], int(child_attrs.get("value", ""))))
            except ValueError:
                continue
    return attrs.get("protocol", ""), attrs.get("server", ""), tuple(extensions), tuple(limits)


def _server_info(reply: Message, rtt_ms: float) -> ServerInfo:
    try:
        protocol, server, extensions, limits = parse_capabilities_xml(reply.content)
    except ValueError:
        # Not legacy (it knows the command), but nothing usable is advertised: core only.
        return ServerInfo(legacy=False, rtt_ms=rtt_ms)
    return ServerInfo(
        legacy=False,
        capabilities=extensions,
        limits=limits,
        rtt_ms=rtt_ms,
        server=server,
        protocol=protocol,
    )
