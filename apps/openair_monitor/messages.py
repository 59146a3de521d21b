"""Messages as the monitor shows them: filters, one-line summaries and every slot of one message.

The type filter is the trigger matcher itself (`openair.protocol.matching.matches`, OA-MATCH-8), so
a pattern typed in the whiteboard view selects exactly what a trigger with that pattern would
wake on. The sender and content filters are globs where `*` is any run of characters and all
else is literal (the retrieve `content` glob, OA-RET-8; for XML content the text of its
elements, OA-RET-13).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from openair.observing import Delivered
from openair.protocol.contentmatch import content_glob, text_of
from openair.protocol.errors import OpenAIRError
from openair.protocol.matching import matches
from openair.protocol.message import Message, Reference
from openair.protocol.times import AirTime
from openair.protocol.types import validate_pattern
from openair.protocol.wakeup import parse_wakeup

__all__ = ["MessageFilter", "detail", "summary", "time_json"]

_PREVIEW = 160  # characters of content in a summary
_TYPE_CACHE = 1024  # types remembered per filter
_NS_PER_MS = 1_000_000


@dataclass(frozen=True, slots=True, kw_only=True)
class MessageFilter:
    """Which stored messages to show: whiteboard (exact), type pattern, sender and content glob.

    Empty strings mean "any". Build it with `MessageFilter.checked` to validate the pattern
    (OA-MATCH-7) before use.
    """

    whiteboard: str = ""
    pattern: str = ""
    sender: str = ""
    content: str = ""

    @classmethod
    def checked(
        cls, *, whiteboard: str = "", pattern: str = "", sender: str = "", content: str = ""
    ) -> MessageFilter:
        """Return a filter; raise PatternInvalidError for an invalid pattern (OA-MATCH-7)."""
        pattern = pattern.strip()
        if pattern and pattern != "*":
            validate_pattern(pattern)
        else:
            pattern = ""
        return cls(whiteboard=whiteboard, pattern=pattern, sender=sender, content=content)

    @property
    def is_open(self) -> bool:
        """True when the filter lets every message of its whiteboard(s) through."""
        return not (self.pattern or self.sender or self.content)

    def compile(self) -> Callable[[Message], bool]:
        """Return the predicate; it caches the pattern's verdict per type."""
        checks: list[Callable[[Message], bool]] = []
        if self.whiteboard:
            board = self.whiteboard
            checks.append(lambda m: m.stored == board)
        if self.pattern:
            pattern, seen = self.pattern, dict[str, bool]()

            def type_ok(m: Message) -> bool:
                hit = seen.get(m.type)
                if hit is None:
                    hit = matches(pattern, m.type)  # the trigger matcher (OA-MATCH-8)
                    if len(seen) < _TYPE_CACHE:
                        seen[m.type] = hit
                return hit

            checks.append(type_ok)
        if self.sender:
            sender_ok = content_glob(self.sender)
            checks.append(lambda m: sender_ok(m.sender))
        if self.content:
            content_ok = content_glob(self.content)  # OA-RET-8
            checks.append(lambda m: content_ok(text_of(m)))  # OA-RET-13
        if not checks:
            return lambda m: True
        if len(checks) == 1:
            return checks[0]  # the common case (a whiteboard view without filters): no loop
        return lambda m: all(check(m) for check in checks)


def time_json(t: AirTime | None) -> dict[str, object] | None:
    """Return a time as {sec, msec, usec, ms, text}, or None when absent."""
    if t is None:
        return None
    return {"sec": t.sec, "msec": t.msec, "usec": t.usec, "ms": t.ms, "text": str(t)}


def latency_ms(msg: Message) -> float | None:
    """Return receivedTime − postedTime in ms (the two clocks may differ), or None.

    Microseconds count only when both times carry them: a stored copy's receivedTime has
    none, and comparing it with a postedTime that has would make latency falsely negative.
    """
    posted, received = msg.posted, msg.received
    if posted is None or received is None:
        return None
    if posted.usec is None or received.usec is None:
        return float(received.ms - posted.ms)
    return (received.us - posted.us) / 1000


