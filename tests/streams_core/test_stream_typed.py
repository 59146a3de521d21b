"""Typed streams (spec 11.7, STREAMS.md 3): soft/hard limits with locks, alarms, idle, config."""

from __future__ import annotations

import pytest

from openair.protocol.datasample import DataSample
from openair.protocol.errors import ContentInvalidError, SampleInvalidError
from openair.server.core.config import StreamConfig
from openair.server.core.streams import Stream
from openair.server.core.streamspec import AddResult, Alarm, StreamSpec

MS = 1_000_000  # ns per ms
T0 = 1_700_000_000_000  # ms since the epoch


def typed(**limits: int | str) -> Stream:
    base: dict[str, int | str] = {"hardsize": 1_000_000, "hardcount": 0}
    base.update(limits)
    return Stream(StreamSpec(name="Cam", whiteboard="WB1", type="Video.Raw", **base))  # type: ignore[arg-type]


def put(
    s: Stream, payload: bytes = b"x", *, at_ms: int = T0, writer: str = "w", **params: str
) -> AddResult:
    sample = DataSample(
        payload=payload, params=tuple((k.replace("_", ":"), v) for k, v in params.items())
    )
    return s.add([sample], writer=writer, received_ns=at_ms * MS)


def kinds(result: AddResult) -> list[str]:
    return [a.kind for a in result.alarms]


def held(s: Stream) -> list[int]:
    return [st.id for st in s.between(0, 2**62)]


def entries(alarm: Alarm) -> dict[str, str]:
    return dict(alarm.entries)


# -- Started, Idle (OA-XSTREAM-7) -----------------------------------------------------------------


def test_started_then_idle_then_started_again() -> None:
    s = typed(idle_ms=500)
    assert s.idle_due_ns() is None and s.tick(T0 * MS) is None  # no sample yet
    first = put(s, at_ms=T0)
    assert kinds(first) == ["Started"]
    started = first.alarms[0]
    assert started.type == "AIR.Stream.Alarm.Started" and started.whiteboard == "WB1"
    assert started.entries == (("stream", "Cam"), ("streamtype", "Video.Raw"), ("time", str(T0)))
    assert kinds(put(s, at_ms=T0 + 100)) == []
    due = s.idle_due_ns()
    assert due == (T0 + 600) * MS
    assert s.tick(due - 1) is None
    idle = s.tick(due)
    assert idle is not None and idle.kind == "Idle" and idle.type == "AIR.Stream.Alarm.Idle"
    assert entries(idle) == {
        "stream": "Cam",
        "streamtype": "Video.Raw",
        "time": str(T0 + 600),
        "idle": "500",
    }
    assert s.tick(due + 10**12) is None and s.idle_due_ns() is None  # once per idle period
    again = put(s, at_ms=T0 + 5000)
    assert kinds(again) == ["Started"] and entries(again.alarms[0])["time"] == str(T0 + 5000)
    assert s.idle_due_ns() == (T0 + 5500) * MS


def test_idle_zero_means_never() -> None:
    s = typed(idle_ms=0)
    put(s)
    assert s.idle_due_ns() is None and s.tick(10**19) is None


def test_tick_late_posts_once() -> None:
    s = typed(idle_ms=100)
    put(s, at_ms=T0)
    alarm = s.tick((T0 + 10_000) * MS)
    assert alarm is not None and entries(alarm)["time"] == str(T0 + 10_000)
    assert s.tick((T0 + 20_000) * MS) is None


def test_alarms_whiteboard() -> None:
    s = Stream(StreamSpec(name="A", whiteboard="WB1", type="T", hardsize=10, alarms="Alarms"))
    assert put(s).alarms[0].whiteboard == "Alarms"


# -- soft limits and the SoftLimit transition rule (OA-XSTREAM-2) ---------------------------


def test_soft_count_drops_oldest_and_alarms_once_per_crossing() -> None:
    s = typed(softcount=3, hardcount=10)
    for _ in range(3):
        put(s)
    crossing = put(s)
    assert kinds(crossing) == ["SoftLimit"] and crossing.dropped == 1
    assert entries(crossing.alarms[0]) == {
        "stream": "Cam", "streamtype": "Video.Raw", "time": str(T0),
        "size": "3", "count": "3", "dropped": "1",
    }  # fmt: skip
    for _ in range(5):  # a steady full ring posts it once, not per sample
        result = put(s)
        assert kinds(result) == [] and result.dropped == 1
    assert held(s) == [7, 8, 9] and s.dropped_total == 6


