"""Stream requests and replies without I/O: builders, readers, chunk parts, error mapping."""

from __future__ import annotations

from dataclasses import replace

import pytest
from client_helpers import FIXED_NS, frames, wire
from hypothesis import given
from hypothesis import strategies as st

from openair.client.link import _JOIN_BELOW
from openair.client.module import FailedReplyError
from openair.client.session import ClientConnection, Reply
from openair.client.stream_wire import (
    StreamInfo,
    add_sample_request,
    add_samples_request,
    alarm_of,
    ids_of,
    integer_of,
    is_alarm,
    make_sample,
    range_content,
    received_sample,
    sample_of,
    samples_of,
    search_content,
    stream_info_of,
    stream_list_of,
    time_content,
    timestamp_of,
    wait_type,
)
from openair.client.streams import error_from
from openair.protocol.codec import encode_message
from openair.protocol.datasample import DataSample, chunk_parts, encode_chunk
from openair.protocol.errors import (
    ApiMisuseError,
    CommandUnknownError,
    ContentInvalidError,
    SampleInvalidError,
    SampleUnknownError,
    StreamUnknownError,
)
from openair.protocol.framing import FrameLimits, FrameReader, FrameTag, coalesce
from openair.protocol.message import Message, Slot
from openair.protocol.objects import parse_root, parse_time
from openair.protocol.times import AirTime


def conn(window: int = 4) -> ClientConnection:
    return ClientConnection(now=lambda: FIXED_NS, name="Writer", window=window)


def joined(parts: list[bytes | bytearray | memoryview]) -> bytes:
    return b"".join(bytes(p) for p in parts)


# -- samples ----------------------------------------------------------------------------------


def test_make_sample_appends_builtins_after_params_in_order() -> None:
    s = make_sample(b"abc", {"k": "v", "b": "2"}, timestamp_ms=1234, seq=7)
    assert s.params == (("k", "v"), ("b", "2"), ("builtin:timestamp", "1234"), ("builtin:seq", "7"))
    assert (s.timestamp_ms, s.seq) == (1234, 7)


def test_make_sample_keeps_a_sample_and_replaces_keys_in_place() -> None:
    base = DataSample(payload=b"x", params=(("builtin:seq", "1"), ("a", "b")))
    s = make_sample(base, {"a": "c"}, seq=2)
    assert s.params == (("builtin:seq", "2"), ("a", "c"))
    assert s.payload is base.payload  # shared, not copied


def test_make_sample_views_a_bytearray_without_copying() -> None:
    buf = bytearray(b"live")
    s = make_sample(buf)
    buf[0:1] = b"L"
    assert bytes(s.payload) == b"Live"


def test_make_sample_refuses_a_negative_timestamp() -> None:
    with pytest.raises(ApiMisuseError):
        make_sample(b"", timestamp_ms=-1)


# -- requests ---------------------------------------------------------------------------------


def test_add_sample_request_content_and_noreply() -> None:
    msg = add_sample_request("Stream1", "Writer")
    assert (msg.type, msg.to, msg.sender, msg.language) == (
        "ADD_SAMPLE",
        "Stream1",
        "Writer",
        "xml",
    )
    assert msg.content == "<datasample/>" and msg.content_is_xml and not msg.noreply
    assert add_sample_request("Stream1", "Writer", noreply=True).noreply


def test_add_samples_request_has_one_object_per_sample() -> None:
    msg = add_samples_request("S", "W", 3)
    root = parse_root(msg.content, ("objectcollection",), ContentInvalidError)
    assert [el[0].tag for el in root] == ["datasample"] * 3
    with pytest.raises(ApiMisuseError):
        add_samples_request("S", "W", 0)


def test_time_and_range_contents() -> None:
    assert parse_time(time_content(1_700_000_000_123)) == AirTime(sec=1_700_000_000, msec=123)
    assert time_content(AirTime(sec=5, msec=6)) == time_content(5006)
    root = parse_root(range_content(1000, 2500), ("objectcollection",), ContentInvalidError)
    bounds = [(el[0].get("sec"), el[0].get("msec")) for el in root]
    assert bounds == [("1", "0"), ("2", "500")]