def summary(
    msg: Message, deliveries: tuple[Delivered, ...] | None, seq: int | None
) -> dict[str, object]:
    """Return the one-line form of a stored message (whiteboard lists, event streams)."""
    content = msg.content
    return {
        "seq": seq,
        "whiteboard": msg.stored,
        "wbid": msg.wbid,
        "id": msg.id,
        "type": msg.type,
        "from": msg.sender,
        "to": msg.to,
        "cc": msg.cc,
        "posted_ms": msg.posted.ms if msg.posted is not None else None,
        "received_ms": msg.received.ms if msg.received is not None else None,
        "latency_ms": latency_ms(msg),
        "priority": msg.effective_priority,
        "xml": msg.content_is_xml,
        "size": len(content),
        "preview": content[:_PREVIEW],
        "wakeups": None if deliveries is None else len(deliveries),
        "attachments": len(msg.binary),  # OA-WB-13
        "attachment_bytes": sum(len(chunk) for chunk in msg.binary),
    }


def _reference(ref: Reference | None) -> dict[str, object] | None:
    if ref is None:
        return None
    return {
        "id": ref.id,
        "stored": ref.stored,
        "type": ref.type,
        "from": ref.sender,
        "to": ref.to,
        "cc": ref.cc,
        "time": time_json(ref.time),
    }


def _slots(msg: Message) -> dict[str, object]:
    """Every slot of the message, named as on the wire."""
    return {
        "type": msg.type,
        "id": msg.id,
        "from": msg.sender,
        "to": msg.to,
        "cc": msg.cc,
        "stored": msg.stored,
        "isresponse": msg.isresponse,
        "inreplyto": _reference(msg.inreplyto),
        "postedTime": time_json(msg.posted),
        "receivedTime": time_json(msg.received),
        "priority": msg.priority,
        "timetolive": msg.timetolive,
        "noreply": msg.noreply,
        "comment": msg.comment,
        "history": msg.history,
        "wbid": msg.wbid,
        "netprotocol": msg.netprotocol,
        "language": msg.language,
        "content": msg.content,
        "contentIsXml": msg.content_is_xml,
        "contentVersion": msg.content_version,
        "binarysizes": [len(chunk) for chunk in msg.binary],
        "extras": [{"name": s.name, "value": s.value, "xml": s.is_xml} for s in msg.extras],
    }


def _wakeup(delivery: Delivered, stored: Message) -> dict[str, object]:
    """Describe one wakeup a post caused: module, delay, the trigger that fired or cc."""
    lasttrigger: str | None
    try:
        lasttrigger = parse_wakeup(delivery.message).lasttrigger  # read only when asked
    except (OpenAIRError, ValueError):
        lasttrigger = None
    base = stored.received.ms * _NS_PER_MS if stored.received is not None else delivery.due_ns
    by_cc = lasttrigger == "" and delivery.module in stored.cc_names  # OA-CC-2
    return {
        "module": delivery.module,
        "id": delivery.message.id,
        "after_ms": max(0, (delivery.due_ns - base) // _NS_PER_MS),
        "lasttrigger": lasttrigger,
        "cause": "cc" if by_cc else "trigger",
        "priority": delivery.priority,
    }


def detail(msg: Message, deliveries: tuple[Delivered, ...] | None) -> dict[str, object]:
    """Return a stored message with every slot, its latency, cc list and the wakeups it caused.

    `deliveries` is None when the post is older than the monitor's ring: its wakeups are then
    unknown (the whiteboard keeps messages, not the wakeups they caused).
    """
    return {
        "whiteboard": msg.stored,
        "wbid": msg.wbid,
        "slots": _slots(msg),
        "latency_ms": latency_ms(msg),
        "cc": list(msg.cc_names),
        "wakeups_known": deliveries is not None,
        "wakeups": [] if deliveries is None else [_wakeup(d, msg) for d in deliveries],
    }
