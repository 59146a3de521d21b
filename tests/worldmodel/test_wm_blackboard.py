"""Classes, inheritance and active functions (OA-WM-4, OA-WM-5), and report filters (OA-WM-9)."""

from __future__ import annotations

import pytest

from openair.protocol.errors import ApiMisuseError, ContentInvalidError
from openair_worldmodel import Blackboard, ClassDef, FunctionRef, Packet, WMObject, WorldModelCore
from openair_worldmodel.interface import Outgoing, ReportFilter
from openair_worldmodel.wire import decode_class, decode_report, encode_class


def _doubled(bb: Blackboard, obj: WMObject, attr: str, packet: Packet | None) -> Packet | None:
    base = bb.stored(obj.name, "base")
    return None if base is None else Packet(value=2 * float(base.value), timestamp=base.timestamp)  # type: ignore[arg-type]


def _tripled(bb: Blackboard, obj: WMObject, attr: str, packet: Packet | None) -> Packet | None:
    base = bb.stored(obj.name, "base")
    return None if base is None else Packet(value=3 * float(base.value), timestamp=base.timestamp)  # type: ignore[arg-type]


def _mirror(bb: Blackboard, obj: WMObject, attr: str, packet: Packet) -> None:
    bb.derive(obj.name, "copy", packet)


def _board() -> Blackboard:
    bb = Blackboard(robot="R", source="M")
    for name, fn in (("doubled", _doubled), ("tripled", _tripled), ("mirror", _mirror)):
        bb.register_function(name, fn)
    bb.define_class(
        ClassDef(
            name="Base",
            attributes=(("base", Packet(value=1.0)), ("derived", None), ("copy", None)),
            functions=(
                FunctionRef(attribute="derived", on="read", name="doubled"),
                FunctionRef(attribute="base", on="write", name="mirror"),
            ),
        )
    )
    bb.define_class(ClassDef(name="Child", parent="Base", attributes=(("extra", None),)))
    bb.define_class(
        ClassDef(
            name="Override",
            parent="Child",
            attributes=(("base", Packet(value=5.0)),),
            functions=(FunctionRef(attribute="derived", on="read", name="tripled"),),
        )
    )
    return bb


def test_instances_inherit_attributes_defaults_and_functions() -> None:
    bb = _board()
    bb.create("c", "Child")
    bb.create("o", "Override")
    assert set(bb.attributes_of("Child")) == {"base", "derived", "copy", "extra"}
    assert bb.read("c", "base") == Packet(value=1.0)  # the inherited default
    assert bb.read("o", "base") == Packet(value=5.0)  # the nearest default
    assert bb.read("c", "derived") == Packet(value=2.0)  # inherited on-read function
    assert bb.read("o", "derived") == Packet(value=15.0)  # overridden on-read function
    assert bb.is_a("o", "Base") and not bb.is_a("c", "Override")


def test_on_write_functions_run_for_local_and_received_packets() -> None:
    bb = _board()
    bb.create("c", "Child")
    assert bb.write("c", "base", 4.0, timestamp=10)
    assert bb.read("c", "copy") is not None and bb.read("c", "copy").value == 4.0  # type: ignore[union-attr]
    assert bb.read("c", "derived") == Packet(value=8.0, timestamp=10)
    bb.put("c", "base", Packet(value=7.0, timestamp=20, source="Other", seq=1), local=False)
    assert bb.read("c", "copy").value == 7.0  # type: ignore[union-attr]
    changes = bb.drain_changes()
    assert [(c.attribute, c.local) for c in changes] == [
        ("base", True),
        ("copy", True),
        ("base", False),
        ("copy", True),
    ]


def test_run_time_classes_from_a_received_structure() -> None:
    sender = _board()
    text = encode_class(sender.classes["Override"])
    core = WorldModelCore(robot="R", module="M2", whiteboard="WB1")
    with pytest.raises(ContentInvalidError):  # parent Child unknown here
        core.receive("WM.Class", text)
    for name, cls in sender.classes.items():
        if name in ("Base", "Child"):
            with pytest.raises(ContentInvalidError):  # functions not bound here
                core.receive("WM.Class", encode_class(cls))
    core.blackboard.register_function("doubled", _doubled)
    core.blackboard.register_function("mirror", _mirror)
    core.blackboard.register_function("tripled", _tripled)
    for name in ("Base", "Child", "Override"):
        core.receive("WM.Class", encode_class(sender.classes[name]))
    assert core.blackboard.classes["Override"] == decode_class(text)
    core.blackboard.create("o", "Override")
    assert core.blackboard.read("o", "derived") == Packet(value=15.0)


def test_class_tree_errors() -> None:
    bb = _board()
    with pytest.raises(ApiMisuseError):
        bb.define_class(ClassDef(name="Base", parent="Override"))  # a cycle
    with pytest.raises(ApiMisuseError):
        bb.define_class(ClassDef(name="X", parent="Nope"))
    with pytest.raises(ApiMisuseError):
        bb.create("x", "Nope")


def test_report_filters_in_value_and_time() -> None:
    rule = ReportFilter(min_change=0.5, min_interval_us=100)
    core = WorldModelCore(robot="R", module="M", whiteboard="WB1", default_filter=rule)
    core.blackboard.create("O")
    published = []
    for stamp, value in ((0, 1.0), (50, 3.0), (150, 1.2), (300, 1.4), (400, 2.0)):
        core.blackboard.write("O", "p", value, timestamp=stamp)
        for out in core.flush():
            assert isinstance(out, Outgoing)
            (obj,) = decode_report(out.content).objects
            published.append(obj.packets[0][1].value)
    # 3.0 is too soon; 1.2 moves 0.2 only; 1.4 moves 0.4 only; 2.0 moves 1.0 after 400 µs
    assert published == [1.0, 2.0]