@pytest.mark.parametrize(
    ("by_id", "last", "expected"),
    [
        (True, False, "WAIT_FOR_FIRST_AFTERID 250"),
        (True, True, "WAIT_FOR_LAST_AFTERID 250"),
        (False, False, "WAIT_FOR_FIRST_SAMPLE 250"),
        (False, True, "WAIT_FOR_LAST_SAMPLE 250"),
    ],
)
def test_wait_types(by_id: bool, last: bool, expected: str) -> None:
    assert wait_type(by_id=by_id, last=last, timeout_ms=250) == expected


def test_wait_type_refuses_negative_timeouts() -> None:
    with pytest.raises(ApiMisuseError):
        wait_type(by_id=True, last=False, timeout_ms=-1)


def test_search_content_children_in_order() -> None:
    text = search_content(after=1000, until=AirTime(sec=2), params={"who": "a*"}, latest=3)
    root = parse_root(text, ("samplesearch",), ContentInvalidError)
    assert [(el.tag, el.get("name"), el.text) for el in root] == [
        ("afterTime", None, "1000"),
        ("untilTime", None, "2000"),
        ("param", "who", "a*"),
        ("latest", None, "3"),
    ]
    assert search_content() == "<samplesearch/>"


# -- chunk parts on the wire ------------------------------------------------------------------


samples = st.builds(
    DataSample,
    payload=st.binary(max_size=64),
    params=st.lists(
        st.tuples(
            st.from_regex(r"[a-z]{1,6}", fullmatch=True),
            st.from_regex(r"[a-z0-9]*", fullmatch=True),
        ),
        max_size=3,
    ).map(tuple),
)


@given(st.lists(samples, min_size=1, max_size=4), st.booleans())
def test_request_parts_equal_the_joined_frame(batch: list[DataSample], usec: bool) -> None:
    msg = (
        add_samples_request("S", "W", len(batch))
        if len(batch) > 1
        else add_sample_request("S", "W")
    )
    extensions = {"usec"} if usec else set()
    a = ClientConnection(now=lambda: FIXED_NS, extensions=extensions)
    b = ClientConnection(now=lambda: FIXED_NS, extensions=extensions)
    parts = a.send_request_parts(msg, [chunk_parts(s) for s in batch])
    whole = b.send_request(replace(msg, binary=tuple(encode_chunk(s) for s in batch)))
    assert joined(parts) == whole  # byte-identical to the codec's frame (canonical XML)
    assert b.last_sent is not None and a.in_flight == 1
    assert a.last_sent == replace(b.last_sent, binary=())


def test_request_parts_keep_the_payload_object() -> None:
    payload = memoryview(bytearray(b"\x01" * 1000))
    sample = DataSample(payload=payload)
    parts = conn().send_request_parts(add_sample_request("S", "W"), [chunk_parts(sample)])
    assert any(p is payload for p in parts)  # written as is, not joined


def test_request_parts_with_extension_slots_and_no_chunks() -> None:
    msg = Message(type="A.B", to="WB1", content="x", extras=(Slot(name="zz", value="1"),))
    a, b = conn(), conn()
    assert joined(a.send_request_parts(msg, [])) == b.send_request(msg)
    with_chunk = a.send_request_parts(msg, [[b"ab", memoryview(b"cd")]])
    ((tag, decoded),) = frames(joined(with_chunk))
    assert tag is FrameTag.MESSAGE and decoded.binary == (b"abcd",)
    assert encode_message(replace(msg, binary=(b"abcd",), posted=decoded.posted)) in joined(
        with_chunk
    )


def test_request_parts_refuse_chunks_given_twice() -> None:
    with pytest.raises(ApiMisuseError):
        conn().send_request_parts(Message(type="A.B", binary=(b"x",)), [[b"y"]])


def test_noreply_parts_are_not_in_flight() -> None:
    c = ClientConnection(now=lambda: FIXED_NS, extensions={"noreply"})
    c.send_request_parts(add_sample_request("S", "W", noreply=True), [chunk_parts(DataSample())])
    assert c.in_flight == 0 and c.counters.requests_sent == 1


