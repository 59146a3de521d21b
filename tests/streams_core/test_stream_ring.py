"""Untyped streams (spec 11.1-11.5): ids, timestamps, ring limits, lookups, search, refusal."""

from __future__ import annotations

import pytest

from openair.protocol.datasample import DataSample, decode_chunk, encode_chunk
from openair.protocol.errors import ApiMisuseError, ContentInvalidError, SampleInvalidError
from openair.server.core.config import StreamConfig
from openair.server.core.streams import Stream
from openair.server.core.streamspec import StoredSample, StreamSpec

MS = 1_000_000  # ns per ms


def ring(hardsize: int = 1_000_000, hardcount: int = 0) -> Stream:
    return Stream(StreamSpec(name="S", whiteboard="WB1", hardsize=hardsize, hardcount=hardcount))


def sample(payload: bytes = b"x", ts: int | str | None = None, **params: str) -> DataSample:
    pairs = [(k.replace("_", ":"), v) for k, v in params.items()]
    if ts is not None:
        pairs.append(("builtin:timestamp", str(ts)))
    return DataSample(payload=payload, params=tuple(pairs))


def put(stream: Stream, *samples: DataSample, at_ms: int = 0) -> tuple[StoredSample, ...]:
    return stream.add(list(samples), writer="w", received_ns=at_ms * MS).stored


def ids(found: list[StoredSample] | tuple[StoredSample, ...]) -> list[int]:
    return [s.id for s in found]


def held(stream: Stream) -> list[int]:
    return ids(stream.between(-(2**62), 2**62))


# -- ids, timestamps, params (OA-STREAM-4) -----------------------------------------------------


def test_ids_start_at_one_and_ignore_the_writers() -> None:
    s = ring()
    first = put(s, sample(builtin_id="99"), sample(builtin_id="abc"))
    second = put(s, sample(builtin_id="1"))
    assert ids(first) == [1, 2] and ids(second) == [3]
    assert [st.sample.id for st in first + second] == [1, 2, 3]
    assert s.added_total == 3 and s.count == 3 and s.size == 3


def test_builtin_params_replaced_in_place_or_appended() -> None:
    s = ring()
    (a,) = put(s, sample(camera="left", builtin_id="7", user="u"), at_ms=5)
    assert a.sample.params == (
        ("camera", "left"),
        ("builtin:id", "1"),
        ("user", "u"),
        ("builtin:timestamp", "5"),
    )
    (b,) = put(s, DataSample(payload=b"", params=(("builtin:timestamp", "9"), ("k", "v"))))
    assert b.sample.params == (("builtin:timestamp", "9"), ("k", "v"), ("builtin:id", "2"))


@pytest.mark.parametrize(
    ("given", "expected"),
    [
        ("1700000000123", 1700000000123),
        ("0", 0),
        ("-1", 42),
        ("1.5", 42),
        ("x", 42),
        ("", 42),
        (str(2**63), 42),
        (None, 42),
    ],
)
def test_timestamp_from_writer_or_receive_time(given: str | None, expected: int) -> None:
    s = ring()
    (st,) = put(s, sample(ts=given), at_ms=42)
    assert st.timestamp_ms == expected and st.sample.timestamp_ms == expected
    assert st.received_ns == 42 * MS


def test_spec_example_is_stored_as_the_spec_says() -> None:
    """Spec 11.2: the writer's sample, added as id 42 without a timestamp, is held as in 11.6."""
    s = ring()
    for _ in range(41):
        put(s, sample())
    example = DataSample(payload=b"\x01\x02\x03\x04", params=(("builtin:seq", "7"),))
    received_ns = 1795328400 * 10**9 + 120 * MS + 999_999
    (st,) = s.add([example], writer="Mic", received_ns=received_ns).stored
    assert st.id == 42 and st.timestamp_ms == 1795328400120
    assert st.parts[2] == (
        b"builtin:seq%equals%7%sep%builtin:id%equals%42%sep%builtin:timestamp%equals%1795328400120\0"
    )
    assert len(st.chunk()) == 97


def test_stored_chunk_is_joined_once_and_shared() -> None:
    s = ring()
    decoded = decode_chunk(encode_chunk(DataSample(payload=b"frame", params=(("k", "v"),))))
    (st,) = put(s, decoded, at_ms=3)
    assert st.size == 5
    # The chunk is joined once when stored; payload and parts are views into it, so readers
    # and subscribers are all sent the same bytes object without another copy.
    assert st.chunk() is st.wire and st.chunk() is st.chunk()
    assert isinstance(st.sample.payload, memoryview) and st.sample.payload.obj is st.wire
    assert st.parts[1] is st.sample.payload
    assert bytes(st.sample.payload) == bytes(decoded.payload) == b"frame"
    assert st.chunk() == encode_chunk(st.sample) == b"".join(st.parts)
    assert decode_chunk(st.chunk()) == st.sample


