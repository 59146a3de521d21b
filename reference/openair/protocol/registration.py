"""AIR.Subscribe registrations (spec 8.1–8.3) and retrieve specifications (spec 9.2).

Readers accept the four registration forms of spec 8.2 with names in any case (OA-MSG-3) and
refuse anything else with REGISTRATION_INVALID (OA-REG-8), PATTERN_INVALID (OA-MATCH-7) or
LIMIT_EXCEEDED (OA-LIM-6); retrieves are refused with RETRIEVE_INVALID (OA-RET-10). Writers
build lxml elements in the canonical spelling; what they write parses back to the same value.

`read_phase` and `phase_spec_element` serve `wakeup.py`: the `<phase>` of a wakeup's PhaseSpec
is read leniently (a server may echo a pattern it accepted but this kit refuses, such as `**`).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from lxml import etree

from openair.protocol.content import (
    ANY_WHITEBOARD,
    DEFAULT_CONTEXT,
    Phase,
    Registration,
    RegistrationForm,
    RetrieveSpec,
    StreamRef,
    Trigger,
)
from openair.protocol.errors import (
    ApiMisuseError,
    LimitExceededError,
    RegistrationInvalidError,
    RetrieveInvalidError,
)
from openair.protocol.message import MAX_PRIORITY
from openair.protocol.objects import (
    MAX_INT64,
    attr,
    element,
    elements,
    inner_text,
    parse_content,
    parse_integer,
    read_retrieve,
    read_retrieves_group,
    retrieve_element,
    retrieves_element,
    serialize,
)
from openair.protocol.types import is_valid_pattern, is_valid_type, validate_pattern
from openair.protocol.xmlsafe import local_name

__all__ = [
    "DEFAULT_MAX_TRIGGERS",
    "encode_phase",
    "encode_registration",
    "encode_retrieve",
    "encode_retrieves",
    "parse_registration",
    "parse_registration_element",
    "parse_retrieve_element",
    "parse_retrieves",
    "phase_spec_element",
    "read_phase",
]

DEFAULT_MAX_TRIGGERS = 1024  # OA-LIM-6
_ANY_NAMES = frozenset({"", "any", "*"})  # OA-TRIG-2
_STREAM_KINDS = ("inputstream", "outputstream", "stream")
# Form 5 (OA-REG-16): bare stream elements, optionally beside the groups of form 1.
_FORM5_STREAMS = frozenset({*_STREAM_KINDS, "streams"})
_FORM5 = _FORM5_STREAMS | {"triggers", "retrieves"}
_DECIMAL = re.compile(r"\s*[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)\s*")
_FORM2_PHASE = "Default"  # the hidden phase of form 2, named as Psyclone names it (spec 8.2)
_FORM14_PHASE = "Default Phase"  # the phase of forms 1 and 4
# Children accepted and ignored: psySpec parts the server does not implement (OA-CONF-6) and
# the informative parts of a phase that Psyclone echoes (spec 8.7).
_MODULE_IGNORED = frozenset({"description", "executable", "parameter", "posts", "post", "crank"})
_PHASE_IGNORED = frozenset(
    {"description", "posts", "post", "crank", "cranks", "currentcontexts", "activationtime"}
) | {"allowselftriggering"}  # read by root_phase


# --------------------------------------------------------------------------------------------
# Retrieve specifications (spec 9.2): the element readers and writers live in objects.py
# --------------------------------------------------------------------------------------------


def parse_retrieve_element(el: etree._Element) -> RetrieveSpec:
    """Read one `<retrieve>` element (spec 9.2); RETRIEVE_INVALID or PATTERN_INVALID if bad."""
    return read_retrieve(el, "", strict=True)


def parse_retrieves(content: str) -> tuple[RetrieveSpec, ...]:
    """Read AIR.Retrieve / AIR.Retrieves content: one `<retrieve>` or one `<retrieves>`.

    Empty content, other elements, unparsable XML, an empty `<retrieves>` and invalid criteria
    are RETRIEVE_INVALID (OA-RET-10); an invalid `type` is PATTERN_INVALID (OA-MATCH-7).
    """
    roots = parse_content(content, RetrieveInvalidError)
    if len(roots) != 1 or local_name(roots[0]) not in ("retrieve", "retrieves"):
        found = ", ".join(f"<{local_name(r)}>" for r in roots) or "nothing"
        raise RetrieveInvalidError(f"content must be one <retrieve> or <retrieves>, found {found}")
    root = roots[0]
    if local_name(root) == "retrieve":
        return (parse_retrieve_element(root),)
    specs = read_retrieves_group(root, strict=True)
    if not specs:
        raise RetrieveInvalidError("<retrieves> holds no <retrieve>")  # OA-RET-10
    return tuple(specs)


def encode_retrieve(spec: RetrieveSpec) -> str:
    """Write one `<retrieve>` (AIR.Retrieve content); `latest` is always written."""
    return serialize(retrieve_element(spec))


def encode_retrieves(specs: Sequence[RetrieveSpec]) -> str:
    """Write `<retrieves>` (AIR.Retrieves content); at least one spec (OA-RET-10)."""
    if not specs:
        raise ApiMisuseError("encode_retrieves needs at least one retrieve")
    return serialize(retrieves_element(specs))


# --------------------------------------------------------------------------------------------
# Reading registrations (spec 8.2, 8.3)
# --------------------------------------------------------------------------------------------


@dataclass(slots=True)
class _Parts:
    """What one phase collects while its children are read."""

    triggers: list[Trigger] = field(default_factory=list)
    retrieves: list[RetrieveSpec] = field(default_factory=list)
    streams: list[StreamRef] = field(default_factory=list)

    @property
    def empty(self) -> bool:
        return not (self.triggers or self.retrieves or self.streams)

    def phase(self, name: str, context: str = DEFAULT_CONTEXT, priority: float = 1.0) -> Phase:
        return Phase(
            name=name,
            context=context,
            triggers=tuple(self.triggers),
            retrieves=tuple(self.retrieves),
            streams=tuple(self.streams),
            priority=priority,
        )


class _Reader:
    """Reads the elements of a registration; counts triggers against `max_triggers`."""

    def __init__(self, *, strict: bool, max_triggers: int) -> None:
        self.strict = strict
        self.max_triggers = max_triggers
        self.count = 0

    def trigger(self, el: etree._Element, group_from: str) -> Trigger:
        """Read `<trigger type from after alias/>` (spec 8.2, 8.4)."""
        pattern = attr(el, "type") or ""
        if not pattern:
            raise RegistrationInvalidError("trigger without a type")  # OA-REG-8
        if self.strict:
            validate_pattern(pattern)  # OA-MATCH-7
        self.count += 1
        if self.count > self.max_triggers:  # OA-LIM-6
            raise LimitExceededError(f"more than {self.max_triggers} triggers")
        whiteboard = attr(el, "from") or group_from  # OA-REG-5
        if whiteboard.lower() in _ANY_NAMES:
            whiteboard = ANY_WHITEBOARD  # OA-TRIG-2
        delay = attr(el, "after") or attr(el, "delay") or "0"  # OA-TRIG-3: delay is a synonym
        after = parse_integer(delay)
        if after is None or not 0 <= after <= MAX_INT64:  # OA-REG-8
            raise RegistrationInvalidError(f"trigger after={delay!r} is not a non-negative integer")
        alias = attr(el, "alias") or attr(el, "name") or ""
        return Trigger(
            pattern=pattern,
            whiteboard=whiteboard,
            after_ms=after,
            alias=alias,
            max_priority=_max_priority(attr(el, "maxpriority")),
        )

    def retrieve(self, el: etree._Element, group_from: str) -> RetrieveSpec:
        try:
            return read_retrieve(el, group_from, strict=self.strict)
        except RetrieveInvalidError as exc:  # OA-REG-8: a refused retrieve refuses the whole
            raise RegistrationInvalidError(f"retrieve: {exc.detail}") from None

    def collect(self, child: etree._Element, parts: _Parts) -> bool:
        """Add a trigger, retrieve or stream child (or group) to `parts`; False if not one."""
        kind = local_name(child)
        if kind == "trigger":
            parts.triggers.append(self.trigger(child, ""))
        elif kind == "triggers":
            group_from = attr(child, "from") or ""
            for item in elements(child):
                if local_name(item) != "trigger":
                    raise RegistrationInvalidError(f"<triggers> holds <{local_name(item)}>")
                parts.triggers.append(self.trigger(item, group_from))
        elif kind == "retrieve":
            parts.retrieves.append(self.retrieve(child, ""))
        elif kind == "retrieves":
            group_from = attr(child, "from") or ""
            parts.retrieves.extend(self.retrieve(item, group_from) for item in elements(child))
        elif kind in _STREAM_KINDS:
            parts.streams.append(_stream(child))
        elif kind == "streams":
            for item in elements(child):
                if local_name(item) not in _STREAM_KINDS:
                    raise RegistrationInvalidError(f"<streams> holds <{local_name(item)}>")
                parts.streams.append(_stream(item))
        else:
            return False
        return True

    def phase(self, el: etree._Element, context: str, default_name: str) -> Phase:
        """Read a `<phase name|id priority>` and its children (OA-REG-4, OA-REG-12)."""
        parts = _Parts()
        for child in elements(el):
            kind = local_name(child)
            if not self.collect(child, parts) and self.strict and kind not in _PHASE_IGNORED:
                raise RegistrationInvalidError(f"<phase> holds <{kind}>")
        name = attr(el, "name") or attr(el, "id") or default_name
        return parts.phase(name, context, self.priority(el))

    def priority(self, el: etree._Element) -> float:
        """Read a phase's `priority` (spec 10: 0.0 to 6.999), 1.0 when absent."""
        text = attr(el, "priority") or ""
        if not text:
            return 1.0
        if _DECIMAL.fullmatch(text) and 0.0 <= float(text) <= 6.999:
            return float(text)
        if self.strict:
            raise RegistrationInvalidError(
                f"phase priority {text!r} is not a decimal from 0.0 to 6.999"
            )
        return 1.0

    def context(self, el: etree._Element) -> list[Phase]:
        """Read `<context name>` holding phases, directly or in `<phases>` (OA-REG-4)."""
        name = attr(el, "name") or ""
        if not is_valid_type(name):
            raise RegistrationInvalidError(f"context name {name!r} is not a dot-delimited name")
        return self.phases(elements(el), name, "<context>")

    def phases(self, children: Iterable[etree._Element], context: str, where: str) -> list[Phase]:
        """Read `<phase>` and `<phases>` elements (the children of a context)."""
        found: list[Phase] = []
        for child in children:
            kind = local_name(child)
            if kind == "phase":
                found.append(self.phase(child, context, _FORM14_PHASE))
            elif kind == "phases":
                found.extend(self.phases(elements(child), context, "<phases>"))
            else:
                raise RegistrationInvalidError(f"{where} holds <{kind}>, not a phase")
        return found

    def module(self, module: str, el: etree._Element) -> Registration:
        """Read `<module>`: form 2 (direct triggers/retrieves) or form 3 (contexts, phases)."""
        hidden = _Parts()
        phases: list[Phase] = []
        for child in elements(el):
            kind = local_name(child)
            if self.collect(child, hidden) or kind in _MODULE_IGNORED:
                continue
            if kind == "spec":
                for ctx in elements(child):
                    if local_name(ctx) != "context":
                        raise RegistrationInvalidError(
                            f"<spec> holds <{local_name(ctx)}>, not <context>"
                        )
                    phases.extend(self.context(ctx))
            elif kind == "context":
                phases.extend(self.context(child))
            elif kind in ("phase", "phases"):
                phases.extend(self.phases([child], DEFAULT_CONTEXT, "<module>"))
            else:
                raise RegistrationInvalidError(f"<module> holds <{kind}>")  # OA-REG-8
        form = RegistrationForm.SPEC if phases else RegistrationForm.MODULE
        if not phases or not hidden.empty:  # form 2 always makes its one hidden phase
            phases.insert(0, hidden.phase(_FORM2_PHASE))
        return Registration(
            module=module,
            form=form,
            phases=tuple(phases),
            allow_self_triggering=_yes(attr(el, "allowselftriggering")),  # OA-REG-6
        )

    def root_phase(self, module: str, el: etree._Element) -> Registration:
        """Read form 4, a root `<phase>` (OA-REG-12), in the default context."""
        flag = attr(el, "allowselftriggering")
        for child in elements(el):
            if local_name(child) == "allowselftriggering":
                flag = inner_text(child).strip()
        return Registration(
            module=module,
            form=RegistrationForm.PHASE,
            phases=(self.phase(el, DEFAULT_CONTEXT, _FORM14_PHASE),),
            allow_self_triggering=_yes(flag),
        )

    def bare_streams(self, module: str, roots: Sequence[etree._Element]) -> Registration:
        """Read form 5: stream elements as roots, beside form 1's groups (OA-REG-16)."""
        parts = _Parts()
        for root in roots:
            self.collect(root, parts)
        return Registration(
            module=module, form=RegistrationForm.BARE, phases=(parts.phase(_FORM14_PHASE),)
        )

    def bare(
        self, module: str, triggers: etree._Element, retrieves: etree._Element | None
    ) -> Registration:
        """Read form 1, `<triggers>` optionally followed by `<retrieves>` (OA-REG-2)."""
        parts = _Parts()
        self.collect(triggers, parts)
        if retrieves is not None:
            self.collect(retrieves, parts)
        return Registration(
            module=module, form=RegistrationForm.BARE, phases=(parts.phase(_FORM14_PHASE),)
        )


