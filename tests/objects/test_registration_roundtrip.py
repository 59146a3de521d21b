"""Property tests: what encode_* writes parses back equal and validates against the XSDs."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from objects_helpers import content_schema, registration_errors, schema_errors

from openair.protocol.content import (
    ANY_WHITEBOARD,
    DEFAULT_CONTEXT,
    ContentMatch,
    Phase,
    Registration,
    RegistrationForm,
    RetrieveSpec,
    StreamRef,
    Trigger,
)
from openair.protocol.errors import ApiMisuseError
from openair.protocol.registration import (
    encode_phase,
    encode_registration,
    encode_retrieve,
    encode_retrieves,
    parse_registration,
    parse_retrieves,
    read_phase,
)
from openair.protocol.times import AirTime
from openair.protocol.xmlsafe import parse_fragment

XML_TEXT = st.text(
    st.characters(
        codec="utf-8", exclude_categories=("Cc", "Cs"), exclude_characters="\ufffe\uffff"
    ),
    max_size=10,
)
NON_EMPTY = XML_TEXT.filter(bool)
SEGMENT = st.from_regex(r"\*|\*?[A-Za-z0-9:_é-]{1,4}(\*[A-Za-z0-9]{1,3})*\*?", fullmatch=True)
PATTERNS = st.lists(SEGMENT, min_size=1, max_size=4).map(".".join)
NAME_SEGMENT = st.from_regex(r"[A-Za-z0-9:_é-]{1,5}", fullmatch=True)
CONTEXTS = st.lists(NAME_SEGMENT, min_size=1, max_size=3).map(".".join)
# Whiteboard names as written; "any" and "*" in any case mean every whiteboard (OA-TRIG-2).
WHITEBOARDS = st.just(ANY_WHITEBOARD) | st.from_regex(
    r"[A-Za-z][A-Za-z0-9.*_-]{0,6}", fullmatch=True
).filter(lambda n: n.lower() != "any")
COUNTS = st.integers(0, 10) | st.integers(0, 2**63 - 1)
TIMES = st.builds(
    AirTime,
    sec=st.integers(-(2**62), 2**62),
    msec=st.integers(0, 999),
    usec=st.none() | st.integers(0, 999),
)
PRIORITIES = st.integers(0, 6999).map(lambda k: k / 1000)

TRIGGERS = st.builds(
    Trigger, pattern=PATTERNS, whiteboard=WHITEBOARDS, after_ms=COUNTS, alias=XML_TEXT
)
RETRIEVES = st.builds(
    RetrieveSpec,
    whiteboard=st.just("") | NON_EMPTY,
    pattern=st.just("") | PATTERNS,
    id=XML_TEXT,
    sender=XML_TEXT,
    content=XML_TEXT,
    contentmatch=st.sampled_from(ContentMatch),
    latest=COUNTS,
    lastmsec=st.none() | COUNTS,
    after_time=st.none() | TIMES,
    until_time=st.none() | TIMES,
)
STREAMS = st.builds(
    StreamRef,
    kind=st.sampled_from(["inputstream", "outputstream", "stream"]),
    alias=XML_TEXT,
    source=XML_TEXT,
)


def phases(
    *,
    name: st.SearchStrategy[str],
    context: st.SearchStrategy[str],
    streams: bool = True,
    priority: st.SearchStrategy[float] = PRIORITIES,
) -> st.SearchStrategy[Phase]:
    return st.builds(
        Phase,
        name=name,
        context=context,
        triggers=st.lists(TRIGGERS, max_size=4).map(tuple),
        retrieves=st.lists(RETRIEVES, max_size=3).map(tuple),
        streams=st.lists(STREAMS, max_size=2).map(tuple) if streams else st.just(()),
        priority=priority,
    )


def registrations(form: RegistrationForm) -> st.SearchStrategy[Registration]:
    """Registrations that `form` can carry (encode_registration's documented constraints)."""
    default = st.just(DEFAULT_CONTEXT)
    if form is RegistrationForm.BARE:
        one = phases(
            name=st.just("Default Phase"), context=default, streams=False, priority=st.just(1.0)
        )
        allow: st.SearchStrategy[bool] = st.just(False)
    elif form is RegistrationForm.MODULE:
        one = phases(name=st.just("Default"), context=default, priority=st.just(1.0))
        allow = st.booleans()
    elif form is RegistrationForm.PHASE:
        one = phases(name=NON_EMPTY, context=default)
        allow = st.booleans()
    else:
        many = st.lists(phases(name=NON_EMPTY, context=default | CONTEXTS), min_size=1, max_size=3)
        return st.builds(
            Registration,
            module=NON_EMPTY,
            form=st.just(form),
            phases=many.map(tuple),
            allow_self_triggering=st.booleans(),
        )
    return st.builds(
        Registration,
        module=NON_EMPTY,
        form=st.just(form),
        phases=one.map(lambda p: (p,)),
        allow_self_triggering=allow,
    )


FORMS = [
    RegistrationForm.BARE,
    RegistrationForm.MODULE,
    RegistrationForm.SPEC,
    RegistrationForm.PHASE,
]


@pytest.mark.parametrize("form", FORMS, ids=lambda f: f.value)
@given(data=st.data())
def test_registrations_round_trip_and_validate(form: RegistrationForm, data: st.DataObject) -> None:
    reg = data.draw(registrations(form))
    content = encode_registration(reg, form)
    assert parse_registration(reg.module, content, max_triggers=100) == reg
    assert registration_errors(content) == ""


@given(RETRIEVES)
def test_retrieve_round_trips_and_validates(spec: RetrieveSpec) -> None:
    content = encode_retrieve(spec)
    assert parse_retrieves(content) == (spec,)
    assert schema_errors(content_schema(), content, "retrieve") == ""


@given(st.lists(RETRIEVES, min_size=1, max_size=4))
def test_retrieves_round_trip_and_validate(specs: list[RetrieveSpec]) -> None:
    content = encode_retrieves(specs)
    assert parse_retrieves(content) == tuple(specs)
    assert schema_errors(content_schema(), content, "retrieves") == ""


@given(
    phase=phases(name=NON_EMPTY, context=CONTEXTS),
    lasttrigger=st.just("") | PATTERNS,
    module=XML_TEXT,
)
def test_phase_spec_round_trips_and_validates(phase: Phase, lasttrigger: str, module: str) -> None:
    content = encode_phase(phase, lasttrigger=lasttrigger, module=module)
    (el,) = parse_fragment(content)
    assert read_phase(el) == phase
    assert el.get("lasttrigger") == lasttrigger and el.get("module") == module
    assert schema_errors(content_schema(), content, "phase") == ""


def test_phase_spec_writes_the_oa_wake_4_attributes() -> None:
    phase = Phase(triggers=(Trigger(pattern="Test.Ping.*", whiteboard="WB1"), Trigger(pattern="A")))
    assert encode_phase(phase, lasttrigger="Test.Ping.*", module="Reader") == (
        '<phase name="Default Phase" module="Reader" context="Psyclone.System.Ready" '
        'lasttrigger="Test.Ping.*" priority="1.000"><triggers>'
        '<trigger after="0" from="WB1" type="Test.Ping.*"/><trigger after="0" from="" type="A"/>'
        "</triggers></phase>"
    )


def test_phase_spec_of_a_module_without_registration_is_empty_default() -> None:
    # OA-WAKE-4: a phase with no triggers in the context Psyclone.System.Ready.
    (el,) = parse_fragment(encode_phase(None, module="M"))
    assert read_phase(el) == Phase()
    assert el.get("lasttrigger") == "" and el.get("context") == DEFAULT_CONTEXT


def test_encode_registration_canonical_module_form() -> None:
    reg = Registration(
        module="N1",
        form=RegistrationForm.MODULE,
        phases=(
            Phase(
                name="Default",
                triggers=(Trigger(pattern="TR.Go", whiteboard="WB1"),),
                retrieves=(RetrieveSpec(whiteboard="WB1", pattern="TR.Data.*", latest=2),),
            ),
        ),
    )
    assert encode_registration(reg) == (
        '<module name="N1"><triggers><trigger type="TR.Go" from="WB1"/></triggers><retrieves>'
        '<retrieve from="WB1" type="TR.Data.*"><latest>2</latest></retrieve></retrieves></module>'
    )
    bare = Registration(
        module="N1",
        form=RegistrationForm.BARE,
        phases=(Phase(triggers=reg.phases[0].triggers, retrieves=reg.phases[0].retrieves),),
    )
    assert encode_registration(bare, RegistrationForm.BARE) == (
        '<triggers><trigger type="TR.Go" from="WB1"/></triggers><retrieves>'
        '<retrieve from="WB1" type="TR.Data.*"><latest>2</latest></retrieve></retrieves>'
    )


def test_module_form_falls_back_to_spec_layout_for_other_phases() -> None:
    reg = Registration(
        module="M",
        form=RegistrationForm.SPEC,
        phases=(Phase(name="A", context="X.Y"), Phase(name="B", context="X.Y"), Phase(name="C")),
    )
    content = encode_registration(reg, RegistrationForm.MODULE)
    assert content == (
        '<module name="M"><spec><context name="X.Y"><phase name="A"/><phase name="B"/></context>'
        '<context name="Psyclone.System.Ready"><phase name="C"/></context></spec></module>'
    )
    assert parse_registration("M", content) == reg


def test_empty_registrations_encode_to_empty_forms() -> None:
    empty = Registration(module="M", form=RegistrationForm.MODULE)
    assert encode_registration(empty) == '<module name="M"/>'
    assert encode_registration(empty, RegistrationForm.BARE) == "<triggers/>"
    assert (
        parse_registration("M", encode_registration(empty, RegistrationForm.PHASE)).triggers == ()
    )


@pytest.mark.parametrize(
    ("reg", "form"),
    [
        (
            Registration(
                module="M", form=RegistrationForm.BARE, phases=(Phase(), Phase(name="Two"))
            ),
            RegistrationForm.BARE,
        ),
        (
            Registration(module="M", form=RegistrationForm.BARE, phases=(Phase(context="X"),)),
            RegistrationForm.BARE,
        ),
        (
            Registration(module="M", form=RegistrationForm.BARE, phases=(Phase(name="N"),)),
            RegistrationForm.BARE,
        ),
        (
            Registration(
                module="M",
                form=RegistrationForm.BARE,
                phases=(Phase(),),
                allow_self_triggering=True,
            ),
            RegistrationForm.BARE,
        ),
        (
            Registration(module="M", form=RegistrationForm.PHASE, phases=(Phase(), Phase())),
            RegistrationForm.PHASE,
        ),
        (
            Registration(
                module="M",
                form=RegistrationForm.MODULE,
                phases=(Phase(triggers=(Trigger(pattern="A**"),)),),
            ),
            RegistrationForm.MODULE,
        ),
        (
            Registration(
                module="M",
                form=RegistrationForm.MODULE,
                phases=(Phase(triggers=(Trigger(pattern="A", after_ms=-1),)),),
            ),
            RegistrationForm.MODULE,
        ),
        (
            Registration(
                module="M",
                form=RegistrationForm.MODULE,
                phases=(Phase(streams=(StreamRef(kind="river"),)),),
            ),
            RegistrationForm.MODULE,
        ),
        (
            Registration(module="M", form=RegistrationForm.SPEC, phases=(Phase(priority=7.5),)),
            RegistrationForm.SPEC,
        ),
    ],
)
def test_encode_refuses_what_the_form_cannot_carry(
    reg: Registration, form: RegistrationForm
) -> None:
    with pytest.raises(ApiMisuseError):
        encode_registration(reg, form)
