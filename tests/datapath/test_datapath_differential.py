"""Differential tests of the data path (issue #20): the reference, the Python and the native path
write byte-identical frames and store identical state for the same traffic.

The traffic is generated: canonical and non-canonical posts (priorities, noreply, cc, `after`,
invalid types, entities), requests to CNS, to a module and to unknown names, frames with binary
chunks, malformed XML, an unknown frame tag; the wakeups are answered with canonical,
non-canonical and malformed acknowledgements and refusals; every byte stream is cut into reads
at generated places (partial reads at any byte). See datapath_harness for the determinism.
"""

from __future__ import annotations

import asyncio
import re
from collections.abc import Mapping

import pytest
from datapath_harness import (
    TRIGGERS,
    Run,
    Transcript,
    datapaths,
    fixed_clock_and_ids,
    frame,
    frames_of,
    request,
    start,
)
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from openair.protocol.framing import FrameTag
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.server.aio.datapath import DataPath
from openair.server.aio.datapath.pure import PurePath

_POSTED = AirTime(sec=1_764_300_000, msec=7)
_TYPES = ["Test.A", "Test.B.c", "Late.X", "Other.Y", "Bad..Type", "AIR.Subscribe", "RETRIEVE"]
_ID = re.compile(rb"<id>([^<]*)</id>")


def _raw(xml: bytes, tag: bytes = b"Message\0") -> bytes:
    return tag + len(xml).to_bytes(4, "little") + xml


@st.composite
def _post(draw: st.DrawFn, n: int) -> bytes:
    """One frame the poster sends: mostly canonical posts, sometimes anything else."""
    kind = draw(st.sampled_from(["post"] * 6 + ["odd", "bad", "chunks", "cns", "module"]))
    ident = f"p{n}"
    if kind == "odd":  # valid but not canonical: an XML declaration and whitespace
        return _raw(
            b'<?xml version="1.0"?>\n<message>\n <type>Test.A</type><id>'
            + ident.encode()
            + b"</id><from>P</from><to>WB1</to></message>"
        )
    if kind == "bad":
        return _raw(draw(st.sampled_from([b"<message><type>Test.A</type>", b"<nope/>", b"\xff"])))
    if kind == "cns":
        return request(draw(st.sampled_from(["PING", "STATUS", "NOPE"])), "P", "CNS", ident)
    if kind == "module":
        return request("Test.Direct", "P", draw(st.sampled_from(["M1", "Nobody"])), ident)
    content = draw(st.text(st.sampled_from("ab &<>\"'é"), max_size=6))
    msg = Message(
        type=draw(st.sampled_from(_TYPES)),
        id=ident,
        sender="P",
        to=draw(st.sampled_from(["WB1", "WB1", "WB2"])),
        posted=_POSTED,
        content=content,
        priority=draw(st.sampled_from([None, 0.5, 3.0, 6.999])),
        noreply=draw(st.booleans()),
        cc=draw(st.sampled_from(["", "M1"])),
        binary=(b"\x00chunk",) if kind == "chunks" else (),
    )
    return frame(msg)


def _ack(wakeup_xml: bytes, variant: str) -> bytes:
    found = _ID.search(wakeup_xml)
    ident = found.group(1).decode() if found else ""
    if variant == "malformed":
        return _raw(b"<message><type>RECEIVE_ACCEPT</type><id>x</id>")
    if variant == "declared":
        return _raw(
            b'<?xml version="1.0"?><message><type>RECEIVE_ACCEPT</type><isresponse>'
            + ident.encode()
            + b"</isresponse></message>"
        )
    kind = "RECEIVE_ERROR" if variant == "refused" else "RECEIVE_ACCEPT"
    msg = Message(type=kind, id="a" + ident[-4:], sender="M1", isresponse=ident, posted=_POSTED)
    return frame(msg)


_ACKS = st.sampled_from(["canonical"] * 5 + ["malformed", "declared", "refused"])


