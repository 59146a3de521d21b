"""Record a running system and replay it (docs/recording.md).

`Recorder` captures every routed message and stream sample into a recording file
(`fileformat`: framed binary records with an index); `RecordingReader` reads one back, record by
record; `plan` and `Replayer` re-post it with the original spacing; `messages_of` gives its
messages to the ontology tools (`openair_ontology.history.history_of_recording`: the ontology
uses the recording, not the other way round).
"""

from __future__ import annotations

from openair_recording.fileformat import (
    Header,
    MessageRecord,
    Record,
    RecordingReader,
    RecordingWriter,
    SampleRecord,
    read_index,
)
from openair_recording.recorder import Recorder, RecordOptions
from openair_recording.replay import Replayer, ReplayOptions, Step, plan

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
    "messages_of",
    "plan",
    "read_index",
]


def messages_of(path: str) -> tuple[tuple[MessageRecord, ...], RecordingReader]:
    """Read every message record of a recording (raises the reader's errors)."""
    reader = RecordingReader.open(path)
    found = tuple(r for r in reader.records() if isinstance(r, MessageRecord))
    return found, reader