def test_binary_frame_and_its_reply() -> None:
    c = conn(window=1)
    sample = DataSample(payload=b"pcm", params=(("builtin:seq", "1"),))
    parts = c.send_binary(chunk_parts(sample))
    reader = FrameReader(FrameLimits())
    reader.feed(joined(parts))
    frame = reader.next_frame()
    assert frame is not None and frame.tag is FrameTag.BINARY
    assert frame.chunks == (encode_chunk(sample),)
    assert c.in_flight == 1
    with pytest.raises(ApiMisuseError):
        c.send_binary([b"x"])  # OA-SESS-18: the window holds one request
    reply = Message(type="DATA_ACCEPTED", sender="Stream1", content="1")  # isresponse empty
    (event,) = c.receive_data(wire(reply))
    assert isinstance(event, Reply) and event.message.content == "1"


# -- replies ----------------------------------------------------------------------------------


def datasample(*batch: DataSample, type_: str = "DATASAMPLE") -> Message:
    if type_ == "DATASAMPLE":
        content = "<datasample/>"
    else:
        content = "<objectcollection>" + "<object><datasample/></object>" * len(batch)
        content += "</objectcollection>"
    return Message(
        type=type_,
        sender="Stream1",
        content=content,
        content_is_xml=True,
        language="xml",
        binary=tuple(encode_chunk(s) for s in batch),
    )


def test_sample_reply_is_a_view_of_the_chunk() -> None:
    sample = DataSample(payload=b"hello", params=(("builtin:id", "4"),))
    msg = datasample(sample)
    got = sample_of(msg)
    assert got == sample and got.id == 4
    assert isinstance(got.payload, memoryview) and got.payload.obj is msg.binary[0]


def test_sample_reply_needs_exactly_one_chunk() -> None:
    with pytest.raises(SampleInvalidError):
        sample_of(datasample())
    with pytest.raises(SampleInvalidError):
        sample_of(replace(datasample(DataSample()), binary=(b"\x05\x00\x00\x00ab\x00",)))


def test_samples_reply_in_order_and_counted() -> None:
    batch = [DataSample(payload=bytes([i])) for i in range(3)]
    assert samples_of(datasample(*batch, type_="DATASAMPLES")) == batch
    empty = Message(type="DATASAMPLES", content="<objectcollection/>", content_is_xml=True)
    assert samples_of(empty) == []
    wrong = replace(datasample(*batch, type_="DATASAMPLES"), binary=())
    with pytest.raises(ContentInvalidError):
        samples_of(wrong)


def test_integer_ids_and_timestamp_replies() -> None:
    assert integer_of(Message(type="COUNT", content=" 12 "), "count") == 12
    for bad in ("", "-1", "x"):
        with pytest.raises(ContentInvalidError):
            integer_of(Message(type="COUNT", content=bad), "count")
    ok = Message(
        type="DATA_ACCEPTED", content="<collection><entry>3</entry><entry>4</entry></collection>"
    )
    assert ids_of(ok) == [3, 4]
    with pytest.raises(ContentInvalidError):
        ids_of(Message(type="DATA_ACCEPTED", content="<collection><item>3</item></collection>"))
    stamp = Message(type="TIMESTAMP", content='<time sec="2" msec="5"/>', content_is_xml=True)
    assert timestamp_of(stamp) == 2005


INFO = (
    '<streaminfo name="Audio" whiteboard="WB1" type="Input.Audio.Perception" count="2" '
    'size="10" oldest="4" newest="5" maxsize="1048576" maxcount="0" softsize="100" '
    'subscribers="1" writers="1" idle="5000" locked="0" future="x"/>'
)


def test_stream_info_reads_every_attribute() -> None:
    info = stream_info_of(Message(type="INFO", content=INFO, content_is_xml=True))
    assert info == StreamInfo(
        name="Audio", whiteboard="WB1", type="Input.Audio.Perception", count=2, size=10,
        oldest=4, newest=5, maxsize=1048576, maxcount=0, softsize=100, subscribers=1,
        writers=1, idle=5000, locked=0, extra=(("future", "x"),),
    )  # fmt: skip
    assert info.as_dict()["future"] == "x" and info.as_dict()["hardsize"] is None
    assert eval(repr(info)) == info  # valid-Python repr


