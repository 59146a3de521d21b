"""Compare decoded messages with the `fields` of a vector manifest (messages/ and legacy/).

The manifests write times as [sec, msec(, usec)], references as objects, extras as
[name, value, is_xml] and binary chunks as hex; these helpers turn a decoded `Message` and the
manifest's values into the same representation so both vector suites check fields one way.
"""

from __future__ import annotations

from typing import Any

from openair.protocol.codec import message_from_element
from openair.protocol.message import Message, Reference
from openair.protocol.times import AirTime
from openair.protocol.xmlsafe import parse_fragment


def manifest_time(value: list[int] | None) -> AirTime | None:
    """Return the AirTime a manifest writes as [sec, msec] or [sec, msec, usec]."""
    if value is None:
        return None
    return AirTime(sec=value[0], msec=value[1], usec=value[2] if len(value) > 2 else None)


def _reference(value: dict[str, Any] | None) -> Reference | None:
    if value is None:
        return None
    return Reference(
        id=value["id"],
        type=value["type"],
        sender=value["from"],
        to=value["to"],
        cc=value["cc"],
        stored=value["stored"],
        time=manifest_time(value["time"]),
    )


def _actual(msg: Message, key: str) -> Any:
    """Return the field `key` of the manifest in the manifest's own representation."""
    if key == "extras":
        return [[s.name, s.value, s.is_xml] for s in msg.extras]
    if key == "binary":
        return [chunk.hex() for chunk in msg.binary]
    return getattr(msg, key)


def _expected(key: str, value: Any) -> Any:
    if key in ("posted", "received"):
        return manifest_time(value)
    if key == "inreplyto":
        return _reference(value)
    return value


def check_fields(msg: Message, fields: dict[str, Any]) -> None:
    """Assert that every field the manifest names has the manifest's value."""
    for key, value in fields.items():
        assert _actual(msg, key) == _expected(key, value), key


def first_nested(msg: Message) -> Message:
    """Return the first <message> inside the XML content (a stored copy)."""
    for root in parse_fragment(msg.content):
        for el in root.iter():
            if isinstance(el.tag, str) and el.tag.lower() == "message":
                return message_from_element(el)
    raise AssertionError("no nested message in the content")
