"""Replica convergence (OA-WM-6): any order and duplication of reports gives the same state."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from openair_worldmodel import Context, Packet, Ref, WorldModelCore
from openair_worldmodel.wire import Report, ReportObject, encode_report

_values = st.one_of(
    st.floats(-10, 10, allow_nan=False), st.sampled_from(["a", "b"]), st.just(Ref(name="X"))
)
_packets = st.builds(
    Packet,
    value=_values,
    accuracy=st.sampled_from([0.0, 0.5]),
    confidence=st.sampled_from([0.5, 1.0]),
    timestamp=st.integers(0, 4),  # few timestamps: ties are common
    source=st.sampled_from(["A", "B"]),
    seq=st.integers(0, 3),  # even clashing (source, seq) pairs must converge
)
_reports = st.builds(
    lambda source, items: Report(
        robot="R1",
        source=source,
        objects=tuple(
            ReportObject(
                name=obj,
                class_name="Thing",
                context=Context.SURROUNDINGS,
                packets=((attr, packet),),
            )
            for obj, attr, packet in items
        ),
    ),
    st.sampled_from(["A", "B"]),
    st.lists(
        st.tuples(st.sampled_from(["O1", "O2"]), st.sampled_from(["p", "q"]), _packets),
        min_size=1,
        max_size=3,
        unique_by=lambda t: (t[0], t[1]),
    ),
)


def _replica(reports: list[Report]) -> object:
    core = WorldModelCore(robot="R1", module="Replica", whiteboard="WB1")
    for report in reports:
        core.receive("WM.Report", encode_report(report))
    return core.blackboard.snapshot()


@settings(max_examples=150)
@given(st.lists(_reports, min_size=1, max_size=6), st.data())
def test_permuted_and_duplicated_reports_converge(
    reports: list[Report], data: st.DataObject
) -> None:
    shuffled = data.draw(st.permutations(reports))
    extra = data.draw(st.lists(st.sampled_from(reports), max_size=4))
    assert _replica(list(shuffled) + extra) == _replica(reports)


@given(st.lists(_packets, min_size=1, max_size=8))
def test_the_replica_keeps_the_greatest_packet(packets: list[Packet]) -> None:
    core = WorldModelCore(robot="R1", module="Replica", whiteboard="WB1")
    core.blackboard.create("O")
    for packet in packets:
        core.blackboard.put("O", "p", packet, local=False)
    assert core.blackboard.stored("O", "p") == max(packets, key=Packet.key)


def test_an_older_local_write_loses_on_clock_skew() -> None:
    core = WorldModelCore(robot="R1", module="Slow", whiteboard="WB1")
    core.blackboard.create("O")
    fast = Packet(value=1.0, timestamp=2_000, source="Fast", seq=1)
    assert core.blackboard.put("O", "p", fast, local=False)
    assert not core.blackboard.write("O", "p", 2.0, timestamp=1_000)  # a clock behind
    assert core.blackboard.stored("O", "p") == fast
