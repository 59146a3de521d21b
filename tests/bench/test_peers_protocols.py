"""The hand-rolled MQTT, NATS and RESP codecs of bench/peers, on known byte strings."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

import pytest


def _load_protocols() -> object:
    """Load bench/peers/protocols.py by path: the repository root is not on pytest's path."""
    path = Path(__file__).resolve().parents[2] / "bench" / "peers" / "protocols.py"
    spec = importlib.util.spec_from_file_location("bench_peers_protocols", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


p: Any = _load_protocols()


@pytest.mark.parametrize(
    ("value", "encoded"),
    [
        (0, b"\x00"),
        (127, b"\x7f"),
        (128, b"\x80\x01"),
        (16_383, b"\xff\x7f"),
        (16_384, b"\x80\x80\x01"),
        (2_097_152, b"\x80\x80\x80\x01"),
        (268_435_455, b"\xff\xff\xff\x7f"),
    ],
)
def test_mqtt_remaining_length_matches_the_spec_table(value: int, encoded: bytes) -> None:
    assert p.mqtt_varint(value) == encoded
    assert p.mqtt_read_varint(b"\x30" + encoded, 1) == (value, 1 + len(encoded))


def test_mqtt_remaining_length_rejects_out_of_range_and_five_bytes() -> None:
    with pytest.raises(ValueError):
        p.mqtt_varint(268_435_456)
    with pytest.raises(ValueError):
        p.mqtt_read_varint(b"\xff\xff\xff\xff\x01", 0)
    assert p.mqtt_read_varint(b"\x80", 0) is None


def test_mqtt_connect_subscribe_publish_bytes() -> None:
    assert p.mqtt_connect("ab", keepalive=60) == (b"\x10\x0e\x00\x04MQTT\x04\x02\x00\x3c\x00\x02ab")
    assert p.mqtt_subscribe(1, ["a/#"]) == b"\x82\x08\x00\x01\x00\x03a/#\x00"
    assert p.mqtt_publish("t", b"hi") == b"\x30\x05\x00\x01thi"


def test_mqtt_publish_with_a_two_byte_remaining_length() -> None:
    packet = p.mqtt_publish("t", b"x" * 200)
    assert packet[:3] == b"\x30\xcb\x01"  # 3 + 200 = 203 = 0x4b | 0x80, then 1
    assert len(packet) == 3 + 203


def test_mqtt_split_keeps_an_incomplete_packet() -> None:
    stream = b"\x20\x02\x00\x00" + b"\x90\x03\x00\x01\x00" + b"\x30\x05\x00\x01t"
    packets, used = p.mqtt_split(stream)
    assert packets == [(p.MQTT_CONNACK, b"\x00\x00"), (p.MQTT_SUBACK, b"\x00\x01\x00")]
    assert used == 9
    topic, data = p.mqtt_publish_payload(p.mqtt_split(p.mqtt_publish("a/b", b"xyz"))[0][0][1])
    assert (topic, data) == ("a/b", b"xyz")


def test_nats_parse_msg_ping_info_and_partial() -> None:
    stream = (
        b'INFO {"server_id":"x"}\r\nMSG bench.flow.data 1 5\r\nhello\r\n'
        b"PING\r\nMSG a.b 2 reply.to 3\r\nabc\r\nMSG a 1 10\r\nshort"
    )
    events, used = p.nats_parse(stream)
    assert events == [
        ("INFO", '{"server_id":"x"}', "", b""),
        ("MSG", "bench.flow.data", "1", b"hello"),
        ("PING", "", "", b""),
        ("MSG", "a.b", "2", b"abc"),
    ]
    assert stream[used:] == b"MSG a 1 10\r\nshort"


def test_nats_payload_may_hold_crlf_and_bad_input_is_rejected() -> None:
    events, _ = p.nats_parse(b"MSG s 1 4\r\n\r\n\r\n\r\n")
    assert events == [("MSG", "s", "1", b"\r\n\r\n")]
    with pytest.raises(ValueError):
        p.nats_parse(b"MSG s 1 2\r\nabcd\r\n")
    with pytest.raises(ValueError):
        p.nats_parse(b"HELLO\r\n")
    assert p.nats_pub("a.b", b"xy") == b"PUB a.b 2\r\nxy\r\n"


def test_resp_encodes_commands_and_parses_replies() -> None:
    assert p.resp_command("PUBLISH", "ch", b"\x00\r\n") == (
        b"*3\r\n$7\r\nPUBLISH\r\n$2\r\nch\r\n$3\r\n\x00\r\n\r\n"
    )
    stream = (
        b"*3\r\n$10\r\npsubscribe\r\n$7\r\nbench.*\r\n:1\r\n"
        b"*4\r\n$8\r\npmessage\r\n$7\r\nbench.*\r\n$1\r\nc\r\n$2\r\nhi\r\n"
        b"+PONG\r\n-ERR wrong\r\n$-1\r\n*2\r\n$1\r\na"
    )
    values, used = p.resp_parse_all(stream)
    assert values == [
        [b"psubscribe", b"bench.*", 1],
        [b"pmessage", b"bench.*", b"c", b"hi"],
        "PONG",
        "ERR wrong",
        None,
    ]
    assert isinstance(values[3], p.RespError)
    assert stream[used:] == b"*2\r\n$1\r\na"


def test_resp_rejects_unknown_type_and_missing_crlf() -> None:
    with pytest.raises(ValueError):
        p.resp_parse(b"?x\r\n")
    with pytest.raises(ValueError):
        p.resp_parse(b"$2\r\nabcd\r\n")


def test_stamps_survive_being_split_anywhere() -> None:
    data, at = p.payload(64)
    messages = [
        p.mqtt_publish("t", data[:at] + p.stamp(i, 10**18 + i) + data[at + p.STAMP_WIDTH :])
        for i in range(3)
    ]
    stream = b"".join(messages)
    for cut in range(len(stream) + 1):
        found: list[tuple[int, int]] = []
        tail = p.scan_stamps(stream[:cut], found)
        p.scan_stamps(tail + stream[cut:], found)
        assert found == [(i, 10**18 + i) for i in range(3)], cut


def test_stamp_and_payload_limits() -> None:
    assert p.stamp(7, 42) == b"7:42" + b"_" * 28
    with pytest.raises(ValueError):
        p.stamp(10**20, 10**20)
    with pytest.raises(ValueError):
        p.payload(p.STAMP_LEN - 1)
