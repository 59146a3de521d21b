"""What the monitor pages show, as JSON-ready dicts: overview, whiteboard lists, modules, graph.

Every view reads the server's memory (counters, sessions, whiteboards) and the tap's ring when
it is asked for; nothing here runs in the post path. Times are Unix milliseconds; rates are per
second over the last few seconds (`RateMeter`) or over the graph window.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from typing import TYPE_CHECKING

from openair.protocol.content import Phase, Registration, RetrieveSpec
from openair.protocol.message import Message
from openair_monitor.messages import MessageFilter, detail, summary
from openair_monitor.tap import Event

if TYPE_CHECKING:
    from openair_monitor.core import Monitor

__all__ = [
    "find_message",
    "graph",
    "module_detail",
    "modules",
    "overview",
    "stream_infos",
    "whiteboard_messages",
    "whiteboards",
]

_NS_PER_MS = 1_000_000
_GRAPH_TYPES = 40  # the busiest types drawn; the rest are summed into one node
_RECENT_WAKEUPS = 50
_SCAN_LIMIT = 5000  # stored messages a history query reads at most (content globs parse XML)
_NODE_KINDS = {"src": "sender", "type": "type", "wb": "whiteboard", "dst": "receiver"}


Table = dict[str, dict[str, object]]  # name -> counters, as Server.counters() nests them


def _table(counters: Mapping[str, object], key: str) -> Table:
    """Return one nested table of the server's counters, skipping what is not a mapping."""
    value = counters.get(key)
    if not isinstance(value, Mapping):
        return {}
    return {str(k): dict(v) for k, v in value.items() if isinstance(v, Mapping)}


def _int(value: object) -> int:
    return value if isinstance(value, int) else 0


def whiteboards(
    mon: Monitor, now: float, counters: Mapping[str, object] | None = None
) -> list[dict[str, object]]:
    """Each whiteboard's counters, size against maxcount, and post rate."""
    boards = _table(counters or mon.server.counters(), "whiteboards")
    out: list[dict[str, object]] = []
    for name in mon.server.whiteboards:
        wb = mon.server.whiteboard(name)
        c = boards.get(name, {})
        received = _int(c.get("received"))
        out.append(
            {
                "name": name,
                "received": received,
                "stored": c.get("stored"),
                "dispatched": c.get("dispatched"),
                "evicted": c.get("evicted"),
                "count": c.get("count"),
                "maxcount": wb.maxcount if wb is not None else None,
                "priority": wb.priority if wb is not None else None,
                "rate": mon.rates.rate(f"wb:{name}", now, received),
            }
        )
    return out


def _reg_summary(reg: Registration | None) -> dict[str, object]:
    if reg is None:
        return {"triggers": 0, "retrieves": 0, "patterns": []}
    triggers = reg.triggers
    phase = reg.active_phase
    return {
        "triggers": len(triggers),
        "retrieves": len(phase.retrieves) if phase is not None else 0,
        "patterns": [t.pattern for t in triggers[:8]],
    }


def modules(
    mon: Monitor, now: float, counters: Mapping[str, object] | None = None
) -> list[dict[str, object]]:
    """Each module the server knows (bound now, or counted before): session, traffic, queue."""
    counters = counters or mon.server.counters()
    per_module, queues = _table(counters, "modules"), _table(counters, "queues")
    server = mon.server
    names = sorted(set(per_module) | set(queues) | mon.bound_names(counters))
    out: list[dict[str, object]] = []
    for name in names:
        info = server.module(name)
        c, q = per_module.get(name, {}), queues.get(name, {})
        posted, delivered = _int(c.get("requests")), _int(c.get("delivered"))
        out.append(
            {
                "name": name,
                "bound": info is not None,
                "since_ms": mon.since_ms(name, info.conn if info is not None else None),
                "port": info.port if info is not None else None,
                "address": info.address if info is not None else None,
                "callback": info is not None and info.callback is not None,
                "extensions": sorted(info.extensions) if info is not None else [],
                "posted": posted,
                "queued": c.get("queued", 0),
                "delivered": delivered,
                "dropped": _int(c.get("dropped")),
                "failed": q.get("failed", 0),
                "depth": q.get("depth", 0),
                "posted_rate": mon.rates.rate(f"out:{name}", now, posted),
                "delivered_rate": mon.rates.rate(f"in:{name}", now, delivered),
                "last_type": mon.tap.last_type.get(name),
                "registration": _reg_summary(server.registration(name)),
            }
        )
    return out


