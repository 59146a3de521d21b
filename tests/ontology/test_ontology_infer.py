"""`openair ontology infer` against a running reference server and its SQLite store.

A server runs in-process (127.0.0.1, port 0); modules post with the Python client; the inferred
ontology must hold every posted type with its count, posters, whiteboards and an example. The
same history read back through `--history HOST:PORT` feeds the linter.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from ontology_helpers import ONTOLOGY, PSYSPEC

from openair.cli import main
from openair.client.blocking import BlockingModule
from openair.server.core.config import load_config
from openair_ontology.history import HistoryError, load_history, read_sqlite
from openair_ontology.model import Kind, TypeIndex
from openair_ontology.parse import read_ontology

SENTENCE = "Input.Perc.UniM.Hear.Voice.Speak.Sentence"
MOUSE = "Skundar.Input.Sens.MouseMotion"
SAID = '<dictionary><entry name="text">come here</entry></dictionary>'


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """A server with the example psySpec and a SQLite store, after a few posts."""
    from ontology_helpers import ServerThread

    store = tmp_path_factory.mktemp("store") / "history.db"
    srv = ServerThread(config=load_config(PSYSPEC), store=f"sqlite:{store}")
    try:
        with BlockingModule("SpeechRecognizer", port=srv.port, bind=False, keepalive=None) as m:
            m.post("PerceptionWB", SENTENCE, SAID, content_is_xml=True)
        with BlockingModule("MouseOdometry", port=srv.port, bind=False, keepalive=None) as m:
            for dx in ("1", "2", "3"):
                m.post("PerceptionWB", MOUSE, dx)
        with BlockingModule("Stray", port=srv.port, bind=False, keepalive=None) as m:
            m.post("DecisionWB", MOUSE, "4")
            m.post("DecisionWB", "Unknown.Thing", "?")
        yield srv, store
    finally:
        srv.stop()


def _infer(tmp_path: Path, *args: str) -> TypeIndex:
    out = tmp_path / "inferred.xml"
    result = CliRunner().invoke(main, ["ontology", "infer", *args, "-o", str(out)])
    assert result.exit_code == 0, result.output
    return TypeIndex(read_ontology(out))


def _check(index: TypeIndex) -> None:
    mouse = index.get(MOUSE)
    assert mouse is not None and mouse.kind is Kind.MESSAGE
    assert mouse.node.observed is not None and mouse.node.observed.count == 4
    assert set(mouse.node.observed.whiteboards) == {"PerceptionWB", "DecisionWB"}
    assert [(p.module, p.whiteboard) for p in mouse.node.posters] == [
        ("MouseOdometry", "PerceptionWB"),  # the most frequent poster first
        ("Stray", "DecisionWB"),
    ]
    assert mouse.node.observed.first <= mouse.node.observed.last
    sentence = index.get(SENTENCE)
    assert sentence is not None and sentence.node.observed is not None
    assert sentence.node.observed.count == 1
    assert sentence.node.content is not None and sentence.node.content.root == "dictionary"
    assert "come here" in sentence.node.examples[0].content
    group = index.get("Input.Perc")
    assert group is not None and group.kind is Kind.GROUP
    assert index.get("Unknown.Thing") is not None


def test_infer_from_a_live_server(recorded: Any, tmp_path: Path) -> None:
    srv, _ = recorded
    _check(_infer(tmp_path, "--from", f"127.0.0.1:{srv.port}"))


def test_infer_from_the_sqlite_store(recorded: Any, tmp_path: Path) -> None:
    _, store = recorded
    _check(_infer(tmp_path, "--from-store", f"sqlite:{store}"))


def test_lint_reads_the_live_history(recorded: Any) -> None:
    srv, _ = recorded
    result = CliRunner().invoke(
        main,
        [
            "ontology",
            "lint",
            str(ONTOLOGY),
            "--psyspec",
            str(PSYSPEC),
            "--history",
            f"127.0.0.1:{srv.port}",
        ],
    )
    assert result.exit_code == 1
    assert "undefined-type: type 'Unknown.Thing' is posted by Stray to DecisionWB" in (
        result.output
    )


def test_live_history_names_whiteboards_from_status(recorded: Any) -> None:
    srv, _ = recorded
    history = load_history(f"127.0.0.1:{srv.port}")
    boards = {m.stored for m in history.messages}
    assert {"PerceptionWB", "DecisionWB"} <= boards
    times = [m.received for m in history.messages if m.received is not None]
    assert times == sorted(times)  # oldest first


def test_infer_needs_exactly_one_source(tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["ontology", "infer", "-o", str(tmp_path / "x.xml")])
    assert result.exit_code == 2
    assert "exactly one" in result.output
    result = CliRunner().invoke(
        main, ["ontology", "infer", "--from-store", "memory", "-o", str(tmp_path / "x.xml")]
    )
    assert result.exit_code == 2


def test_infer_exit_3_when_the_server_is_unreachable(unused_port: int, tmp_path: Path) -> None:
    result = CliRunner().invoke(
        main, ["ontology", "infer", "--from", f"127.0.0.1:{unused_port}", "-o", str(tmp_path / "x")]
    )
    assert result.exit_code == 3


def test_sqlite_file_that_is_no_store(tmp_path: Path) -> None:
    other = tmp_path / "other.db"
    other.write_bytes(b"not a database at all" * 100)
    with pytest.raises(HistoryError, match="sqlite"):
        read_sqlite(str(other))
