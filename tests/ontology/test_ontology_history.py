"""History sources and what the usage model reads from a psySpec and a history."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest
from ontology_helpers import HISTORY, ONTOLOGY, PSYSPEC

from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.server.aio.stores import SqliteStore
from openair.server.core.config import load_config
from openair_ontology.history import HistoryError, load_history, read_sqlite, read_xml
from openair_ontology.lint import lint
from openair_ontology.model import TypeIndex
from openair_ontology.parse import read_ontology
from openair_ontology.usage import Source, usage_from_config, usage_from_history


def test_example_history_reads_oldest_first() -> None:
    history = read_xml(HISTORY)
    assert len(history.messages) == 33
    times = [m.received for m in history.messages]
    assert times == sorted(t for t in times if t is not None)
    assert history.messages[0].type == "Psyclone.Context:Psyclone.System.Ready"


@pytest.mark.parametrize(
    ("content", "problem"),
    [
        (b'<!DOCTYPE x [<!ENTITY e "y">]><objectcollection/>', "XML_FORBIDDEN"),
        (b"<objectcollection><object>", "XML_MALFORMED"),
        (b"<objectcollection><object><dictionary/></object></objectcollection>", "not a message"),
        (b"<messages/>", "objectcollection"),
    ],
)
def test_bad_history_files_are_refused(tmp_path: Path, content: bytes, problem: str) -> None:
    path = tmp_path / "history.xml"
    path.write_bytes(content)
    with pytest.raises(HistoryError, match=problem):
        read_xml(path)


@pytest.mark.parametrize(
    ("spec", "problem"),
    [
        ("nohistory", "cannot read"),
        ("somewhere/history.xml", "cannot read"),
        ("host:notaport", "not a file, sqlite:PATH or HOST:PORT"),
        ("sqlite:", "no such file"),
    ],
)
def test_history_sources_are_told_apart(spec: str, problem: str) -> None:
    with pytest.raises(HistoryError, match=problem):
        load_history(spec)


def _stored(type_: str, wbid: int, sender: str = "M") -> Message:
    return Message(
        type=type_, sender=sender, to="WB1", stored="WB1", wbid=wbid, content=f"#{wbid}",
        received=AirTime(sec=1_800_000_000 + wbid),
    )  # fmt: skip


def test_sqlite_store_is_read_and_damaged_rows_skipped(tmp_path: Path) -> None:
    path = tmp_path / "store.db"
    store = SqliteStore(path)
    for wbid in (1, 2, 3):
        store.append("WB1", _stored("Test.Ping", wbid))
    store.close()
    with sqlite3.connect(path) as db:
        db.execute("UPDATE messages SET xml = ? WHERE wbid = 2", (b"<broken",))
    history = read_sqlite(str(path))
    assert [m.content for m in history.messages] == ["#1", "#3"]
    assert history.notes == ("1 stored rows did not decode and were skipped",)
    assert load_history(f"sqlite:{path}").messages == history.messages


def test_history_usage_counts_posters_and_keeps_the_latest_example() -> None:
    msgs = [_stored("A.B", 1, "X"), _stored("a.b", 2, "Y"), _stored("A.B", 3, "Y")]
    usage = usage_from_history(msgs)
    (obs,) = usage.observations
    assert (obs.type, obs.count) == ("A.B", 3)  # ASCII case ignored (OA-MATCH-1)
    assert obs.posters == (("Y", "WB1", 2), ("X", "WB1", 1))
    assert obs.first == AirTime(sec=1_800_000_001) and obs.last == AirTime(sec=1_800_000_003)
    assert obs.example is not None and obs.example.content == "#3"
    assert {(p.module, p.count, p.source) for p in usage.postings} == {
        ("Y", 2, Source.HISTORY),
        ("X", 1, Source.HISTORY),
    }


def test_invalid_history_types_are_counted_and_reported() -> None:
    usage = usage_from_history([_stored("Test.Ping.", 1), _stored("Test.Ping.", 2)])
    assert usage.observations == () and usage.invalid_types == (("Test.Ping.", 2),)
    findings = lint(TypeIndex(read_ontology(ONTOLOGY)), usage)
    invalid = [f for f in findings if f.code == "invalid-type"]
    assert len(invalid) == 1 and "2 message(s)" in invalid[0].message


def test_psyspec_usage_reads_posts_triggers_and_streams() -> None:
    usage = usage_from_config(load_config(PSYSPEC))
    assert ("Navigator", "Skundar.Decision.Cmd2dMove", "DecisionWB") in {
        (p.module, p.type, p.whiteboard) for p in usage.postings
    }
    retrieve = next(s for s in usage.subscriptions if s.kind == "retrieve")
    assert (retrieve.module, retrieve.pattern) == ("DialogManager", "Input.Perc.UniM.Vis.Face.*")
    camera = next(s for s in usage.streams if s.name == "Camera")
    assert camera.type == "Input.Video.Perception"
    assert camera.readers == ("FaceTracker", "Tracker") and camera.writers == ()
    board = next(w for w in usage.whiteboards if w.name == "MotorWB")
    assert board.description == "Motor commands, scheduled first"