def _fill(info: Mapping[str, str], size_limits: str, count_limits: str) -> float | None:
    """Return the fuller of size and count, each against the first of its limits present."""
    fills = []
    for used_key, limit_keys in (("size", size_limits), ("count", count_limits)):
        used = _number(info.get(used_key))
        for key in limit_keys.split(","):
            bound = _number(info.get(key))
            if bound:  # 0 or absent: no limit of this kind
                if used is not None:
                    fills.append(used / bound)
                break
    return max(fills) if fills else None


def stream_infos(
    mon: Monitor, now: float, counters: Mapping[str, object] | None = None
) -> list[dict[str, object]]:
    """Each stream's info, with its sample rate and fill against the soft and hard limits.

    The hard limit is `hardsize`/`hardcount` for a typed stream, else `maxsize`/`maxcount`.
    """
    out: list[dict[str, object]] = []
    for name, info in mon.streams(counters).items():
        row: dict[str, object] = {"name": name, **info}
        added = _number(info.get("added"))
        row["rate"] = None if added is None else mon.rates.rate(f"stream:{name}", now, int(added))
        row["fill_soft"] = _fill(info, "softsize", "softcount")
        row["fill_hard"] = _fill(info, "hardsize,maxsize", "hardcount,maxcount")
        out.append(row)
    return out


def _number(text: object) -> float | None:
    if text is None:
        return None
    try:
        return float(str(text))
    except ValueError:
        return None


def overview(mon: Monitor, now: float, now_ns: int) -> dict[str, object]:
    """The overview page: server, whiteboards, modules and streams."""
    server = mon.server
    counters = server.counters()
    started = server.started_ns
    return {
        "server": {
            "name": server.system_name,
            "implementation": server.server_name,
            "host": server.host,
            "port": server.port,
            "http_port": mon.http_port,
            "started_ms": started // _NS_PER_MS if started else None,
            "uptime_s": (now_ns - started) / 1e9 if started else None,
            "now_ms": now_ns // _NS_PER_MS,
            "connections": counters.get("connections"),
            "bound": counters.get("bound"),
            "triggers": counters.get("triggers"),
            "delivered": counters.get("delivered"),
            "dropped": counters.get("dropped"),
            "extensions": sorted(server.extensions),
            "post_enabled": mon.post_enabled,
            "post_hosts": sorted(mon.post_hosts) if mon.post_enabled else [],
        },
        "monitor": mon.stats(),
        "whiteboards": whiteboards(mon, now, counters),
        "modules": modules(mon, now, counters),
        "streams": stream_infos(mon, now, counters),
    }


def whiteboard_messages(
    mon: Monitor, name: str, flt: MessageFilter, *, limit: int, before: int | None
) -> dict[str, object] | None:
    """The newest stored messages of a whiteboard that pass `flt` (wbid < `before` if given)."""
    board = mon.server.whiteboard(name)
    if board is None:
        return None
    accept = flt.compile()
    events = {m.id: d for _, (m, d) in mon.tap.newest_first() if m.stored == name}
    found: list[dict[str, object]] = []
    scanned = 0
    for msg in board.newest_first():
        if before is not None and (msg.wbid or 0) >= before:
            continue
        scanned += 1
        if scanned > _SCAN_LIMIT or len(found) >= limit:
            break
        if accept(msg):
            found.append(summary(msg, events.get(msg.id), None))
    return {
        "whiteboard": name,
        "count": len(board),
        "maxcount": board.maxcount,
        "next_wbid": board.next_wbid,
        "seq": mon.tap.count,
        "truncated": scanned > _SCAN_LIMIT,
        "messages": found,
    }


def find_message(mon: Monitor, whiteboard: str, key: str) -> dict[str, object] | None:
    """Return the detail of a stored message by wbid (digits) or id, or None."""
    board = mon.server.whiteboard(whiteboard)
    if board is None:
        return None
    wbid = int(key) if key.isdigit() else None
    event = mon.tap.find(whiteboard, wbid, "" if wbid is not None else key)
    if event is not None:
        return detail(*event)
    for msg in board.newest_first():
        if (wbid is not None and msg.wbid == wbid) or msg.id == key:
            return detail(msg, None)
    return None


def stored_message(mon: Monitor, whiteboard: str, key: str) -> Message | None:
    """Return a message the whiteboard still stores, by wbid (digits) or id, or None."""
    board = mon.server.whiteboard(whiteboard)
    if board is None:
        return None
    wbid = int(key) if key.isdigit() else None
    for msg in board.newest_first():
        if (wbid is not None and msg.wbid == wbid) or msg.id == key:
            return msg
    return None