async def _script(
    run: Run, posts: bytes, cuts: list[int], acks: list[str], ack_cuts: list[int]
) -> Transcript:
    module, callback, poster = run.open(), run.open(), run.open()
    await run.feed(module, request("BIND_NOLISTEN", "M1", "CNS", "b1"))
    await run.feed(module, request("AIR.Subscribe", "M1", "WB1", "s1", TRIGGERS))
    notify = Message(type="RECEIVE_NAME_NOTIFICATION", id="r1", sender="M1", posted=_POSTED)
    await run.feed(callback, frame(notify, FrameTag.RECEIVE))
    await run.feed(poster, request("BIND", "P", "CNS", "b2"))
    answered = 0
    for round_ in range(4):
        part = len(posts) * (round_ + 1) // 4
        done = len(posts) * round_ // 4
        await run.feed(poster, posts[done:part], [c - done for c in cuts])
        run.now[0] += 7_000_000  # 7 ms: `after` delays fall due
        await asyncio.sleep(0.01)
        await run.settle()
        wakeups = frames_of(run.transports[callback].written)[answered:]
        answered += len(wakeups)
        replies = b"".join(_ack(x, acks[i % len(acks)]) for i, x in enumerate(wakeups))
        await run.feed(callback, replies, ack_cuts)
    return run.transcript()


async def _all_paths(
    posts: bytes,
    cuts: list[int],
    acks: list[str],
    ack_cuts: list[int],
    paths: Mapping[str, DataPath | None] | None = None,
) -> None:
    results: dict[str, Transcript] = {}
    for name, path in (datapaths() if paths is None else paths).items():
        with pytest.MonkeyPatch.context() as mp, fixed_clock_and_ids(mp) as now:
            run = await start(path, now)
            try:
                results[name] = await _script(run, posts, cuts, acks, ack_cuts)
            finally:
                mp.undo()  # the real clock again: the shutdown's bounds are timed by it
                await run.server.stop()
    reference = results.pop("reference")
    for name, got in results.items():
        assert got.written == reference.written, f"{name}: other bytes written"
        assert got.closed == reference.closed, f"{name}: other connections closed"
        assert got.history == reference.history, f"{name}: other history stored"
        assert got.counters == reference.counters, f"{name}: other counters"


@settings(
    max_examples=25,
    deadline=None,
    # No shrinking: an example takes ~0.1 s, and shrinking a failure took minutes; the failing
    # example is printed as generated.
    phases=[Phase.explicit, Phase.reuse, Phase.generate],
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(
    frames=st.lists(st.integers(0, 10_000), min_size=1, max_size=14).flatmap(
        lambda ns: st.tuples(*[_post(i) for i in range(len(ns))])
    ),
    tail=st.sampled_from([b"", b"", b"Bogus\0\0\0\0\0\0\0"]),
    cuts=st.lists(st.integers(0, 4000), max_size=12),
    acks=st.lists(_ACKS, min_size=1, max_size=6),
    ack_cuts=st.lists(st.integers(0, 2000), max_size=6),
)
def test_generated_traffic_gives_identical_output_and_state(
    frames: tuple[bytes, ...], tail: bytes, cuts: list[int], acks: list[str], ack_cuts: list[int]
) -> None:
    asyncio.run(_all_paths(b"".join(frames) + tail, cuts, acks, ack_cuts))


def test_reads_of_one_byte_give_identical_output_and_state() -> None:
    """Partial reads at every byte: each post arrives one byte per read."""
    posts = b"".join(
        request(t, "P", "WB1", f"q{i}", "x &amp; y")
        for i, t in enumerate(["Test.A", "Late.B", "Other", "Test.C"])
    )
    cuts = list(range(1, len(posts)))
    paths = datapaths()
    asyncio.run(_all_paths(posts, cuts, ["canonical", "declared"], list(range(1, 400)), paths))
    for name, path in paths.items():
        if path is not None:  # the comparison was not vacuous: the data path did the work
            assert isinstance(path, PurePath)
            assert path.requests >= 6 and path.acks >= 1, name


def test_the_comparison_can_fail() -> None:
    """A data path that drops a frame is caught: the harness compares what it claims to."""

    class Dropping:
        name = "dropping"
        find_marker = None

        def feed(self, conn: object, data: bytes, received_ns: int) -> bytes:
            return data[len(data) // 2 :]

    posts = request("Test.A", "P", "WB1", "q1") + request("Test.B", "P", "WB1", "q2")
    paths: dict[str, DataPath | None] = {"reference": None, "dropping": Dropping()}
    with pytest.raises(AssertionError, match="dropping: other bytes written"):
        asyncio.run(_all_paths(posts, [], ["canonical"], [], paths))