def test_soft_limit_alarms_again_after_an_add_that_did_not_drop() -> None:
    s = typed(softsize=100, hardsize=1000)
    assert kinds(put(s, b"a" * 60)) == ["Started"]
    assert kinds(put(s, b"b" * 60)) == ["SoftLimit"]
    assert kinds(put(s, b"c" * 60)) == []  # still dropping: no new alarm
    assert kinds(put(s, b"")) == []  # 60 bytes held: nothing dropped
    alarm = put(s, b"d" * 60)
    assert kinds(alarm) == ["SoftLimit"]
    assert entries(alarm.alarms[0])["size"] == "60" and held(s) == [4, 5]  # 4 is empty


def test_soft_limit_default_is_the_hard_limit() -> None:
    s = typed(hardcount=2)
    put(s)
    put(s)
    result = put(s)
    assert kinds(result) == ["SoftLimit"] and result.dropped == 1 and held(s) == [2, 3]


def test_soft_skips_locked_samples() -> None:
    s = typed(softcount=3, hardcount=10)
    for _ in range(3):
        put(s)
    lock = s.lock(1, 2, owner=7)
    assert s.locked == 2 and s.is_locked(1) and s.is_locked(2) and not s.is_locked(3)
    result = put(s)
    assert result.dropped == 1 and held(s) == [1, 2, 4]  # 3 went, behind the locked ones
    assert s.by_id(3) is None and s.by_id(4).id == 4  # type: ignore[union-attr]
    assert [st.id for st in s.between(0, 2**62)] == [1, 2, 4]
    assert s.first_after_id(2).id == 4  # type: ignore[union-attr]
    assert s.unlock(lock, owner=7)
    put(s)
    assert held(s) == [2, 4, 5] and s.locked == 0


def test_soft_never_drops_the_newest_sample() -> None:
    s = typed(softcount=2, hardcount=4)
    put(s)
    put(s)
    s.lock(1, 2, owner=1)
    result = put(s)  # above the soft limit, but only the new sample is unlocked
    assert result.dropped == 0 and kinds(result) == [] and held(s) == [1, 2, 3]
    result = put(s)
    assert result.dropped == 1 and kinds(result) == ["SoftLimit"] and held(s) == [1, 2, 4]


# -- hard limits (OA-XSTREAM-3, OA-XSTREAM-4) -----------------------------------------------------


def test_hard_limit_drops_locked_samples() -> None:
    s = typed(softcount=2, hardcount=4)
    for _ in range(4):
        put(s)  # soft drops down to 2 each time after the second
    assert held(s) == [3, 4]
    s.lock(3, 4, owner=1)
    assert put(s).dropped == 0  # only the newest is unlocked
    s.lock(5, 5, owner=1)
    assert put(s).dropped == 0
    assert held(s) == [3, 4, 5, 6] and s.locked == 3
    s.lock(6, 6, owner=2)
    result = put(s)
    assert kinds(result) == ["HardLimit"] and result.dropped == 1
    assert entries(result.alarms[0])["dropped"] == "1"
    assert held(s) == [4, 5, 6, 7] and s.locked == 3 and s.count == 4


def test_hard_size_limit_and_refusal() -> None:
    s = typed(softsize=10, hardsize=20)
    put(s, b"a" * 10)
    s.lock(1, 1, owner=1)
    assert put(s, b"b" * 10).dropped == 0  # 20 bytes: above soft, at hard
    result = put(s, b"c" * 15)  # soft drops 2, hard then drops the locked 1
    assert kinds(result) == ["SoftLimit", "HardLimit"] and held(s) == [3] and s.size == 15
    assert [entries(a)["dropped"] for a in result.alarms] == ["1", "1"]
    assert put(s, b"d" * 20).dropped == 1
    with pytest.raises(SampleInvalidError):
        put(s, b"e" * 21)