def test_empty_add_changes_nothing() -> None:
    s = ring()
    result = s.add([], writer="w", received_ns=0)
    assert result.stored == () and result.dropped == 0 and s.count == 0
    assert s.last_add_ns is None and not s.writers
    assert ids(put(s, sample())) == [1]


# -- limits (OA-STREAM-9, OA-STREAM-13) ----------------------------------------------------------


def test_ring_drops_oldest_by_size() -> None:
    s = ring(hardsize=100)
    for _ in range(3):
        assert s.add([sample(b"a" * 30)], writer="w", received_ns=0).dropped == 0
    result = s.add([sample(b"b" * 30)], writer="w", received_ns=0)
    assert result.dropped == 1 and result.alarms == ()
    assert held(s) == [2, 3, 4] and s.size == 90 and s.dropped_total == 1
    result = s.add([sample(b"c" * 100)], writer="w", received_ns=0)
    assert result.dropped == 3 and held(s) == [5] and s.size == 100


def test_ring_drops_oldest_by_count() -> None:
    s = ring(hardcount=2)
    result = s.add([sample(), sample(), sample()], writer="w", received_ns=0)
    # All three were added (and get ids); the first was dropped again at once.
    assert ids(result.stored) == [1, 2, 3] and result.dropped == 1
    assert held(s) == [2, 3] and s.count == 2
    assert s.by_id(1) is None and s.oldest() is not None and s.oldest().id == 2  # type: ignore[union-attr]


def test_oversized_sample_refuses_the_whole_add() -> None:
    s = ring(hardsize=10)
    put(s, sample(b"0123456789"))
    with pytest.raises(SampleInvalidError) as info:
        s.add([sample(b"ok"), sample(b"01234567890")], writer="other", received_ns=7 * MS)
    assert "sample 2 of 2" in info.value.detail and "10 bytes" in info.value.detail
    # Nothing changed: not the samples, the ids, the counters, the writers nor the time.
    assert held(s) == [1] and s.size == 10 and s.added_total == 1
    assert s.writers == {"w"} and s.last_add_ns == 0
    assert ids(put(s, sample(b"ok"))) == [2]


def test_from_config_untyped() -> None:
    cfg = StreamConfig(name="V", maxsize=0.5, maxcount=7, attributes=(("type", "A.B"),))
    spec = StreamSpec.from_config(cfg, "WB2", typed_streams=False)
    assert spec == StreamSpec(name="V", whiteboard="WB2", hardsize=524288, hardcount=7)
    assert not spec.typed and spec.alarm_whiteboard == "WB2"
    plain = StreamSpec.from_config(StreamConfig(name="P"), "WB1", typed_streams=True)
    assert not plain.typed and plain.hardsize == 10 * 1048576 and plain.hardcount == 0
    tiny = StreamSpec.from_config(StreamConfig(name="T", maxsize=1e-7), "WB1", typed_streams=True)
    assert tiny.hardsize == 0  # rounded down


@pytest.mark.parametrize(
    "cfg",
    [
        StreamConfig(name="S", maxsize=-1.0),
        StreamConfig(name="S", maxsize=float("nan")),
        StreamConfig(name="S", maxsize=float("inf")),
        StreamConfig(name="S", maxcount=-1),
    ],
)
def test_from_config_bad_core_values(cfg: StreamConfig) -> None:
    with pytest.raises(ContentInvalidError, match="'S'"):
        StreamSpec.from_config(cfg, "WB1", typed_streams=False)


def test_spec_refuses_inconsistent_limits() -> None:
    with pytest.raises(ApiMisuseError):
        StreamSpec(name="S", whiteboard="W", hardsize=-1)
    with pytest.raises(ApiMisuseError):
        StreamSpec(name="S", whiteboard="W", type="T", hardsize=10, softsize=11)


def test_untyped_info() -> None:
    s = ring(hardsize=2048, hardcount=5)
    assert s.info() == {
        "name": "S", "whiteboard": "WB1", "count": "0", "size": "0", "maxsize": "2048",
        "maxcount": "5", "writers": "0", "locked": "0",
    }  # fmt: skip
    put(s, sample(b"abc"), sample(b"de"))
    s.add([sample()], writer="v", received_ns=0)
    info = s.info()
    assert (info["count"], info["size"], info["oldest"], info["newest"]) == ("3", "6", "1", "3")
    assert info["writers"] == "2" and s.writers == {"w", "v"}


def test_untyped_never_alarms() -> None:
    s = ring(hardcount=1)
    for seq in (1, 5, 2):
        assert s.add([sample(builtin_seq=str(seq))], writer="w", received_ns=0).alarms == ()
    assert s.idle_due_ns() is None and s.tick(10**18) is None


# -- lookups (OA-STREAM-6, OA-STREAM-7) -----------------------------------------------------------


def timed(*stamps: int) -> Stream:
    s = ring()
    for ts in stamps:
        put(s, sample(ts=ts))
    return s