def _max_priority(text: str | None) -> float | None:
    """Read an alarm trigger's `maxpriority`, a decimal 0.0-6.999 (OA-TRIG-5)."""
    if text is None:
        return None
    value = text.strip()
    if not _DECIMAL.fullmatch(value) or not 0.0 <= float(value) <= MAX_PRIORITY:
        raise RegistrationInvalidError(f"trigger maxpriority={text!r} is not 0.0-6.999")
    return float(value)


def _yes(value: str | None) -> bool:
    """OA-REG-6: `yes` in any case means yes; absent or anything else means no."""
    return value is not None and value.strip().lower() == "yes"


def _stream(el: etree._Element) -> StreamRef:
    """Read `<inputstream|outputstream alias source/>` or `<stream name source/>`."""
    return StreamRef(
        kind=local_name(el),
        alias=attr(el, "alias") or attr(el, "name") or "",
        source=attr(el, "source") or "",
    )


def parse_registration_element(
    module: str, el: etree._Element, *, max_triggers: int = DEFAULT_MAX_TRIGGERS
) -> Registration:
    """Read a registration whose content is one element: `<triggers>`, `<module>` or `<phase>`.

    `module` is the registering module (the message's `from`, OA-REG-1); a `name` attribute in
    the content does not change it.
    """
    if not module:
        raise RegistrationInvalidError("AIR.Subscribe without a from")  # OA-REG-8
    reader = _Reader(strict=True, max_triggers=max_triggers)
    kind = local_name(el)
    if kind == "triggers":
        return reader.bare(module, el, None)
    if kind == "module":
        return reader.module(module, el)
    if kind == "phase":
        return reader.root_phase(module, el)
    raise RegistrationInvalidError(f"<{kind}> is not a registration")  # OA-REG-8