def test_alarm_order_gap_then_hard_limit() -> None:
    s = typed(softcount=1, hardcount=1)
    put(s, builtin_seq="1")
    s.lock(1, 1, owner=1)
    result = put(s, builtin_seq="3")
    assert kinds(result) == ["Gap", "HardLimit"] and result.dropped == 1


def test_batch_soft_limit_then_steady() -> None:
    s = typed(softcount=1, hardcount=5)
    batch = [DataSample(params=(("builtin:seq", "1"),)), DataSample(params=(("builtin:seq", "2"),))]
    assert kinds(s.add(batch, writer="w", received_ns=0)) == ["Started", "SoftLimit"]
    assert kinds(put(s, builtin_seq="3")) == []  # still dropping: no second SoftLimit


def test_first_add_orders_started_gap_soft() -> None:
    s = typed(softcount=1, hardcount=5)
    batch = [DataSample(params=(("builtin:seq", "1"),)), DataSample(params=(("builtin:seq", "3"),))]
    result = s.add(batch, writer="w", received_ns=0)
    assert kinds(result) == ["Started", "Gap", "SoftLimit"]


# -- locks (OA-XSTREAM-5) --------------------------------------------------------------------------


def test_lock_ids_ranges_and_owners() -> None:
    s = typed(hardcount=100)
    for _ in range(5):
        put(s)
    a = s.lock(2, 3, owner=1)
    b = s.lock(4, 99, owner=1)  # only held samples: 4 and 5
    c = s.lock(50, 60, owner=2)  # an empty range still gets an id
    d = s.lock(3, 2, owner=2)
    assert [a, b, c, d] == [1, 2, 3, 4] and s.locked == 4
    put(s)
    assert not s.is_locked(6) and s.locked == 4  # later samples are not locked
    assert not s.unlock(a, owner=2) and s.is_locked(2)  # another owner's lock
    assert not s.unlock(99, owner=1)
    assert s.unlock(a, owner=1) and not s.unlock(a, owner=1)
    assert s.locked == 2 and s.info()["locked"] == "2"
    assert s.release(owner=1) == 1 and s.locked == 0
    assert s.release(owner=1) == 0 and s.release(owner=2) == 2
    assert s.lock(1, 1, owner=3) == 5  # ids stay unique


def test_overlapping_locks_count_once() -> None:
    s = typed(hardcount=100)
    for _ in range(6):
        put(s)
    s.lock(1, 4, owner=1)
    s.lock(3, 5, owner=2)
    s.lock(2, 2, owner=3)
    assert s.locked == 5
    s.release(owner=1)
    assert s.locked == 4


def test_release_on_owner_lets_soft_drop_again() -> None:
    s = typed(softcount=2, hardcount=10)
    put(s)
    put(s)
    s.lock(1, 2, owner=9)
    put(s)
    put(s)
    assert held(s) == [1, 2, 4]
    assert s.release(owner=9) == 1
    put(s)
    assert held(s) == [4, 5]


# -- Gap (OA-XSTREAM-8) ----------------------------------------------------------------------------


def test_gap_per_writer() -> None:
    s = typed(hardcount=100)
    assert kinds(put(s, writer="A", builtin_seq="1")) == ["Started"]
    assert kinds(put(s, writer="A", builtin_seq="2")) == []
    assert kinds(put(s, writer="B", builtin_seq="7")) == []  # B's first: no gap
    gap = put(s, writer="A", builtin_seq="4", at_ms=T0 + 3)
    assert kinds(gap) == ["Gap"] and gap.stored[0].id == 4  # the sample is still added
    assert entries(gap.alarms[0]) == {
        "stream": "Cam", "streamtype": "Video.Raw", "time": str(T0 + 3),
        "writer": "A", "expected": "3", "received": "4",
    }  # fmt: skip
    assert kinds(put(s, writer="A")) == []  # no seq: ignored
    assert kinds(put(s, writer="A", builtin_seq="five")) == []
    assert kinds(put(s, writer="A", builtin_seq="5")) == []
    assert kinds(put(s, writer="B", builtin_seq="8")) == []
    repeat = put(s, writer="A", builtin_seq="5")
    assert (
        entries(repeat.alarms[0])["expected"] == "6"
        and entries(repeat.alarms[0])["received"] == "5"
    )
    assert s.writers == {"A", "B"}


