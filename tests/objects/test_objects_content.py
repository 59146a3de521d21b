"""Content objects (spec 3.4, 15.1): capabilities, tcplocation, dictionary, collections, time."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from objects_helpers import (
    capabilities_schema,
    content_schema,
    doc_content,
    doc_paths,
    schema_errors,
)

from openair.protocol.content import Dictionary, TcpLocation
from openair.protocol.errors import (
    ApiMisuseError,
    ContentInvalidError,
    XmlForbiddenError,
    XmlTooDeepError,
)
from openair.protocol.message import Message
from openair.protocol.objects import (
    Capabilities,
    encode_capabilities,
    encode_dictionary,
    encode_message_collection,
    encode_tcplocation,
    encode_time,
    parse_capabilities,
    parse_dictionary,
    parse_message_collection,
    parse_tcplocation,
    parse_time,
)
from openair.protocol.times import AirTime

# Text that XML 1.0 can carry in attributes and elements (no controls, surrogates, U+FFFE/F).
XML_TEXT = st.text(
    st.characters(
        codec="utf-8", exclude_categories=("Cc", "Cs"), exclude_characters="\ufffe\uffff"
    ),
    max_size=12,
)
NAMES = st.from_regex(r"[a-z][a-z0-9]{0,6}(-[a-z0-9]{1,4}){0,2}", fullmatch=True)

# --- capabilities ---------------------------------------------------------------------------

SPEC_CAPABILITIES = """
<capabilities protocol="OpenAIR/1.0" server="openair-kit/0.1.0">
  <extension name="noreply"/>
  <extension name="pipelining"/>
  <limit name="max-frame-xml" value="16777216"/>
  <limit name="max-triggers" value="1024"/>