def parse_registration(
    module: str, content: str, *, max_triggers: int = DEFAULT_MAX_TRIGGERS
) -> Registration:
    """Read AIR.Subscribe content in any of the four forms of spec 8.2.

    Raises REGISTRATION_INVALID for empty or unparsable content, any other shape, a trigger
    without a type or with a bad `after`, or a retrieve that section 9 refuses (OA-REG-8);
    PATTERN_INVALID for an invalid pattern (OA-MATCH-7); LIMIT_EXCEEDED beyond `max_triggers`
    (OA-LIM-6).
    """
    if not module:
        raise RegistrationInvalidError("AIR.Subscribe without a from")  # OA-REG-8
    roots = parse_content(content, RegistrationInvalidError)
    names = [local_name(r) for r in roots]
    if _FORM5_STREAMS.intersection(names) and _FORM5.issuperset(names):  # OA-REG-16
        reader = _Reader(strict=True, max_triggers=max_triggers)
        return reader.bare_streams(module, roots)
    if names == ["triggers", "retrieves"]:  # OA-REG-2: two sibling roots
        reader = _Reader(strict=True, max_triggers=max_triggers)
        return reader.bare(module, roots[0], roots[1])
    if len(roots) != 1:
        shown = ", ".join(f"<{n}>" for n in names) or "empty content"
        raise RegistrationInvalidError(f"not a registration: {shown}")  # OA-REG-8
    return parse_registration_element(module, roots[0], max_triggers=max_triggers)