def test_gap_inside_a_batch() -> None:
    s = typed(hardcount=100)
    batch = [DataSample(params=(("builtin:seq", str(n)),)) for n in (1, 2, 4, 5, 9)]
    result = s.add(batch, writer="conn:3", received_ns=0)
    gaps = [entries(a) for a in result.alarms if a.kind == "Gap"]
    assert [(g["expected"], g["received"]) for g in gaps] == [("3", "4"), ("6", "9")]


# -- configuration (OA-XSTREAM-1, STREAMS.md 3) ----------------------------------------------------


def cfg(**attrs: str) -> StreamConfig:
    return StreamConfig(name="V", maxsize=2.0, maxcount=50, attributes=tuple(attrs.items()))


def test_from_config_typed_defaults() -> None:
    spec = StreamSpec.from_config(cfg(type="Video.Raw"), "WB3", typed_streams=True)
    assert spec.typed and spec.type == "Video.Raw"
    assert (spec.hardsize, spec.hardcount, spec.softsize, spec.softcount) == (
        2097152,
        50,
        None,
        None,
    )
    assert (spec.soft_size, spec.soft_count, spec.idle_ms, spec.alarm_whiteboard) == (
        2097152,
        50,
        5000,
        "WB3",
    )


def test_from_config_typed_attributes() -> None:
    spec = StreamSpec.from_config(
        cfg(
            type="A.B",
            softsize="100",
            softcount="5",
            hardsize="200",
            hardcount="10",
            idle="0",
            alarms="AL",
        ),
        "WB1",
        typed_streams=True,
    )
    assert (spec.softsize, spec.softcount, spec.hardsize, spec.hardcount) == (100, 5, 200, 10)
    assert spec.idle_ms == 0 and spec.alarm_whiteboard == "AL"
    info = Stream(spec).info()
    keys = ("type", "maxsize", "maxcount", "softsize", "softcount", "hardsize", "hardcount", "idle")
    assert [info[k] for k in keys] == ["A.B", "2097152", "50", "100", "5", "200", "10", "0"]


def test_from_config_alarms_whiteboard_must_exist() -> None:
    known = {"WB1", "AL"}
    spec = StreamSpec.from_config(
        cfg(type="T", alarms="AL"), "WB1", typed_streams=True, whiteboards=known
    )
    assert spec.alarm_whiteboard == "AL"
    with pytest.raises(ContentInvalidError, match="alarms"):
        StreamSpec.from_config(
            cfg(type="T", alarms="Nope"), "WB1", typed_streams=True, whiteboards=known
        )
    # Without the list (or on an untyped stream) the caller checks.
    assert (
        StreamSpec.from_config(cfg(type="T", alarms="Nope"), "WB1", typed_streams=True).alarms
        == "Nope"
    )
    assert not StreamSpec.from_config(
        cfg(alarms="Nope"), "WB1", typed_streams=True, whiteboards=known
    ).typed


def test_from_config_softcount_without_hardcount() -> None:
    spec = StreamSpec.from_config(
        StreamConfig(name="V", attributes=(("type", "T"), ("softcount", "5"))),
        "W",
        typed_streams=True,
    )
    assert spec.hardcount == 0 and spec.soft_count == 5


@pytest.mark.parametrize(
    "attrs",
    [
        {"type": ""},
        {"type": "A..B"},
        {"type": "A.*"},
        {"type": "A", "softsize": "x"},
        {"type": "A", "softsize": "0"},
        {"type": "A", "hardsize": "0"},
        {"type": "A", "hardsize": " "},
        {"type": "A", "hardsize": "-1"},
        {"type": "A", "hardcount": "1.5"},
        {"type": "A", "idle": "1e3"},
        {"type": "A", "idle": "٣"},
        {"type": "A", "softcount": "99999999999999999999"},
        {"type": "A", "softsize": "300", "hardsize": "200"},
        {"type": "A", "softsize": "2097153"},
        {"type": "A", "softcount": "51"},
        {"type": "A", "softcount": "3", "hardcount": "2"},
    ],
)
def test_from_config_bad_typed_values(attrs: dict[str, str]) -> None:
    with pytest.raises(ContentInvalidError) as info:
        StreamSpec.from_config(cfg(**attrs), "WB1", typed_streams=True)
    assert "'V'" in info.value.detail
