"""Record a running system and replay it (docs/recording.md).

`Recorder` captures every routed message and stream sample into a recording file
(`fileformat`: framed binary records with an index); `RecordingReader` reads one back, record by
record; `plan` and `Replayer` re-post it with the original spacing; `history_from_recording`
gives its messages to the ontology tools.
"""

from __future__ import annotations

from openair.errors import OpenAIRError
from openair.ontology.history import History, HistoryError
from openair.recording.fileformat import (
    Header,
    MessageRecord,
    Record,
    RecordingReader,
    RecordingWriter,
    SampleRecord,
    read_index,
)
from openair.recording.recorder import Recorder, RecordOptions
from openair.recording.replay import Replayer, ReplayOptions, Step, plan

__all__ = [
    "Header",
    "MessageRecord",
    "Record",
    "RecordOptions",
    "Recorder",
    "RecordingReader",
    "RecordingWriter",
    "ReplayOptions",
    "Replayer",
    "SampleRecord",
    "Step",
    "history_of",
    "messages_of",
    "plan",
    "read_index",
]


def messages_of(path: str) -> tuple[tuple[MessageRecord, ...], RecordingReader]:
    """Read every message record of a recording (raises the reader's errors)."""
    reader = RecordingReader.open(path)
    found = tuple(r for r in reader.records() if isinstance(r, MessageRecord))
    return found, reader


def history_of(path: str) -> History:
    """Return a recording's messages as an ontology history (oldest first); raise HistoryError."""
    try:
        records, reader = messages_of(path)
    except OSError as exc:
        raise HistoryError(f"recording {path}: cannot read: {exc.strerror}") from None
    except OpenAIRError as exc:
        raise HistoryError(f"recording {path}: not a readable recording: {exc}") from None
    ordered = sorted(records, key=lambda r: r.time_us)  # stable: file order within a time
    return History(
        source=path, messages=tuple(r.message for r in ordered), notes=tuple(reader.warnings)
    )