</capabilities>"""


def test_capabilities_reads_the_spec_example() -> None:
    caps = parse_capabilities(SPEC_CAPABILITIES)
    assert caps.protocol == "OpenAIR/1.0"
    assert caps.server == "openair-kit/0.1.0"
    assert caps.extensions == ("noreply", "pipelining")
    assert caps.limits == (("max-frame-xml", 16777216), ("max-triggers", 1024))
    assert caps.limit("max-triggers", 7) == 1024
    assert caps.limit("max-queue", 7) == 7


def test_capabilities_names_match_in_any_case_and_unknown_children_are_ignored() -> None:
    caps = parse_capabilities(
        '<CAPABILITIES Protocol="OpenAIR/1.0" SERVER="x"><Extension NAME="usec"/>'
        '<future thing="1"/><LIMIT name="max-queue" VALUE="5"/></CAPABILITIES>'
    )
    assert caps == Capabilities(server="x", extensions=("usec",), limits=(("max-queue", 5),))


@pytest.mark.parametrize("path", doc_paths("capabilities", "valid"), ids=lambda p: p.stem)
def test_capabilities_valid_samples_round_trip(path: Path) -> None:
    caps = parse_capabilities(doc_content(path))
    text = encode_capabilities(caps)
    assert parse_capabilities(text) == caps
    assert schema_errors(capabilities_schema(), text, "capabilities") == ""


@pytest.mark.parametrize(
    "content",
    [
        "",
        "<capabilities server='x'/>",  # OA-CAP-1: protocol required
        "<capabilities protocol='OpenAIR/1.0'/>",  # server required
        "<capabilities protocol='OpenAIR/1.0' server='x'><limit name='a' value='many'/>"
        "</capabilities>",
        "<capabilities protocol='OpenAIR/1.0' server='x'><limit name='a' value='-1'/>"
        "</capabilities>",
        "<capabilities protocol='OpenAIR/1.0' server='x'><extension/></capabilities>",
        "<capabilities protocol='OpenAIR/1.0' server='x'/><capabilities/>",
        "<capabilities protocol='OpenAIR/1.0' server='x'>",
        "UNKNOWN_COMMAND",
        "<dictionary/>",
    ],
)
def test_capabilities_refuses_malformed_content(content: str) -> None:
    with pytest.raises(ContentInvalidError):
        parse_capabilities(content)


@given(
    server=XML_TEXT,
    extensions=st.lists(NAMES, unique=True, max_size=5),
    limits=st.dictionaries(NAMES, st.integers(0, 2**40), max_size=5),
)
def test_capabilities_round_trip_and_validate(
    server: str, extensions: list[str], limits: dict[str, int]
) -> None:
    caps = Capabilities(server=server, extensions=tuple(extensions), limits=tuple(limits.items()))
    text = encode_capabilities(caps)
    assert parse_capabilities(text) == caps
    assert schema_errors(capabilities_schema(), text, "capabilities") == ""


# --- tcplocation ----------------------------------------------------------------------------

# psyclone-wire/03-post-wakeup.txt, the RESOLVE_SUCCESS content for WB1 (verbatim).
PSYCLONE_TCPLOCATION = (
    '<tcplocation address="127.0.0.1" port="10110" name="WB1" procid="32" ipnumber="127.0.0.1" '
    'pointer="016C82D8" netprotocol="" auth="127.0.0.1|02401025000302502116023040211602304021160'
    '240101024075690435602401" additional="" />'
)


def test_tcplocation_keeps_psyclone_extra_attributes_in_order() -> None:
    loc = parse_tcplocation(PSYCLONE_TCPLOCATION)
    assert (loc.address, loc.port, loc.name) == ("127.0.0.1", 10110, "WB1")
    assert [k for k, _ in loc.extra] == [
        "procid",
        "ipnumber",
        "pointer",
        "netprotocol",
        "auth",
        "additional",
    ]
    assert dict(loc.extra)["pointer"] == "016C82D8"
    assert parse_tcplocation(encode_tcplocation(loc)) == loc


def test_tcplocation_bind_form_is_port_only() -> None:
    assert encode_tcplocation(TcpLocation(port=10555)) == '<tcplocation port="10555"/>'
    assert parse_tcplocation("<TcpLocation PORT=' 10555 '/>") == TcpLocation(port=10555)


@pytest.mark.parametrize(
    "content",
    [
        "",
        "<tcplocation address='127.0.0.1' name='WB1'/>",
        "<tcplocation port='http'/>",
        "<tcplocation port='1e3'/>",
        "<tcplocation port='99999999999'/>",
        "<tcplocation port='1'/><tcplocation port='2'/>",
        "10110",
    ],
)
def test_tcplocation_refuses_malformed_content(content: str) -> None:
    with pytest.raises(ContentInvalidError):
        parse_tcplocation(content)


def test_tcplocation_port_range_is_the_callers_business() -> None:
    # OA-SESS-4: a BIND for port 0 or 70000 is BIND_REFUSED, decided by the server.
    assert parse_tcplocation("<tcplocation port='70000'/>").port == 70000
    assert parse_tcplocation("<tcplocation port='-1'/>").port == -1


def test_tcplocation_extra_may_not_shadow_a_field() -> None:
    with pytest.raises(ApiMisuseError):
        encode_tcplocation(TcpLocation(port=1, extra=(("Port", "2"),)))


@given(
    address=XML_TEXT,
    port=st.integers(0, 65535),
    name=XML_TEXT,
    extra=st.dictionaries(st.sampled_from(["procid", "auth", "pointer", "x-y"]), XML_TEXT),
)
def test_tcplocation_round_trips_and_validates(
    address: str, port: int, name: str, extra: dict[str, str]
) -> None:
    loc = TcpLocation(address=address, port=port, name=name, extra=tuple(extra.items()))
    text = encode_tcplocation(loc)
    assert parse_tcplocation(text) == loc
    if set(extra) <= {"procid", "auth", "pointer"}:
        assert schema_errors(content_schema(), text, "tcplocation") == ""


# --- dictionary -----------------------------------------------------------------------------

# psyclone-wire/01-connect-bind.txt, the ENTRY answer to GET_ENTRY Global (verbatim).
PSYCLONE_GLOBAL = """<dictionary>
	<entry name="spec"></entry>
	<entry name="name">Default built-in</entry>
	<entry name="title">Psyclone Default</entry>
	<entry name="description">Default built-in PsySpec</entry>
	<entry name="datastorefile"></entry>
	<entry name="htmldir">html</entry>