def test_stream_info_refuses_bad_numbers_and_missing_names() -> None:
    for bad in ('<streaminfo name="A" count="many"/>', '<streaminfo count="1"/>', "<other/>"):
        with pytest.raises(ContentInvalidError):
            stream_info_of(Message(type="INFO", content=bad, content_is_xml=True))


def test_stream_list() -> None:
    content = f'<streams>{INFO}<streaminfo name="Stream2" whiteboard="WB2"/></streams>'
    listed = stream_list_of(Message(type="STREAMS", content=content, content_is_xml=True))
    assert [(i.name, i.whiteboard, i.oldest) for i in listed] == [
        ("Audio", "WB1", 4),
        ("Stream2", "WB2", None),
    ]


def test_received_sample_reads_the_dropped_slot() -> None:
    msg = datasample(DataSample(payload=b"a")).with_extra("dropped", "7")
    got = received_sample(msg, 99)
    assert (got.stream, got.dropped, got.received_ns, bytes(got.sample.payload)) == (
        "Stream1", 7, 99, b"a",
    )  # fmt: skip
    assert received_sample(datasample(DataSample())).dropped == 0
    with pytest.raises(ContentInvalidError):
        received_sample(msg.with_extra("dropped", "-2"))


def test_alarm_parsing() -> None:
    content = (
        '<dictionary><entry name="stream">Audio</entry><entry name="streamtype">In.A</entry>'
        '<entry name="time">5</entry><entry name="dropped">3</entry></dictionary>'
    )
    msg = Message(type="AIR.Stream.Alarm.HardLimit", sender="Audio", content=content,
                  content_is_xml=True)  # fmt: skip
    alarm = alarm_of(msg)
    assert (alarm.kind, alarm.stream, alarm.entries["dropped"]) == ("HardLimit", "Audio", "3")
    assert not is_alarm(Message(type="AIR.Stream.Alarm."))
    with pytest.raises(ContentInvalidError):
        alarm_of(Message(type="Other.Type"))


# -- error mapping ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("reply", "expected"),
    [
        (Message(type="RECEIVE_ERROR", content="SAMPLE_UNKNOWN: no sample 9"), SampleUnknownError),
        (Message(type="RECEIVE_ERROR", content="STREAM_UNKNOWN: no X"), StreamUnknownError),
        (Message(type="DATA_NOT_ACCEPTED", content="SAMPLE_INVALID: too big"), SampleInvalidError),
        (Message(type="UNKNOWN_COMMAND", content="Offending cmd: FOO"), CommandUnknownError),
        (Message(type="RECEIVE_ERROR", content="API_MISUSE: local only"), FailedReplyError),
        (Message(type="NAME", content="unexpected"), FailedReplyError),
    ],
)
def test_error_from_maps_named_conditions(reply: Message, expected: type[Exception]) -> None:
    sent = Message(type="GET_COUNT", to="S")
    error = error_from(sent, reply)
    assert type(error) is expected
    cause = error if isinstance(error, FailedReplyError) else error.__cause__
    assert isinstance(cause, FailedReplyError) and cause.response is reply


def test_error_from_keeps_the_detail() -> None:
    error = error_from(
        Message(type="X"), Message(type="RECEIVE_ERROR", content="SAMPLE_UNKNOWN: gone")
    )
    assert error.detail == "gone"


def test_the_writer_joins_small_parts_and_keeps_large_ones() -> None:
    big = memoryview(bytearray(100_000))
    parts: list[bytes | bytearray | memoryview] = [b"head", b"len4", big, b"params\0"]
    out = coalesce(parts, _JOIN_BELOW)
    assert out[0] == b"headlen4" and out[1] is big and out[2] == b"params\0"
    assert coalesce([b"a", b"b", b"c"], _JOIN_BELOW) == [b"abc"]
    assert coalesce([], _JOIN_BELOW) == []