def read_phase(el: etree._Element) -> Phase:
    """Read a wakeup's PhaseSpec `<phase>` leniently (patterns are not validated).

    The phase keeps its `context` attribute (default `Psyclone.System.Ready`); informative parts
    (`pid`, `currentcontexts`, `activationtime`, …) and unknown children are skipped.
    """
    reader = _Reader(strict=False, max_triggers=MAX_INT64)
    context = attr(el, "context") or DEFAULT_CONTEXT
    return reader.phase(el, context, _FORM14_PHASE)


# --------------------------------------------------------------------------------------------
# Writing registrations and phases
# --------------------------------------------------------------------------------------------


def _trigger_element(t: Trigger, *, echo: bool = False) -> etree._Element:
    """Build `<trigger>`: `type from after alias`, or the PhaseSpec echo `after from type`."""
    if not is_valid_pattern(t.pattern):
        raise ApiMisuseError(f"trigger type {t.pattern!r} is not a valid pattern")
    if t.after_ms < 0:
        raise ApiMisuseError(f"trigger after is negative: {t.after_ms}")
    if echo:  # OA-WAKE-4: each trigger written with after, from and type
        attrs = [("after", str(t.after_ms)), ("from", t.whiteboard), ("type", t.pattern)]
    else:
        attrs = [("type", t.pattern)]
        if t.whiteboard:
            attrs.append(("from", t.whiteboard))
        if t.after_ms:
            attrs.append(("after", str(t.after_ms)))
    if t.alias:
        attrs.append(("alias", t.alias))
    if t.max_priority is not None:  # OA-TRIG-5
        attrs.append(("maxpriority", repr(t.max_priority)))
    return element("trigger", attrs)


