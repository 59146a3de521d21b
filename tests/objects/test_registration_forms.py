"""AIR.Subscribe registrations: the four forms of spec 8.2 and the refusals of spec 8.3."""

from __future__ import annotations

from pathlib import Path

import pytest
from objects_helpers import doc_content, doc_paths

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
    LimitExceededError,
    PatternInvalidError,
    RegistrationInvalidError,
    XmlForbiddenError,
)
from openair.protocol.registration import parse_registration, parse_registration_element
from openair.protocol.xmlsafe import parse_fragment

TR_DATA = RetrieveSpec(whiteboard="WB1", pattern="TR.Data.*", latest=2)


def one_phase(
    form: RegistrationForm, name: str, *triggers: Trigger, retrieves: tuple[RetrieveSpec, ...] = ()
) -> Registration:
    return Registration(
        module="M",
        form=form,
        phases=(Phase(name=name, triggers=triggers, retrieves=retrieves),),
    )


# --- the four forms (verbatim AIR.Subscribe contents of psyclone-wire/10-*.txt and 02-*.txt) ---


def test_form1_bare_triggers_as_javaopenair_sends_them() -> None:
    content = '\n\t\t<triggers>\n\t\t\t<trigger from="WB1" type="Test.Ping.*" />\n\t\t</triggers>\n'
    reg = parse_registration("M", content)
    assert reg == one_phase(
        RegistrationForm.BARE, "Default Phase", Trigger(pattern="Test.Ping.*", whiteboard="WB1")
    )
    assert reg.active_phase is reg.phases[0]


def test_form1_bare_triggers_with_retrieves_apply_them() -> None:
    # OA-REG-2: the retrieves of the bare form count (Psyclone drops them, N4 of 10-*.txt).
    content = (
        '<triggers><trigger from="WB1" type="TR.Go"/></triggers><retrieves>'
        '<retrieve from="WB1" type="TR.Data.*"><latest>2</latest></retrieve></retrieves>'
    )
    reg = parse_registration("N4", content)
    assert reg.form is RegistrationForm.BARE
    assert reg.triggers == (Trigger(pattern="TR.Go", whiteboard="WB1"),)
    assert reg.retrieves == (TR_DATA,)


def test_form2_module_element_mary_style() -> None:
    reg = parse_registration(
        "M", '<module name="M1"><trigger from="WB1" type="Reg.Mary"/></module>'
    )
    assert reg == one_phase(
        RegistrationForm.MODULE, "Default", Trigger(pattern="Reg.Mary", whiteboard="WB1")
    )


def test_form2_module_name_does_not_name_the_module() -> None:
    # OA-REG-1: the module is the message's from, not the content's name attribute.
    reg = parse_registration("Sender", '<module name="Other"><trigger type="A"/></module>')
    assert reg.module == "Sender"


def test_form2_groups_inherit_from_and_read_after() -> None:
    content = """<module name="N1" allowselftriggering="yes">
      <triggers from="WB1">
        <trigger type="TR.Go"/>
        <trigger type="TR.Stop" after="500"/>
        <trigger type="TR.Own" from="WB2"/>
      </triggers>
      <retrieves from="WB1"><retrieve type="TR.Data.*"><latest>2</latest></retrieve>
        <retrieve from="WB2" type="X"/></retrieves>
    </module>"""
    reg = parse_registration("N1", content)
    assert reg.allow_self_triggering
    assert reg.triggers == (
        Trigger(pattern="TR.Go", whiteboard="WB1"),
        Trigger(pattern="TR.Stop", whiteboard="WB1", after_ms=500),
        Trigger(pattern="TR.Own", whiteboard="WB2"),  # OA-REG-5: its own from wins
    )
    assert reg.retrieves == (TR_DATA, RetrieveSpec(whiteboard="WB2", pattern="X"))


def test_form2_module_mixing_direct_children_and_groups_keeps_order() -> None:
    content = (
        '<module><trigger type="A"/><triggers><trigger type="B"/></triggers>'
        '<retrieve type="R"/><trigger type="C"/><description>ignored</description>'
        '<executable name="x"/><parameter name="p"/><posts to="WB1"><post type="P"/>'
        '</posts><crank name="c"/><inputstream alias="In" source="Video"/>'
        '<streams><stream name="Audio" source="Mic"/></streams></module>'
    )
    reg = parse_registration("M", content)
    assert [t.pattern for t in reg.triggers] == ["A", "B", "C"]
    assert reg.retrieves == (RetrieveSpec(pattern="R"),)
    assert reg.phases[0].streams == (
        StreamRef(kind="inputstream", alias="In", source="Video"),
        StreamRef(kind="stream", alias="Audio", source="Mic"),
    )