def _retrieve(spec: RetrieveSpec) -> dict[str, object]:
    return {
        "whiteboard": spec.whiteboard,
        "pattern": spec.pattern,
        "id": spec.id,
        "from": spec.sender,
        "content": spec.content,
        "latest": spec.latest,
        "lastmsec": spec.lastmsec,
    }


def _phase(phase: Phase, active: bool) -> dict[str, object]:
    return {
        "name": phase.name,
        "context": phase.context,
        "active": active,
        "triggers": [
            {"pattern": t.pattern, "whiteboard": t.whiteboard, "after_ms": t.after_ms}
            for t in phase.triggers
        ],
        "retrieves": [_retrieve(r) for r in phase.retrieves],
    }


def _registration(reg: Registration | None) -> dict[str, object] | None:
    if reg is None:
        return None
    active = reg.active_phase
    return {
        "form": reg.form.value,
        "allow_self_triggering": reg.allow_self_triggering,
        "phases": [_phase(p, p is active) for p in reg.phases],
    }


def _recent_wakeups(mon: Monitor, name: str) -> list[dict[str, object]]:
    out: list[dict[str, object]] = []
    for seq, (msg, deliveries) in mon.tap.newest_first():
        for d in deliveries:
            if d.module == name:
                out.append({**summary(msg, deliveries, seq), "wakeup_id": d.message.id})
                break
        if len(out) >= _RECENT_WAKEUPS:
            break
    return out


def module_detail(mon: Monitor, name: str, now: float) -> dict[str, object] | None:
    """A module's session, registration, counters, recent wakeups and latency histogram."""
    row = next((m for m in modules(mon, now) if m["name"] == name), None)
    reg = mon.server.registration(name)
    if row is None and reg is None:
        return None
    hist = mon.tap.latency.get(name)
    return {
        "name": name,
        "module": row,
        "registration": _registration(reg),
        "recent_wakeups": _recent_wakeups(mon, name),
        "latency": hist.as_dict() if hist is not None else None,
        "latency_measured": mon.latency_hooked,
    }


def _graph_events(mon: Monitor, now_ns: int) -> tuple[list[Event], float]:
    """Return the ring's events of the last window and the span (s) they stand for."""
    window_ms = mon.options.window_s * 1000
    now_ms = now_ns // _NS_PER_MS
    events: list[Event] = []
    oldest = now_ms
    for _, (msg, deliveries) in mon.tap.newest_first():
        received = msg.received.ms if msg.received is not None else now_ms
        if now_ms - received > window_ms:
            return events, mon.options.window_s  # the ring covers the whole window
        events.append((msg, deliveries))
        oldest = received
    wrapped = mon.tap.count > len(mon.tap.ring)
    span = (now_ms - oldest) / 1000 if wrapped else mon.options.window_s
    return events, max(span, 0.1)


def graph(mon: Monitor, now_ns: int) -> dict[str, object]:
    """Modules → types → whiteboards → modules, with message rates on the edges."""
    events, span = _graph_events(mon, now_ns)
    types = Counter(msg.type for msg, _ in events)
    shown = {t for t, _ in types.most_common(_GRAPH_TYPES)}
    edges: Counter[tuple[str, str]] = Counter()
    for msg, deliveries in events:
        kind = f"type:{msg.type}" if msg.type in shown else "type:(other types)"
        edges[(f"src:{msg.sender}", kind)] += 1
        edges[(kind, f"wb:{msg.stored}")] += 1
        for d in deliveries:
            edges[(f"wb:{msg.stored}", f"dst:{d.module}")] += 1
    nodes: dict[str, dict[str, object]] = {}
    for name in mon.server.whiteboards:
        nodes[f"wb:{name}"] = {"id": f"wb:{name}", "kind": "whiteboard", "label": name}
    for name in sorted(mon.bound_names()):
        nodes[f"dst:{name}"] = {"id": f"dst:{name}", "kind": "receiver", "label": name}
    for a, b in edges:
        for node in (a, b):
            if node not in nodes:
                kind, label = node.split(":", 1)
                nodes[node] = {"id": node, "kind": _NODE_KINDS[kind], "label": label}
    return {
        "window_s": round(span, 3),
        "events": len(events),
        "nodes": list(nodes.values()),
        "edges": [
            {"from": a, "to": b, "count": n, "rate": round(n / span, 3)}
            for (a, b), n in sorted(edges.items())
        ],
    }