def _stream_element(s: StreamRef) -> etree._Element:
    if s.kind not in _STREAM_KINDS:
        raise ApiMisuseError(f"stream kind {s.kind!r} is not one of {_STREAM_KINDS}")
    return element(s.kind, [(k, v) for k, v in (("alias", s.alias), ("source", s.source)) if v])


def _fill(el: etree._Element, phase: Phase, *, echo: bool = False) -> etree._Element:
    """Append a phase's `<triggers>`, `<retrieves>` and streams to `el`."""
    if phase.triggers or echo:
        group = element("triggers")
        group.extend(_trigger_element(t, echo=echo) for t in phase.triggers)
        el.append(group)
    if phase.retrieves:  # retrieves.xsd: a <retrieves> group holds at least one retrieve
        el.append(retrieves_element(phase.retrieves))
    el.extend(_stream_element(s) for s in phase.streams)
    return el


def _priority_text(priority: float) -> str:
    if not 0.0 <= priority <= 6.999:
        raise ApiMisuseError(f"phase priority out of range 0.0-6.999: {priority}")
    return f"{priority:.3f}"


def _phase_element(phase: Phase) -> etree._Element:
    """Build a registration `<phase name [priority]>` (forms 3 and 4)."""
    attrs = [("name", phase.name)]
    if phase.priority != 1.0:
        attrs.append(("priority", _priority_text(phase.priority)))
    return _fill(element("phase", attrs), phase)


