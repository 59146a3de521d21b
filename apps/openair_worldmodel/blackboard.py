"""The blackboard: objects, a class tree with inheritance, packets and active functions.

Sans-I/O and synchronous: no method awaits, so on one event loop every mutation is atomic (the
"thread-safe for one event loop" of issue #11). Every packet, local or received, goes through
the same last-writer-wins rule (OA-WM-6), so a local module and its peers' replicas agree.
Accepted packets are queued as `Change`s; the interface drains them to publish reports and to
evaluate plans.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from openair.protocol.errors import ApiMisuseError
from openair_worldmodel.packets import Context, Packet, Value

__all__ = [
    "ROOT_CLASS",
    "ActiveFunction",
    "Blackboard",
    "Change",
    "ClassDef",
    "FunctionRef",
    "ReadFunction",
    "WMObject",
    "WriteFunction",
]

ROOT_CLASS = "Object"
MAX_FUNCTION_DEPTH = 8  # active functions that write each other stop here (no endless chains)

ReadFunction = Callable[["Blackboard", "WMObject", str, Packet | None], Packet | None]
WriteFunction = Callable[["Blackboard", "WMObject", str, Packet], None]
# Stored untyped: one registry holds both kinds, the class says which kind an attribute uses.
ActiveFunction = Callable[..., Any]


@dataclass(frozen=True, slots=True, kw_only=True)
class FunctionRef:
    """An active function of a class: attribute, `read` or `write`, and a registered name."""

    attribute: str
    on: str
    name: str

    def __post_init__(self) -> None:
        if self.on not in ("read", "write"):
            raise ValueError(f"an active function runs on read or write, not {self.on!r}")


@dataclass(frozen=True, slots=True, kw_only=True)
class ClassDef:
    """A class of the tree (OA-WM-4): parent, declared attributes with defaults, functions.

    `attributes` maps each attribute the class declares to its default packet (None: no
    default). Instances also have every attribute their ancestors declare.
    """

    name: str
    parent: str | None = ROOT_CLASS
    attributes: tuple[tuple[str, Packet | None], ...] = ()
    functions: tuple[FunctionRef, ...] = ()


@dataclass(slots=True, kw_only=True)
class WMObject:
    """An object: its class, context, owning robot, packets and staleness (OA-WM-3, OA-WM-14)."""

    name: str
    class_name: str
    context: Context
    owner: str = ""
    packets: dict[str, Packet] = field(default_factory=dict)
    stale: bool = False


@dataclass(frozen=True, slots=True, kw_only=True)
class Change:
    """A packet the blackboard accepted; `local` is False for one received in a report."""

    object: str
    class_name: str
    context: Context
    attribute: str
    packet: Packet
    local: bool


class Blackboard:
    """One module's world model (or its replica of the robot's world model)."""

    def __init__(self, *, robot: str = "", source: str = "") -> None:
        self.robot = robot
        self.source = source
        self.classes: dict[str, ClassDef] = {ROOT_CLASS: ClassDef(name=ROOT_CLASS, parent=None)}
        self.objects: dict[str, WMObject] = {}
        self.registry: dict[str, ActiveFunction] = {}
        self._changes: list[Change] = []
        self._depth = 0
        self._seq = 0

    # -- classes -------------------------------------------------------------------------------

    def register_function(self, name: str, function: ActiveFunction) -> None:
        """Make `function` available to classes under `name` (also to classes received)."""
        self.registry[name] = function

    def define_class(self, cls: ClassDef) -> ClassDef:
        """Add (or redefine) a class at run time (OA-WM-4); its parent and functions must exist."""
        if cls.name == ROOT_CLASS:
            raise ApiMisuseError(f"the root class {ROOT_CLASS} cannot be redefined")
        if cls.parent is None or cls.parent not in self.classes:
            raise ApiMisuseError(f"class {cls.name}: unknown parent {cls.parent!r}")
        if cls.name in self.lineage(cls.parent):
            raise ApiMisuseError(f"class {cls.name}: the class tree would have a cycle")
        missing = [f.name for f in cls.functions if f.name not in self.registry]
        if missing:
            raise ApiMisuseError(f"class {cls.name}: unregistered active functions {missing}")
        self.classes[cls.name] = cls
        return cls

    def lineage(self, class_name: str) -> list[str]:
        """Return the class and its ancestors, most derived first."""
        chain: list[str] = []
        name: str | None = class_name
        while name is not None and name in self.classes and name not in chain:
            chain.append(name)
            name = self.classes[name].parent
        return chain

    def is_a(self, obj: str, class_name: str) -> bool:
        """True when object `obj` is an instance of `class_name` or of a subclass of it."""
        found = self.objects.get(obj)
        return found is not None and class_name in self.lineage(found.class_name)

    def attributes_of(self, class_name: str) -> dict[str, Packet | None]:
        """Return every attribute an instance has, with the nearest class's default."""
        out: dict[str, Packet | None] = {}
        for name in self.lineage(class_name):
            for attribute, default in self.classes[name].attributes:
                out.setdefault(attribute, default)
        return out

    def function_for(self, class_name: str, attribute: str, on: str) -> ActiveFunction | None:
        """Return the active function the nearest class gives (a subclass overrides)."""
        for name in self.lineage(class_name):
            for ref in self.classes[name].functions:
                if ref.attribute == attribute and ref.on == on:
                    return self.registry[ref.name]
        return None

    # -- objects -------------------------------------------------------------------------------

    def create(
        self,
        name: str,
        class_name: str = ROOT_CLASS,
        context: Context = Context.SURROUNDINGS,
        *,
        owner: str = "",
    ) -> WMObject:
        """Create an instance at run time, or return the existing object of that name."""
        if class_name not in self.classes:
            raise ApiMisuseError(f"object {name}: unknown class {class_name!r}")
        if not name or any(c.isspace() for c in name):
            raise ApiMisuseError(f"an object name is non-empty without white space: {name!r}")
        existing = self.objects.get(name)
        if existing is not None:
            return existing
        obj = WMObject(name=name, class_name=class_name, context=context, owner=owner or self.robot)
        self.objects[name] = obj
        return obj

    def stored(self, obj: str, attribute: str) -> Packet | None:
        """Return the packet the replica holds (or the class default), without functions."""
        found = self.objects.get(obj)
        if found is None:
            return None
        packet = found.packets.get(attribute)
        return packet if packet is not None else self.attributes_of(found.class_name).get(attribute)

    def read(self, obj: str, attribute: str) -> Packet | None:
        """Read an attribute; an inherited on-read active function may compute it (OA-WM-5)."""
        found = self.objects.get(obj)
        if found is None:
            return None
        packet = self.stored(obj, attribute)
        function = self.function_for(found.class_name, attribute, "read")
        if function is None or self._depth >= MAX_FUNCTION_DEPTH:
            return packet
        self._depth += 1
        try:
            result = function(self, found, attribute, packet)
        finally:
            self._depth -= 1
        if result is not None and not isinstance(result, Packet):
            raise ApiMisuseError(f"on-read function of {obj}.{attribute} returned {result!r}")
        return result

    def write(
        self,
        obj: str,
        attribute: str,
        value: Value,
        *,
        timestamp: int,
        accuracy: float = 0.0,
        confidence: float = 1.0,
    ) -> bool:
        """Write a local observation; False when an existing packet is newer (OA-WM-6)."""
        self._seq += 1
        packet = Packet(
            value=value,
            accuracy=accuracy,
            confidence=confidence,
            timestamp=timestamp,
            source=self.source,
            seq=self._seq,
        )
        return self.put(obj, attribute, packet, local=True)

    def put(self, obj: str, attribute: str, packet: Packet, *, local: bool) -> bool:
        """Store `packet` if it wins under last-writer-wins; run on-write functions if so."""
        found = self.objects.get(obj)
        if found is None:
            raise ApiMisuseError(f"no object {obj!r}: create it first")
        if not packet.newer_than(found.packets.get(attribute)):
            return False  # OA-WM-6: an older or equal packet changes nothing
        found.packets[attribute] = packet
        self._changes.append(
            Change(
                object=obj,
                class_name=found.class_name,
                context=found.context,
                attribute=attribute,
                packet=packet,
                local=local,
            )
        )
        self._run_write_function(found, attribute, packet)
        return True

    def _run_write_function(self, obj: WMObject, attribute: str, packet: Packet) -> None:
        function = self.function_for(obj.class_name, attribute, "write")
        if function is None or self._depth >= MAX_FUNCTION_DEPTH:
            return
        self._depth += 1
        try:
            function(self, obj, attribute, packet)
        finally:
            self._depth -= 1

    def derive(self, obj: str, attribute: str, packet: Packet) -> bool:
        """Write a value an active function computed, as a local write of this blackboard."""
        self._seq += 1
        return self.put(
            obj, attribute, replace(packet, source=self.source, seq=self._seq), local=True
        )

    def drain_changes(self) -> list[Change]:
        """Return and forget the changes accepted since the last call."""
        out, self._changes = self._changes, []
        return out

    # -- staleness and snapshots -----------------------------------------------------------------

    def mark_stale(self, owner: str, contexts: Iterable[Context] = (Context.SYSTEM,)) -> list[str]:
        """Mark the objects `owner` owns in `contexts` stale (OA-WM-14); return their names."""
        wanted = frozenset(contexts)
        names = []
        for obj in self.objects.values():
            if obj.owner == owner and obj.context in wanted and not obj.stale:
                obj.stale = True
                names.append(obj.name)
        return names

    def snapshot(self) -> Mapping[str, tuple[str, str, bool, tuple[tuple[str, Packet], ...]]]:
        """Return the replica state as plain values (for comparing replicas)."""
        return {
            name: (obj.class_name, obj.context.value, obj.stale, tuple(sorted(obj.packets.items())))
            for name, obj in sorted(self.objects.items())
        }