def test_form3_greta_style_spec_context_phase() -> None:
    content = (
        '<module name="M2"><spec><context name="Psyclone.System.Ready"><phase id="M2.Main">'
        '<triggers><trigger from="WB1" type="Reg.Greta"/></triggers></phase></context>'
        "</spec></module>"
    )
    reg = parse_registration("M2", content)
    assert reg.form is RegistrationForm.SPEC
    assert reg.phases == (
        Phase(name="M2.Main", triggers=(Trigger(pattern="Reg.Greta", whiteboard="WB1"),)),
    )


def test_form3_other_context_is_kept_but_not_in_force() -> None:
    # OA-REG-10: accepted; without `contexts` only Psyclone.System.Ready phases are in force.
    content = (
        '<module name="M5"><spec><context name="Some.Other.Context"><phase id="M5.Main">'
        '<triggers><trigger from="WB1" type="Reg.Ctx"/></triggers></phase></context>'
        "</spec></module>"
    )
    reg = parse_registration("M5", content)
    assert [p.context for p in reg.phases] == ["Some.Other.Context"]
    assert reg.active_phase is None
    assert reg.triggers == ()


def test_form3_contexts_without_spec_phases_wrapper_names_and_ignored_parts() -> None:
    content = """<module name="Domino-60" type="external" priority="2.0" allowselftriggering="No">
      <description>Flips dominoes</description>
      <context name="Scene.Bright"><phases>
          <phase name="First"><crank name="MyCrank"/>
            <triggers from="Whiteboard.2"><trigger after="1000" type="DEMO.Domino.50"/></triggers>
            <posts to="Whiteboard.2"><post type="DEMO.Domino.Flip" phasechange="yes"/></posts>
          </phase>
          <phase id="Second"/><phase/></phases></context>
      <CONTEXT NAME="Psyclone.System.Ready"><Phase Name="Main" priority="3.5"/></CONTEXT>
    </module>"""
    reg = parse_registration("Domino-60", content)
    assert reg.form is RegistrationForm.SPEC and not reg.allow_self_triggering
    assert [(p.name, p.context) for p in reg.phases] == [
        ("First", "Scene.Bright"),
        ("Second", "Scene.Bright"),
        ("Default Phase", "Scene.Bright"),
        ("Main", DEFAULT_CONTEXT),
    ]
    assert reg.phases[0].triggers == (
        Trigger(pattern="DEMO.Domino.50", whiteboard="Whiteboard.2", after_ms=1000),
    )
    assert reg.active_phase == Phase(name="Main", priority=3.5)


def test_form3_module_triggers_beside_contexts_make_a_first_hidden_phase() -> None:
    content = (
        '<module><trigger type="A"/><context name="X.Y"><phase name="P">'
        '<triggers><trigger type="B"/></triggers></phase></context></module>'
    )
    reg = parse_registration("M", content)
    assert reg.form is RegistrationForm.SPEC
    assert [(p.name, p.context) for p in reg.phases] == [("Default", DEFAULT_CONTEXT), ("P", "X.Y")]
    assert reg.triggers == (Trigger(pattern="A"),)


def test_form4_root_phase() -> None:
    content = (
        '<phase><triggers><trigger from="WB1" type="TR.Go"/></triggers><retrieves>'
        '<retrieve from="WB1" type="TR.Data.*"><latest>2</latest></retrieve></retrieves>'
        "</phase>"
    )
    reg = parse_registration("N3", content)
    assert reg == Registration(
        module="N3",
        form=RegistrationForm.PHASE,
        phases=(
            Phase(triggers=(Trigger(pattern="TR.Go", whiteboard="WB1"),), retrieves=(TR_DATA,)),
        ),
    )