</dictionary>"""


def test_dictionary_reads_psyclone_global_entry() -> None:
    d = parse_dictionary(PSYCLONE_GLOBAL)
    assert [k for k, _ in d.entries] == [
        "spec",
        "name",
        "title",
        "description",
        "datastorefile",
        "htmldir",
    ]
    assert d.get("name") == "Default built-in"
    assert d.get("spec") == ""
    assert d.get("missing", "none") == "none"


def test_dictionary_unescapes_text_and_keeps_duplicates_in_order() -> None:
    d = parse_dictionary(
        '<DICTIONARY><Entry NAME="a">x &amp; y</Entry><entry name="a">2</entry></DICTIONARY>'
    )
    assert d.entries == (("a", "x & y"), ("a", "2"))
    assert d.get("a") == "x & y"


@pytest.mark.parametrize(
    "content",
    [
        "",
        "<dictionary><entry>no name</entry></dictionary>",
        "<dictionary><entry name='k'><time sec='1' msec='2'/></entry></dictionary>",
        "<dictionary><item name='k'>v</item></dictionary>",
        "<collection><entry>v</entry></collection>",
        "<dictionary>",
    ],
)
def test_dictionary_refuses_malformed_content(content: str) -> None:
    with pytest.raises(ContentInvalidError):
        parse_dictionary(content)


@given(st.lists(st.tuples(XML_TEXT, XML_TEXT), max_size=6))
def test_dictionary_round_trips_and_validates(entries: list[tuple[str, str]]) -> None:
    d = Dictionary(entries=tuple(entries))
    text = encode_dictionary(d)
    assert parse_dictionary(text) == d
    assert schema_errors(content_schema(), text, "dictionary") == ""


def test_encoders_refuse_characters_xml_cannot_carry() -> None:
    # OA-MSG-14: refuse to encode rather than send a malformed frame.
    with pytest.raises(ApiMisuseError):
        encode_dictionary(Dictionary(entries=(("k", "nul\x00"),)))
    with pytest.raises(ApiMisuseError):
        encode_tcplocation(TcpLocation(port=1, name="\x01"))


# --- message collections --------------------------------------------------------------------

# psyclone-wire/05-retrieve.txt, an AIR.Retrieve.Success from WB2 (verbatim): the stored copy
# puts wbid before postedTime and has no content element; a receiver reads it anyway.
PSYCLONE_RETRIEVE_RESULT = """<objectcollection>
	<object>
		<message>
			<type>Psyclone.Context:Psyclone.System.Ready</type>
			<id>dc9e1ef0-9537-47b3-a238-1f4a26c9a823</id>
			<from>Psyclone</from>
			<to>AIRCentral</to>
			<cc></cc>
			<stored>AIRCentral</stored>
			<isresponse></isresponse>
			<wbid>00000000</wbid>
			<postedTime  sec="1795330126" msec="715" tzc="Greenwich_0_60" />
			<receivedTime  sec="1795330126" msec="750" tzc="Greenwich_0_60" />
		</message>
	</object>