def test_empty_lookups() -> None:
    s = ring()
    assert s.newest() is None and s.oldest() is None and s.by_id(1) is None
    assert s.at_or_before(10**15) is None and s.between(0, 10**15) == []
    assert s.first_at_or_after(0) is None and s.last_at_or_after(0) is None
    assert s.first_after_id(0) is None and s.last_after_id(0) is None
    assert s.search() == []


@pytest.mark.parametrize("ident", [0, -1, 6, 10**9])
def test_by_id_absent(ident: int) -> None:
    assert timed(1, 2, 3, 4, 5).by_id(ident) is None


def test_by_id_after_drops() -> None:
    s = ring(hardcount=3)
    for _ in range(10):
        put(s, sample())
    assert [s.by_id(i) is not None for i in range(6, 12)] == [False, False, True, True, True, False]
    assert s.by_id(9).id == 9  # type: ignore[union-attr]


def test_time_lookups_with_ties() -> None:
    s = timed(10, 20, 20, 20, 30)
    assert s.at_or_before(20).id == 4  # type: ignore[union-attr]  # ties: the newest
    assert s.at_or_before(25).id == 4  # type: ignore[union-attr]
    assert s.at_or_before(9) is None and s.at_or_before(10).id == 1  # type: ignore[union-attr]
    assert ids(s.between(20, 20)) == [2, 3, 4] and ids(s.between(11, 30)) == [2, 3, 4, 5]
    assert s.between(21, 29) == [] and s.between(30, 10) == []
    assert s.first_at_or_after(20).id == 2  # type: ignore[union-attr]
    assert s.first_at_or_after(31) is None
    assert s.last_at_or_after(20).id == 5  # type: ignore[union-attr]
    assert s.last_at_or_after(31) is None


def test_time_lookups_out_of_order() -> None:
    s = timed(30, 10, 20, 10, 5)
    assert s.at_or_before(10).id == 4  # type: ignore[union-attr]  # greatest <= 10, newest tie
    assert s.at_or_before(29).id == 3  # type: ignore[union-attr]
    assert s.at_or_before(4) is None
    assert ids(s.between(10, 20)) == [2, 3, 4]  # oldest (by id) first
    assert s.first_at_or_after(15).id == 1  # type: ignore[union-attr]
    assert s.last_at_or_after(15).id == 3  # type: ignore[union-attr]
    assert s.last_at_or_after(31) is None and s.first_at_or_after(31) is None


def test_order_recovers_when_out_of_order_samples_age_out() -> None:
    s = ring(hardcount=3)
    for ts in (50, 10, 20, 30, 40):
        put(s, sample(ts=ts))
    assert held(s) == [3, 4, 5]
    assert s.at_or_before(35).id == 4  # type: ignore[union-attr]
    assert ids(s.between(20, 40)) == [3, 4, 5]


def test_id_lookups_for_waits() -> None:
    s = ring(hardcount=4)
    for _ in range(6):
        put(s, sample())
    assert held(s) == [3, 4, 5, 6]
    assert s.first_after_id(0).id == 3  # type: ignore[union-attr]
    assert s.first_after_id(4).id == 5  # type: ignore[union-attr]
    assert s.first_after_id(6) is None and s.last_after_id(6) is None
    assert s.last_after_id(1).id == 6  # type: ignore[union-attr]
    assert s.newest().id == 6 and s.oldest().id == 3  # type: ignore[union-attr]


# -- search (OA-XSTREAM-9; usable on any stream) ---------------------------------------------------


def test_search() -> None:
    s = ring()
    put(s, sample(ts=10, camera="left", kind="a?b"))
    put(s, sample(ts=20, camera="right"))
    put(s, sample(ts=30, camera="left-2", kind="axb"))
    put(s, sample(ts=40))
    assert ids(s.search()) == [1, 2, 3, 4]
    assert ids(s.search(after_ms=20, until_ms=30)) == [2, 3]
    assert ids(s.search(params=[("camera", "left*")])) == [1, 3]
    assert ids(s.search(params=[("camera", "*")])) == [1, 2, 3]  # a missing param never matches
    assert ids(s.search(params=[("kind", "a?b")])) == [1]  # `?` is literal (OA-RET-8)
    assert ids(s.search(params=[("camera", "LEFT*")])) == []  # case-sensitive
    assert ids(s.search(params=[("camera", "left*"), ("kind", "a*")], latest=1)) == [3]
    assert ids(s.search(latest=2)) == [3, 4] and ids(s.search(latest=9)) == [1, 2, 3, 4]
    assert ids(s.search(params=[("builtin:id", "2")])) == [2]
    put(s, DataSample(payload=b"", params=(("tag", "a"), ("tag", "b"))))
    assert ids(s.search(params=[("tag", "b")])) == [5]  # any parameter of the key may match
    assert s.search(after_ms=41) == [] and s.search(after_ms=30, until_ms=20) == []


def test_search_out_of_order() -> None:
    s = timed(30, 10, 20, 10)
    assert ids(s.search(after_ms=10, until_ms=20)) == [2, 3, 4]
    assert ids(s.search(until_ms=15, latest=1)) == [4]
    assert ids(s.search(after_ms=25)) == [1]