def test_form4_root_phase_reads_psyclone_phase_echo_parts() -> None:
    # A CurrentPhase answer sent back as a registration: informative parts are skipped.
    content = (
        '<phase name="Main" module="M" context="Psyclone.System.Ready" lasttrigger="" '
        'pid="x" priority="1.000"><allowselftriggering>Yes</allowselftriggering>'
        '<triggers><trigger after="0" from="" type="A.*"/></triggers><currentcontexts>'
        '<objectdictionary/></currentcontexts><activationtime sec="1" msec="2"/></phase>'
    )
    reg = parse_registration("M", content)
    assert reg.allow_self_triggering
    assert reg.phases == (Phase(name="Main", triggers=(Trigger(pattern="A.*"),)),)


@pytest.mark.parametrize(
    "content", ["<triggers/>", "<module name='M'/>", "<phase/>", "<module><spec/></module>"]
)
def test_a_registration_without_triggers_is_valid(content: str) -> None:
    # OA-REG-11: it removes all triggers and retrieves.
    reg = parse_registration("M", content)
    assert reg.triggers == () and reg.retrieves == ()


# --- attributes -----------------------------------------------------------------------------


@pytest.mark.parametrize("written", ["any", "ANY", "*", "", None])
def test_from_any_star_empty_or_absent_means_every_whiteboard(written: str | None) -> None:
    attr = "" if written is None else f' from="{written}"'
    reg = parse_registration("M", f'<triggers><trigger type="From.Test"{attr}/></triggers>')
    assert reg.triggers[0].whiteboard == ANY_WHITEBOARD  # OA-TRIG-2


@pytest.mark.parametrize("written", ["WB*", "wb1", "NoSuchWB", "any1"])
def test_other_from_values_are_names_kept_as_written(written: str) -> None:
    reg = parse_registration(
        "M", f'<triggers><trigger type="From.Test" from="{written}"/></triggers>'
    )
    assert reg.triggers[0].whiteboard == written


def test_group_from_any_and_empty_own_from_inherit() -> None:
    content = '<triggers from="WB1"><trigger type="A" from=""/></triggers>'
    assert parse_registration("M", content).triggers[0].whiteboard == "WB1"
    content = '<triggers from="any"><trigger type="A"/></triggers>'
    assert parse_registration("M", content).triggers[0].whiteboard == ANY_WHITEBOARD


def test_names_match_in_any_case() -> None:
    # OA-MSG-3: element and attribute names of content objects in any case.
    content = (
        '<MODULE ALLOWSELFTRIGGERING="YES"><Triggers FROM="WB1"><TRIGGER TYPE="A.b" '
        'AFTER="7" Alias="go"/></Triggers></MODULE>'
    )
    reg = parse_registration("M", content)
    assert reg.allow_self_triggering
    assert reg.triggers == (Trigger(pattern="A.b", whiteboard="WB1", after_ms=7, alias="go"),)


def test_delay_and_name_are_synonyms_of_after_and_alias() -> None:
    reg = parse_registration("M", '<triggers><trigger type="A" delay="250" name="n"/></triggers>')
    assert reg.triggers == (Trigger(pattern="A", after_ms=250, alias="n"),)
    reg = parse_registration("M", '<triggers><trigger type="A" after="1" delay="2"/></triggers>')
    assert reg.triggers[0].after_ms == 1


@pytest.mark.parametrize(
    ("value", "allowed"),
    [("yes", True), ("Yes", True), (" YES ", True), ("no", False), ("true", False), ("1", False)],
)
def test_allowselftriggering_is_yes_in_any_case_else_no(value: str, allowed: bool) -> None:
    reg = parse_registration("M", f'<module allowselftriggering="{value}"/>')
    assert reg.allow_self_triggering is allowed  # OA-REG-6


# --- refusals (spec 8.3) --------------------------------------------------------------------