def _only_phase(reg: Registration, form: RegistrationForm) -> Phase:
    """Return the one default-context phase that forms 1 and 4 can carry."""
    if not reg.phases:
        return Phase()  # an empty registration (OA-REG-11)
    if len(reg.phases) > 1 or reg.phases[0].context != DEFAULT_CONTEXT:
        raise ApiMisuseError(f"the {form.value} form carries one phase in {DEFAULT_CONTEXT}")
    return reg.phases[0]


def _encode_bare(reg: Registration) -> str:
    phase = _only_phase(reg, RegistrationForm.BARE)
    if reg.allow_self_triggering or phase.streams or phase.priority != 1.0:
        raise ApiMisuseError("the bare form cannot carry self-triggering, streams or priority")
    if phase.name != _FORM14_PHASE:
        raise ApiMisuseError(f"the bare form's phase is always named {_FORM14_PHASE!r}")
    triggers = element("triggers")
    triggers.extend(_trigger_element(t) for t in phase.triggers)
    parts = [serialize(triggers)]
    if phase.retrieves:
        parts.append(serialize(retrieves_element(phase.retrieves)))
    return "".join(parts)  # OA-REG-2: two sibling roots


def _encode_root_phase(reg: Registration) -> str:
    el = _phase_element(_only_phase(reg, RegistrationForm.PHASE))
    if reg.allow_self_triggering:
        el.insert(0, element("allowselftriggering", text="yes"))
    return serialize(el)


def _is_form2(reg: Registration) -> bool:
    """Whether the registration is exactly the hidden phase of form 2."""
    if len(reg.phases) != 1:
        return not reg.phases
    phase = reg.phases[0]
    return (phase.name, phase.context, phase.priority) == (_FORM2_PHASE, DEFAULT_CONTEXT, 1.0)


def _encode_module(reg: Registration, form: RegistrationForm) -> str:
    attrs = [("name", reg.module)]
    if reg.allow_self_triggering:
        attrs.append(("allowselftriggering", "yes"))
    root = element("module", attrs)
    if form is RegistrationForm.MODULE and _is_form2(reg):
        if reg.phases:
            _fill(root, reg.phases[0])
        return serialize(root)
    spec = element("spec")
    context: etree._Element | None = None
    for phase in reg.phases:  # consecutive phases of one context share a <context>
        if context is None or context.get("name") != phase.context:
            context = element("context", (("name", phase.context),))
            spec.append(context)
        context.append(_phase_element(phase))
    root.append(spec)
    return serialize(root)


def encode_registration(reg: Registration, form: RegistrationForm = RegistrationForm.MODULE) -> str:
    """Write AIR.Subscribe content in `form` (spec 8.2).

    MODULE writes form 2 when the registration is one phase named `Default` in the default
    context with priority 1.0, and form 3 otherwise; SPEC and CONFIG write form 3; BARE and
    PHASE carry one default-context phase and refuse more (API_MISUSE), BARE also refuses
    self-triggering, streams, a priority or a phase name other than `Default Phase`.
    """
    if form is RegistrationForm.BARE:
        return _encode_bare(reg)
    if form is RegistrationForm.PHASE:
        return _encode_root_phase(reg)
    return _encode_module(reg, form)


def phase_spec_element(
    phase: Phase | None, *, module: str = "", lasttrigger: str = ""
) -> etree._Element:
    """Build the PhaseSpec `<phase name module context lasttrigger priority>` (OA-WAKE-4).

    `None` is the phase of a module without a registration: no triggers, default context.
    """
    phase = phase or Phase()
    attrs = [
        ("name", phase.name),
        ("module", module),
        ("context", phase.context),
        ("lasttrigger", lasttrigger),
        ("priority", _priority_text(phase.priority)),
    ]
    return _fill(element("phase", attrs), phase, echo=True)


def encode_phase(phase: Phase | None, *, lasttrigger: str = "", module: str = "") -> str:
    """Write the PhaseSpec `<phase>` of a wakeup or a CurrentPhase reply (OA-WAKE-4, OA-SESS-13)."""
    return serialize(phase_spec_element(phase, module=module, lasttrigger=lasttrigger))
