"""Fuzz the reference server's frame and message path over TCP.

Each example opens a fresh connection and sends random bytes, a mutated valid frame, or random XML
in a well-formed frame. Whatever the server does with that connection (answer, RECEIVE_ERROR,
close), afterwards it must still answer PING on a fresh connection (OA-ERR-4) and every post it
acknowledged must still be stored (OA-ERR-5). The long runs are marked `fuzz` (`make fuzz`); a
small smoke run of a few dozen examples is part of `make test`.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import ClassVar

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "server_wire"))
from wire_helpers import RawConn, ServerThread, collection_messages, now

from openair.protocol.codec import encode_message
from openair.protocol.framing import Frame, FrameTag, encode_frame
from openair.protocol.message import Message
from openair.protocol.times import AirTime


class Shared:
    server: ServerThread | None = None
    acked: ClassVar[list[str]] = []


@pytest.fixture(scope="module", autouse=True)
def shared_server() -> Iterator[None]:
    Shared.server = ServerThread()
    Shared.acked = []
    yield
    Shared.server.stop()
    Shared.server = None


def port() -> int:
    assert Shared.server is not None
    return Shared.server.port


def valid_post(n: int) -> Message:
    return Message(
        type=f"Fuzz.Post.N{n}",
        sender="Fuzzer",
        to="WB1",
        posted=now(),
        priority=2.0,
        content=f"post {n}",
    )


#: A fixed valid frame (fixed id and time, so every example draws the same way) to mutate.
TEMPLATE = encode_frame(
    Frame(
        tag=FrameTag.MESSAGE,
        xml=encode_message(
            Message(
                type="Fuzz.Template",
                id="t-1",
                sender="Fuzzer",
                to="WB1",
                priority=2.0,
                posted=AirTime(sec=1795328371, msec=396),
                content="template",
            )
        ),
    )
)
XML_PIECES = st.sampled_from(
    [
        "<message>",
        "</message>",
        "<type>",
        "</type>",
        "Fuzz.X",
        "<to>WB1</to>",
        "<id>x</id>",
        '<content language="xml">',
        "</content>",
        "<binarysizes>3,4</binarysizes>",
        "<!DOCTYPE m [<!ENTITY e 'x'>]>",
        "&e;",
        '<postedTime sec="x"/>',
        "<a><b><c>",
        'priority="9"',
        '<message priority="-1">',
        "\x00",
        "\ufffe",
        "é",
        "<![CDATA[",
        "<retrieve/>",
        "<type>AIR.Retrieve</type>",
        "<type>BIND</type>",
        "<from>;</from>",
    ]
)
RANDOM_XML = st.lists(XML_PIECES | st.text(max_size=8), max_size=30).map("".join)


@st.composite
def mutated_frame(draw: st.DrawFn) -> bytes:
    """A valid post frame with a few bytes changed, inserted or cut (header included)."""
    data = bytearray(TEMPLATE)
    for _ in range(draw(st.integers(1, 4))):
        where = draw(st.integers(0, len(data) - 1))
        action = draw(st.sampled_from(("flip", "insert", "cut")))
        if action == "flip":
            data[where] ^= 1 << draw(st.integers(0, 7))
        elif action == "insert":
            data[where:where] = draw(st.binary(min_size=1, max_size=8))
        else:
            del data[where : where + draw(st.integers(1, 8))]
    return bytes(data)


PAYLOADS = st.one_of(
    st.binary(max_size=300),
    mutated_frame(),
    RANDOM_XML.map(lambda x: encode_frame(Frame(tag=FrameTag.MESSAGE, xml=x.encode("utf-8")))),
)


def poke(payload: bytes, post_number: int) -> None:
    """Send `payload` on a fresh connection, then check the server on another one."""
    hostile = RawConn(port())
    with contextlib.suppress(OSError):  # the server may have closed it already (framing error)
        hostile.send_raw(payload)
    check = RawConn(port())
    try:
        reply = check.request(Message(type="PING", sender="Fuzzer", to="CNS", posted=now()))
        assert reply.type == "PING_SUCCESS"  # OA-ERR-4: one bad connection harms no other
        post = valid_post(post_number)
        if check.request(post).type == "RECEIVE_ACCEPT":
            Shared.acked.append(post.id)
        spec = '<retrieve from="WB1" type="Fuzz.Post.*"><latest>0</latest></retrieve>'
        ret = check.request(
            Message(
                type="AIR.Retrieve",
                sender="Fuzzer",
                to="WB1",
                posted=now(),
                content=spec,
                content_is_xml=True,
                language="xml",
            )
        )
        stored = {m.id for m in collection_messages(ret)}
        lost = [i for i in Shared.acked if i not in stored]
        assert not lost, f"acknowledged posts lost (OA-ERR-5): {lost}"
    finally:
        hostile.close()
        check.close()


_COUNT = iter(range(10**9))


@settings(max_examples=40, suppress_health_check=[HealthCheck.too_slow], deadline=None)
@given(payload=PAYLOADS)
def test_fuzz_smoke(payload: bytes) -> None:
    poke(payload, next(_COUNT))


@pytest.mark.fuzz
@settings(suppress_health_check=list(HealthCheck), deadline=None)
@given(payload=PAYLOADS)
def test_fuzz_frames(payload: bytes) -> None:
    poke(payload, next(_COUNT))


@pytest.mark.fuzz
@settings(suppress_health_check=list(HealthCheck), deadline=None)
@given(chunks=st.lists(PAYLOADS, min_size=2, max_size=5))
def test_fuzz_pipelined_garbage(chunks: list[bytes]) -> None:
    """Several hostile frames back to back on one connection."""
    poke(b"".join(chunks), next(_COUNT))