@pytest.mark.parametrize(
    "content",
    [
        "",
        "   ",
        "text, not XML",
        "<triggers>",
        "<retrieves><retrieve type='X'/></retrieves>",
        "<retrieves><retrieve type='X'/></retrieves><triggers><trigger type='X'/></triggers>",
        "<module name='A'/><module name='B'/>",
        "<triggers/><triggers/>",
        "<subscription type='X'/>",
        "<triggers><trigger from='WB1'/></triggers>",
        "<triggers><trigger type=''/></triggers>",
        "<triggers><trigger type='A' after='-1500'/></triggers>",
        "<triggers><trigger type='A' after='1.5s'/></triggers>",
        "<triggers><trigger type='A' after='1e3'/></triggers>",
        "<triggers><trigger type='A' after='99999999999999999999'/></triggers>",
        "<triggers><retrieve type='A'/></triggers>",
        "<module><subscription type='Y'/></module>",
        "<module><spec><phase id='P'/></spec></module>",
        "<module><spec><context><phase id='P'/></context></spec></module>",
        "<module><context name='Bad..Name'/></module>",
        "<module><context name='C'><trigger type='A'/></context></module>",
        "<phase><unknown/></phase>",
        "<phase priority='high'/>",
        "<phase priority='9'/>",
        "<module><streams><trigger type='A'/></streams></module>",
        "<triggers/><retrieves><retrieve type='A' latest='x'/></retrieves>",
        "<module><retrieve><latest>-1</latest></retrieve></module>",
        "<module><retrieves><trigger type='A'/></retrieves></module>",
        "<module><retrieve><beforecontext>A</beforecontext></retrieve></module>",
    ],
)
def test_malformed_registrations_are_registration_invalid(content: str) -> None:
    with pytest.raises(RegistrationInvalidError):
        parse_registration("M", content)


def test_an_empty_from_is_registration_invalid() -> None:
    with pytest.raises(RegistrationInvalidError):
        parse_registration("", "<triggers/>")  # OA-REG-8


@pytest.mark.parametrize(
    "content",
    [
        '<triggers><trigger from="WB1" type="**"/></triggers>',
        '<module><trigger type="Test..*"/></module>',
        '<triggers><trigger type="Test Ping"/></triggers>',
        '<phase><retrieves><retrieve type=".A"/></retrieves></phase>',
        '<triggers from="WB1"><trigger type="A."/></triggers>',
    ],
)
def test_invalid_patterns_are_pattern_invalid(content: str) -> None:
    with pytest.raises(PatternInvalidError):
        parse_registration("M", content)  # OA-MATCH-7


def test_more_triggers_than_the_limit_are_limit_exceeded() -> None:
    four = "<triggers>" + '<trigger type="A"/>' * 4 + "</triggers>"
    assert len(parse_registration("M", four, max_triggers=4).triggers) == 4
    with pytest.raises(LimitExceededError):
        parse_registration("M", four, max_triggers=3)  # OA-LIM-6
    spread = (
        '<module><trigger type="A"/><context name="X"><phase><triggers><trigger type="B"/>'
        '</triggers></phase><phase><triggers><trigger type="C"/></triggers></phase>'
        "</context></module>"
    )
    with pytest.raises(LimitExceededError):
        parse_registration("M", spread, max_triggers=2)


def test_the_default_limit_is_1024() -> None:
    content = "<triggers>" + '<trigger type="A"/>' * 1025 + "</triggers>"
    with pytest.raises(LimitExceededError):
        parse_registration("M", content)


def test_hostile_xml_keeps_its_own_condition() -> None:
    with pytest.raises(XmlForbiddenError):
        parse_registration("M", '<!DOCTYPE t [<!ENTITY x "y">]><triggers/>')


def test_parse_registration_element_takes_one_root() -> None:
    (el,) = parse_fragment('<module name="M1"><trigger type="A"/></module>')
    assert parse_registration_element("M", el).triggers == (Trigger(pattern="A"),)
    (el,) = parse_fragment("<retrieves/>")
    with pytest.raises(RegistrationInvalidError):
        parse_registration_element("M", el)


# --- the sample documents of tests/schemas/docs/registration --------------------------------


@pytest.mark.parametrize("path", doc_paths("registration", "valid"), ids=lambda p: p.stem)
def test_valid_registration_samples_are_accepted(path: Path) -> None:
    reg = parse_registration("M", doc_content(path))
    assert reg.module == "M"


# Samples that the schema refuses but the prose accepts: OA-REG-6 says any value other than
# yes means no, and receivers are lenient where the schema describes what senders write.
LENIENT = {"allowselftriggering-true"}


@pytest.mark.parametrize(
    "path",
    [p for p in doc_paths("registration", "invalid") if p.stem not in LENIENT],
    ids=lambda p: p.stem,
)
def test_invalid_registration_samples_are_refused(path: Path) -> None:
    with pytest.raises((RegistrationInvalidError, PatternInvalidError)):
        parse_registration("M", doc_content(path))