</objectcollection>"""


def test_message_collection_reads_psyclone_stored_copies() -> None:
    (msg,) = parse_message_collection(PSYCLONE_RETRIEVE_RESULT)
    assert msg.type == "Psyclone.Context:Psyclone.System.Ready"
    assert msg.stored == "AIRCentral"
    assert msg.wbid == 0
    assert msg.received == AirTime(sec=1795330126, msec=750)
    assert msg.content == ""


def test_message_collection_empty_and_round_trip() -> None:
    assert parse_message_collection("<objectcollection />") == ()
    assert encode_message_collection([]) == "<objectcollection/>"
    msgs = [
        Message(
            type="Ret.A.1",
            sender="Poster",
            to="WB1",
            stored="WB1",
            wbid=3,
            content="c1",
            posted=AirTime(sec=1, msec=2),
            received=AirTime(sec=1, msec=3),
        ),
        Message(
            type="Ret.B.1",
            sender="P",
            content="<b>x</b>",
            content_is_xml=True,
            language="xml",
            posted=AirTime(sec=5, msec=6),
        ),
    ]
    text = encode_message_collection(msgs)
    assert parse_message_collection(text) == tuple(msgs)
    assert schema_errors(content_schema(), text, "objectcollection") == ""


@pytest.mark.parametrize(
    "content",
    [
        "",
        "<objectdictionary/>",
        "<objectcollection><message><type>A</type></message></objectcollection>",
        "<objectcollection><object/></objectcollection>",
        "<objectcollection><object><datasample/></object></objectcollection>",
        "<objectcollection><object><message><type>A</type></message><message><type>B</type>"
        "</message></object></objectcollection>",
        "<objectcollection><object><message><id>no type</id></message></object></objectcollection>",
        "<objectcollection><object><message><type>A</type><postedTime sec='x'/></message>"
        "</object></objectcollection>",
    ],
)
def test_message_collection_refuses_malformed_content(content: str) -> None:
    with pytest.raises(ContentInvalidError):
        parse_message_collection(content)


def test_hostile_xml_keeps_its_own_condition() -> None:
    with pytest.raises(XmlForbiddenError):
        parse_dictionary('<!DOCTYPE d [<!ENTITY x "y">]><dictionary/>')
    with pytest.raises(XmlTooDeepError):
        parse_message_collection("<a>" * 100 + "</a>" * 100)


# --- time -----------------------------------------------------------------------------------


def test_time_reads_any_element_with_sec() -> None:
    assert parse_time('<time sec="1795328338" msec="12"/>') == AirTime(sec=1795328338, msec=12)
    assert parse_time('<TIME SEC="5" MS="7" tzc="Greenwich_0_60"/>') == AirTime(sec=5, msec=7)
    assert parse_time('<now sec="5" msec="0" usec="17"/>') == AirTime(sec=5, usec=17)


@pytest.mark.parametrize(
    "content",
    [
        "",
        "<time msec='1'/>",
        "<time sec='soon'/>",
        "<time sec='1' msec='1000'/>",
        "<time sec='1'/><time sec='2'/>",
        "1795328338",
    ],
)
def test_time_refuses_malformed_content(content: str) -> None:
    with pytest.raises(ContentInvalidError):
        parse_time(content)


@given(
    st.builds(
        AirTime,
        sec=st.integers(-(2**63), 2**63 - 1),
        msec=st.integers(0, 999),
        usec=st.none() | st.integers(0, 999),
    )
)
def test_time_round_trips_and_validates(t: AirTime) -> None:
    text = encode_time("time", t)
    assert parse_time(text) == t
    assert schema_errors(content_schema(), text, "time") == ""


READERS = {
    "tcplocation": parse_tcplocation,
    "dictionary": parse_dictionary,
    "time": parse_time,
    "capabilities": parse_capabilities,
    "objectcollection": parse_message_collection,
}
READABLE_SAMPLES = [
    path
    for path in doc_paths("content", "valid")
    if (root := doc_content(path).split(None, 1)[0].strip("<>/")) in READERS
    and (root != "objectcollection" or "<message" in doc_content(path))
]


def test_there_are_readable_content_samples() -> None:
    assert len(READABLE_SAMPLES) >= 5


@pytest.mark.parametrize("path", READABLE_SAMPLES, ids=lambda p: p.stem)
def test_objects_read_the_valid_content_samples(path: Path) -> None:
    content = doc_content(path)
    READERS[content.split(None, 1)[0].strip("<>/")](content)
