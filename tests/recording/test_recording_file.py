"""The recording file: exact bytes back, streaming reads, cut-off and hostile files, filters."""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import pytest
from click.testing import CliRunner

from openair.cli import main
from openair.protocol.datasample import DataSample
from openair.protocol.errors import (
    BinarySizesInvalidError,
    FrameTooLargeError,
    FrameTruncatedError,
    FrameUnknownTagError,
    MessageInvalidError,
    OpenAIRError,
    XmlForbiddenError,
)
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair_recording import (
    Header,
    MessageRecord,
    RecordingReader,
    RecordingWriter,
    ReplayOptions,
    SampleRecord,
    plan,
    read_index,
)
from openair_recording.fileformat import MAGIC

BASE_MS = 1_800_000_000_000
HEADER = Header(server="127.0.0.1:1", started_ns=BASE_MS * 1_000_000, whiteboards=("WB1",))


def stored(type_: str, wbid: int, at_ms: int, **slots: object) -> Message:
    return Message(
        type=type_, sender="Poster", to="WB1", stored="WB1", wbid=wbid,
        posted=AirTime(sec=at_ms // 1000, msec=at_ms % 1000, usec=123),
        received=AirTime.from_ms(at_ms + 1), **slots,  # type: ignore[arg-type]
    )  # fmt: skip


MESSAGES = [
    stored("Cam.Frame", 1, BASE_MS, binary=(bytes(range(256)), b"", b"\x00" * 3), priority=0.25),
    stored(
        "Ears.Word",
        2,
        BASE_MS + 2000,
        content="<w>hi</w>",
        content_is_xml=True,
        language="xml",
        cc="A;B",
    ),
    stored("Cam.Frame", 3, BASE_MS + 5000, content="é ✓", language="LISP", content_version="CL"),
]
SAMPLE = DataSample(
    payload=b"\x00\xff" * 100,
    params=(("builtin:id", "7"), ("builtin:timestamp", str(BASE_MS + 3000)), ("k", "v")),
)


def write(path: Path, *, close: bool = True) -> RecordingWriter:
    writer = RecordingWriter(path, HEADER)
    writer.add_message(MESSAGES[0], 1)
    writer.add_message(MESSAGES[1], 2)
    writer.add_sample("Mic", SAMPLE, 3, dropped=4)
    writer.add_message(MESSAGES[2], 4)
    if close:
        writer.close(5)
    return writer


def read(path: Path) -> tuple[RecordingReader, list[MessageRecord | SampleRecord]]:
    reader = RecordingReader.open(path)
    return reader, list(reader.records())


def test_every_slot_attachment_and_payload_comes_back_exactly(tmp_path: Path) -> None:
    path = tmp_path / "r.oair"
    write(path)
    reader, records = read(path)
    assert reader.header == HEADER and reader.complete and reader.warnings == []
    messages = [r.message for r in records if isinstance(r, MessageRecord)]
    assert messages == MESSAGES  # ids, both times (with usec), binary, priority, cc, language…
    sample = next(r for r in records if isinstance(r, SampleRecord))
    assert (sample.stream, sample.dropped, sample.captured_ns) == ("Mic", 4, 3)
    assert sample.sample == SAMPLE and sample.sample.id == 7


def test_the_index_points_at_every_record(tmp_path: Path) -> None:
    path = tmp_path / "r.oair"
    write(path)
    index = read_index(path)
    _, records = read(path)
    assert index is not None
    assert [e.tag for e in index] == [b"H", b"M", b"M", b"S", b"M"]
    assert [e.offset for e in index[1:]] == [r.offset for r in records]
    assert [e.time_ns for e in index[1:]] == [1, 2, 3, 4]


def test_a_crashed_recording_is_readable_and_says_it_did_not_stop(tmp_path: Path) -> None:
    path = tmp_path / "r.oair"
    write(path, close=False)  # flushed record by record: no index, no end record
    assert read_index(path) is None
    reader, records = read(path)
    assert len(records) == 4 and not reader.complete
    assert any("no end record" in w for w in reader.warnings)


@pytest.mark.parametrize("cut", [1, 7, 30])
def test_a_file_cut_mid_record_is_read_up_to_the_last_whole_record(
    tmp_path: Path, cut: int
) -> None:
    path = tmp_path / "r.oair"
    write(path, close=False)
    _, records = read(path)
    last = records[-1].offset
    data = path.read_bytes()
    path.write_bytes(data[: last + cut])
    reader, kept = read(path)
    assert [r.offset for r in kept] == [r.offset for r in records[:-1]]
    assert (
        len(reader.warnings) == 1
        and f"truncated: the record at byte {last}" in (reader.warnings[0])
    )


def frame(tag: bytes, body: bytes, crc: int | None = None) -> bytes:
    check = zlib.crc32(tag + body) if crc is None else crc
    return tag + struct.pack("<I", len(body)) + body + struct.pack("<I", check)


def header_frame() -> bytes:
    return frame(b"H", HEADER.to_json())


def message_body(xml: bytes, xml_len: int | None = None) -> bytes:
    size = len(xml) if xml_len is None else xml_len
    return struct.pack("<QI", 1, size) + xml + struct.pack("<I", 0)


GOOD_XML = b"<message><type>A.B</type><id>1</id></message>"
HOSTILE = {
    "not a recording": (b"<?xml version='1.0'?><recording/>", FrameUnknownTagError),
    "unknown tag": (MAGIC + header_frame() + frame(b"Z", b""), FrameUnknownTagError),
    "length over the limit": (
        MAGIC + header_frame() + b"M" + struct.pack("<I", 0xFFFFFFFF) + b"\0" * 64,
        FrameTooLargeError,
    ),
    "XML length past the record": (
        MAGIC + header_frame() + frame(b"M", message_body(GOOD_XML, 10_000)),
        BinarySizesInvalidError,
    ),
    "bad checksum mid-file": (
        MAGIC + header_frame() + frame(b"M", message_body(GOOD_XML), 1) + frame(b"E", b""),
        BinarySizesInvalidError,
    ),
    "DOCTYPE in a message": (
        MAGIC
        + header_frame()
        + frame(b"M", message_body(b'<!DOCTYPE m [<!ENTITY x "y">]><message/>')),
        XmlForbiddenError,
    ),
    "header is not JSON": (MAGIC + frame(b"H", b"{nope"), MessageInvalidError),
    "cut inside the header": (MAGIC + header_frame()[:9], FrameTruncatedError),
    "header of another format": (
        MAGIC + frame(b"H", json.dumps({"format": 99}).encode()),
        MessageInvalidError,
    ),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_a_hostile_file_gives_a_clear_error(tmp_path: Path, case: str) -> None:
    data, error = HOSTILE[case]
    path = tmp_path / "bad.oair"
    path.write_bytes(data)
    with pytest.raises(OpenAIRError) as caught:
        read(path)
    assert isinstance(caught.value, error), caught.value
    assert str(path) in str(caught.value) or "record at" in str(caught.value)


def test_the_cli_refuses_a_hostile_file_with_exit_2(tmp_path: Path) -> None:
    path = tmp_path / "bad.oair"
    path.write_bytes(HOSTILE["length over the limit"][0])
    result = CliRunner().invoke(main, ["replay", str(path), "--to", "127.0.0.1:1"])
    assert result.exit_code == 2
    assert "not a readable recording" in result.output and "max" in result.output


def test_filters_select_by_time_window_and_type(tmp_path: Path) -> None:
    path = tmp_path / "r.oair"
    write(path)
    _, records = read(path)
    start = (BASE_MS + 1) * 1000  # the first receivedTime, in µs

    def chosen(options: ReplayOptions) -> list[str]:
        steps = plan(records, options)
        return [
            s.record.message.type if isinstance(s.record, MessageRecord) else "sample"
            for s in steps
        ]

    assert chosen(ReplayOptions(speed=0)) == ["Cam.Frame", "Ears.Word", "sample", "Cam.Frame"]
    assert chosen(ReplayOptions(types="Cam.*")) == ["Cam.Frame", "sample", "Cam.Frame"]
    window = ReplayOptions(from_us=start + 1_000_000, until_us=start + 3_000_000)
    assert chosen(window) == ["Ears.Word", "sample"]
    assert chosen(ReplayOptions(from_us=start + 4_000_000)) == ["Cam.Frame"]


def test_speed_scales_every_gap_by_the_same_factor(tmp_path: Path) -> None:
    path = tmp_path / "r.oair"
    write(path)
    _, records = read(path)
    normal = [s.delay for s in plan(records, ReplayOptions(speed=1.0))]
    fast = [s.delay for s in plan(records, ReplayOptions(speed=2.5))]
    assert normal[0] == 0 and all(d > 0 for d in normal[1:])
    assert all(abs(n / f - 2.5) < 1e-9 for n, f in zip(normal[1:], fast[1:], strict=True))
    assert [s.delay for s in plan(records, ReplayOptions(speed=0))] == [0.0] * 4


def test_ontology_infer_reads_a_recording(tmp_path: Path) -> None:
    path = tmp_path / "r.oair"
    write(path)
    out = tmp_path / "onto.xml"
    result = CliRunner().invoke(
        main, ["ontology", "infer", "--from-recording", str(path), "-o", str(out)]
    )
    assert result.exit_code == 0, result.output
    text = out.read_text()
    assert 'segment="Frame"' in text and 'segment="Word"' in text
    assert 'count="2"' in text  # Cam.Frame was posted twice
    assert "2 types from 3 messages" in result.output


def test_ontology_infer_warns_about_a_cut_recording(tmp_path: Path) -> None:
    path = tmp_path / "r.oair"
    write(path, close=False)
    path.write_bytes(path.read_bytes()[:-5])
    result = CliRunner().invoke(
        main, ["ontology", "infer", "--from-recording", str(path), "-o", str(tmp_path / "o.xml")]
    )
    assert result.exit_code == 0, result.output
    assert "warning:" in result.output and "truncated" in result.output
    assert "2 types from 2 messages" in result.output


def test_recorded_stream_sizes_are_created_in_mib() -> None:
    # GET_STREAMS reports bytes; <stream maxsize> is in MiB (OA-STREAM-9).
    from openair_recording.replay import _mib

    assert _mib("10485760") == "10"
    assert _mib("524288") == "0.5"
    assert _mib("0") == "" and _mib("") == "" and _mib("x") == ""
