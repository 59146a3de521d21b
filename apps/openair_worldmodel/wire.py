"""The `WM.` messages of the world model (spec 16.2): their content objects, read and written.

Every reader takes the content text of a message (language `xml`) and raises
ContentInvalidError (CONTENT_INVALID) for anything `schemas/worldmodel.xsd` would refuse, and
for the rules an XSD cannot state (a condition that does not parse, OA-WM-10; an attribute twice
in one report, OA-WM-7). Writers produce exactly the canonical form the vectors hold.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from lxml import etree

from openair.protocol.errors import ContentInvalidError
from openair.protocol.objects import element, elements, inner_text, parse_root, serialize
from openair_worldmodel.blackboard import ClassDef, FunctionRef
from openair_worldmodel.conditions import parse_condition, to_text
from openair_worldmodel.packets import Context, Packet, Ref, Value, canonical_value, value_kind
from openair_worldmodel.plans import ACK_STATUSES, Ack, ControlAction, Plan, ReportAction

__all__ = [
    "TYPE_ACK",
    "TYPE_CANCEL",
    "TYPE_CLASS",
    "TYPE_HELLO",
    "TYPE_PLAN",
    "TYPE_REPORT",
    "Cancel",
    "Hello",
    "PlanAck",
    "Report",
    "ReportObject",
    "decode_ack",
    "decode_cancel",
    "decode_class",
    "decode_hello",
    "decode_plan",
    "decode_report",
    "encode_ack",
    "encode_cancel",
    "encode_class",
    "encode_hello",
    "encode_plan",
    "encode_report",
]

TYPE_REPORT = "WM.Report"
TYPE_CLASS = "WM.Class"
TYPE_PLAN = "WM.Plan"
TYPE_ACK = "WM.Plan.Ack"
TYPE_CANCEL = "WM.Plan.Cancel"
TYPE_HELLO = "WM.Hello"

_NUMBER = re.compile(r"[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)([eE][+-]?[0-9]+)?")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_:-]*(\.[A-Za-z_][A-Za-z0-9_:-]*)*")
_ATTRIBUTE = re.compile(r"[A-Za-z_][A-Za-z0-9_:-]*")
_MAX_U64 = 2**64 - 1


@dataclass(frozen=True, slots=True, kw_only=True)
class ReportObject:
    """One object of a report: its class, context and packets (attribute, packet)."""

    name: str
    class_name: str
    context: Context
    packets: tuple[tuple[str, Packet], ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class Report:
    """A `WM.Report` (OA-WM-7): packets of one writer (each with the writer's sequence number)."""

    robot: str
    source: str
    objects: tuple[ReportObject, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class PlanAck:
    """A `WM.Plan.Ack` (OA-WM-12): an Ack with the executor and the plan's origin."""

    ack: Ack
    executor: str
    origin: str


@dataclass(frozen=True, slots=True, kw_only=True)
class Hello:
    """A `WM.Hello` (OA-WM-14): module `module` of robot `robot` is present."""

    robot: str
    module: str
    whiteboard: str


@dataclass(frozen=True, slots=True, kw_only=True)
class Cancel:
    """A `WM.Plan.Cancel`: terminate the plan `plan` of `origin` at `executor`."""

    plan: str
    executor: str
    origin: str


def _bad(detail: str) -> ContentInvalidError:
    return ContentInvalidError(detail)


def _get(el: etree._Element, name: str, *, pattern: re.Pattern[str] | None = None) -> str:
    value = el.get(name)
    if value is None:
        raise _bad(f"<{el.tag}> needs the attribute {name}")
    if pattern is not None and not pattern.fullmatch(value):
        raise _bad(f"<{el.tag} {name}={value!r}>: not a valid {name}")
    return value


def _number(text: str, what: str) -> float:
    if not _NUMBER.fullmatch(text.strip()):
        raise _bad(f"{what}: not a finite number: {text!r}")
    value = float(text)
    if value in (float("inf"), float("-inf")):
        raise _bad(f"{what}: out of range: {text!r}")
    return value


def _integer(text: str | None, what: str, default: int | None = None) -> int:
    if text is None and default is not None:
        return default
    if text is None or not text.strip().isdigit() or int(text) > _MAX_U64:
        raise _bad(f"{what}: not a non-negative integer: {text!r}")
    return int(text)


def _only(el: etree._Element, allowed: tuple[str, ...]) -> None:
    unknown = sorted(set(el.attrib) - set(allowed))
    if unknown:
        raise _bad(f"<{el.tag}>: unknown attributes {unknown}")


# -- packets -------------------------------------------------------------------------------------


def _value_element(value: Value) -> etree._Element:
    return element(value_kind(value), text=canonical_value(value))


def _read_value(el: etree._Element) -> Value:
    children = elements(el)
    if len(children) != 1 or children[0].tag not in ("number", "string", "ref"):
        raise _bad(f"<{el.tag}> holds exactly one <number>, <string> or <ref>")
    child = children[0]
    if elements(child):
        raise _bad(f"<{child.tag}> holds text only")
    text = child.text or ""
    if child.tag == "number":
        return _number(text, "<number>")
    if child.tag == "ref":
        if not _NAME.fullmatch(text):
            raise _bad(f"<ref>: not an object name: {text!r}")
        return Ref(name=text)
    return text


def _packet_fields(el: etree._Element, packet: Packet, *, seq: bool = True) -> None:
    if seq:
        el.set("seq", str(packet.seq))
    el.set("accuracy", repr(packet.accuracy))
    el.set("confidence", repr(packet.confidence))
    el.set("timestamp", str(packet.timestamp))
    el.append(_value_element(packet.value))


def _read_packet(el: etree._Element, source: str, *, strict: bool = True) -> Packet:
    if strict:  # a report's packet carries every field (OA-WM-7); a class default may omit them
        for name in ("seq", "accuracy", "confidence", "timestamp"):
            _get(el, name)
    accuracy = _number(el.get("accuracy", "0"), "accuracy")
    confidence = _number(el.get("confidence", "1"), "confidence")
    if accuracy < 0 or not 0 <= confidence <= 1:
        raise _bad("accuracy must be ≥ 0 and confidence within 0 to 1")
    timestamp = _integer(el.get("timestamp"), "timestamp")
    seq = _integer(el.get("seq"), "seq", 0)
    return Packet(
        value=_read_value(el),
        accuracy=accuracy,
        confidence=confidence,
        timestamp=timestamp,
        source=source,
        seq=seq,
    )


# -- WM.Report -----------------------------------------------------------------------------------


def encode_report(report: Report) -> str:
    """Write a `<wmreport>` (OA-WM-7)."""
    root = element("wmreport", (("robot", report.robot), ("source", report.source)))
    for obj in report.objects:
        item = element(
            "object",
            (("name", obj.name), ("class", obj.class_name), ("context", obj.context.value)),
        )
        for attribute, packet in obj.packets:
            child = element("packet", (("attribute", attribute),))
            _packet_fields(child, packet)
            item.append(child)
        root.append(item)
    return serialize(root)


def decode_report(content: str) -> Report:
    """Read a `<wmreport>`; each packet gets the report's source (OA-WM-6, OA-WM-7)."""
    root = parse_root(content, ("wmreport",), ContentInvalidError)
    _only(root, ("robot", "source"))
    source = _get(root, "source")
    if not source:
        raise _bad("<wmreport> needs a non-empty source")
    objects, seen = [], set()
    for item in elements(root):
        if item.tag != "object":
            raise _bad(f"<wmreport> holds <object> elements, not <{item.tag}>")
        _only(item, ("name", "class", "context"))
        name = _get(item, "name", pattern=_NAME)
        try:
            context = Context(_get(item, "context"))
        except ValueError:
            raise _bad(f"object {name}: unknown context {item.get('context')!r}") from None
        packets = []
        for child in elements(item):
            if child.tag != "packet":
                raise _bad(f"<object> holds <packet> elements, not <{child.tag}>")
            _only(child, ("attribute", "seq", "accuracy", "confidence", "timestamp"))
            attribute = _get(child, "attribute", pattern=_ATTRIBUTE)
            if (name, attribute) in seen:
                raise _bad(f"{name}.{attribute} occurs twice in one report")  # OA-WM-7
            seen.add((name, attribute))
            packets.append((attribute, _read_packet(child, source)))
        objects.append(
            ReportObject(
                name=name,
                class_name=_get(item, "class", pattern=_NAME),
                context=context,
                packets=tuple(packets),
            )
        )
    if not objects or any(not o.packets for o in objects):
        raise _bad("a report holds at least one object, each with at least one packet")
    return Report(robot=_get(root, "robot"), source=source, objects=tuple(objects))


# -- WM.Class ------------------------------------------------------------------------------------


def encode_class(cls: ClassDef) -> str:
    """Write a `<wmclass>` (OA-WM-4): declared attributes, defaults and function names."""
    attrs = [("name", cls.name)] + ([("parent", cls.parent)] if cls.parent else [])
    root = element("wmclass", attrs)
    for attribute, default in cls.attributes:
        child = element("attribute", (("name", attribute),))
        if default is not None:
            _packet_fields(child, default, seq=False)
        root.append(child)
    for ref in cls.functions:
        root.append(
            element("function", (("attribute", ref.attribute), ("on", ref.on), ("name", ref.name)))
        )
    return serialize(root)


def decode_class(content: str) -> ClassDef:
    """Read a `<wmclass>`; the receiver binds function names to its own registry (OA-WM-5)."""
    root = parse_root(content, ("wmclass",), ContentInvalidError)
    _only(root, ("name", "parent"))
    attributes: list[tuple[str, Packet | None]] = []
    functions: list[FunctionRef] = []
    for child in elements(root):
        if child.tag == "attribute" and not functions:
            _only(child, ("name", "accuracy", "confidence", "timestamp"))
            name = _get(child, "name", pattern=_ATTRIBUTE)
            default = None
            if elements(child):
                timestamp = child.get("timestamp", "0")
                child.set("timestamp", timestamp)
                default = _read_packet(child, "", strict=False)
            attributes.append((name, default))
        elif child.tag == "function":
            _only(child, ("attribute", "on", "name"))
            on = _get(child, "on")
            if on not in ("read", "write"):
                raise _bad(f"<function on={on!r}>: read or write")
            functions.append(
                FunctionRef(
                    attribute=_get(child, "attribute", pattern=_ATTRIBUTE),
                    on=on,
                    name=_get(child, "name", pattern=_NAME),
                )
            )
        else:
            raise _bad(f"<wmclass> holds <attribute> then <function> elements, not <{child.tag}>")
    return ClassDef(
        name=_get(root, "name", pattern=_NAME),
        parent=root.get("parent", "Object"),
        attributes=tuple(attributes),
        functions=tuple(functions),
    )


# -- WM.Plan -------------------------------------------------------------------------------------


def encode_plan(plan: Plan) -> str:
    """Write a `<wmplan>` (OA-WM-10); conditions in their printed form."""
    root = element(
        "wmplan", (("name", plan.name), ("executor", plan.executor), ("origin", plan.origin))
    )
    for tag, cond in (
        ("initiation", plan.initiation),
        ("trigger", plan.trigger),
        ("termination", plan.termination),
    ):
        root.append(element(tag, text=to_text(cond)))
    if isinstance(plan.action, ControlAction):
        root.append(element("control", (("type", plan.action.type),), plan.action.content))
    else:
        for obj, attribute in plan.action.items:
            attrs = [("object", obj)] + ([("attribute", attribute)] if attribute else [])
            root.append(element("report", attrs))
    return serialize(root)


def decode_plan(content: str) -> Plan:
    """Read a `<wmplan>`; a condition that does not parse is CONTENT_INVALID (OA-WM-10)."""
    root = parse_root(content, ("wmplan",), ContentInvalidError)
    _only(root, ("name", "executor", "origin"))
    children = elements(root)
    tags = [c.tag for c in children]
    if tags[:3] != ["initiation", "trigger", "termination"] or len(children) < 4:
        raise _bad("<wmplan> holds <initiation>, <trigger>, <termination>, then the action")
    conditions = [parse_condition(inner_text(c)) for c in children[:3]]
    actions = children[3:]
    if [a.tag for a in actions] == ["control"]:
        _only(actions[0], ("type",))
        action: ControlAction | ReportAction = ControlAction(
            type=_get(actions[0], "type", pattern=_NAME), content=actions[0].text or ""
        )
    elif all(a.tag == "report" for a in actions):
        for a in actions:
            _only(a, ("object", "attribute"))
        action = ReportAction(
            items=tuple((_get(a, "object", pattern=_NAME), a.get("attribute", "")) for a in actions)
        )
    else:
        raise _bad("the action is one <control> or one or more <report> elements")
    return Plan(
        name=_get(root, "name", pattern=_NAME),
        initiation=conditions[0],
        trigger=conditions[1],
        termination=conditions[2],
        action=action,
        origin=root.get("origin", ""),
        executor=_get(root, "executor"),
    )


# -- WM.Plan.Ack, WM.Plan.Cancel, WM.Hello -------------------------------------------------------


def encode_ack(ack: PlanAck) -> str:
    """Write a `<wmack>` (OA-WM-12)."""
    attrs = [
        ("plan", ack.ack.plan),
        ("executor", ack.executor),
        ("origin", ack.origin),
        ("status", ack.ack.status),
        ("count", str(ack.ack.count)),
    ]
    if ack.ack.reason:
        attrs.append(("reason", ack.ack.reason))
    return serialize(element("wmack", attrs))


def decode_ack(content: str) -> PlanAck:
    """Read a `<wmack>`."""
    root = parse_root(content, ("wmack",), ContentInvalidError)
    _only(root, ("plan", "executor", "origin", "status", "count", "reason"))
    if elements(root) or (root.text or "").strip():
        raise _bad("<wmack> is empty")
    status = _get(root, "status")
    if status not in ACK_STATUSES:
        raise _bad(f"unknown acknowledgement {status!r}")
    ack = Ack(
        plan=_get(root, "plan"),
        status=status,
        count=_integer(root.get("count"), "count"),
        reason=root.get("reason", ""),
    )
    return PlanAck(ack=ack, executor=_get(root, "executor"), origin=_get(root, "origin"))


def encode_cancel(cancel: Cancel) -> str:
    """Write a `<wmcancel>`."""
    return serialize(
        element(
            "wmcancel",
            (("plan", cancel.plan), ("executor", cancel.executor), ("origin", cancel.origin)),
        )
    )


def decode_cancel(content: str) -> Cancel:
    """Read a `<wmcancel>`."""
    root = parse_root(content, ("wmcancel",), ContentInvalidError)
    _only(root, ("plan", "executor", "origin"))
    return Cancel(
        plan=_get(root, "plan"), executor=_get(root, "executor"), origin=_get(root, "origin")
    )


def encode_hello(hello: Hello) -> str:
    """Write a `<wmhello>` (OA-WM-14)."""
    return serialize(
        element(
            "wmhello",
            (("robot", hello.robot), ("module", hello.module), ("whiteboard", hello.whiteboard)),
        )
    )


def decode_hello(content: str) -> Hello:
    """Read a `<wmhello>`."""
    root = parse_root(content, ("wmhello",), ContentInvalidError)
    _only(root, ("robot", "module", "whiteboard"))
    robot = _get(root, "robot")
    if not robot:
        raise _bad("<wmhello> needs a non-empty robot")
    return Hello(robot=robot, module=_get(root, "module"), whiteboard=_get(root, "whiteboard"))
