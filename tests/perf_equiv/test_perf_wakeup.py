"""The spliced wakeup is the lxml-built one: same Message, same bytes, for hostile contents too."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from perf_strategies import messages, safe_text

from openair.protocol.codec import encode_with_lxml
from openair.protocol.content import Phase, RetrieveSpec, Trigger
from openair.protocol.errors import ApiMisuseError
from openair.protocol.message import Message
from openair.protocol.times import AirTime
from openair.protocol.wakeup import (
    EncodedCopies,
    assemble_wakeup,
    build_wakeup,
    collection_xml,
    frame_bytes,
    phase_spec_xml,
)
from openair.server.core.whiteboard import derive

_patterns = st.sampled_from(["A.*", "Bench.Flow.*", "*", "x.y", "a<b&c"])
_triggers = st.builds(
    Trigger,
    pattern=st.sampled_from(["A.*", "Bench.Flow.*", "*", "x.y"]),
    whiteboard=st.sampled_from(["", "WB1", "any"]),
    after_ms=st.integers(0, 5000),
)
phases = st.none() | st.builds(
    Phase,
    name=safe_text,
    context=st.sampled_from(["Psyclone.System.Ready", "Other"]),
    triggers=st.lists(_triggers, max_size=3).map(tuple),
    retrieves=st.lists(
        st.builds(RetrieveSpec, pattern=st.sampled_from(["A.*", ""]), latest=st.integers(0, 3)),
        max_size=2,
    ).map(tuple),
    priority=st.floats(0.0, 6.999),
)
_wb_names = st.sampled_from(["WB1", "AIRCentral", "wb<&>\"'"])
_module_names = st.one_of(st.sampled_from(["BenchSub0", "M"]), safe_text.filter(bool))


def _usable(msg: Message) -> bool:
    try:
        encode_with_lxml(msg)
    except ApiMisuseError:
        return False
    return True


@settings(max_examples=200)
@given(
    stored=messages(writable=True).filter(_usable),
    retrieved=st.lists(messages(plain=True).filter(_usable), max_size=3),
    phase=phases,
    whiteboard=_wb_names,
    module=_module_names,
    lasttrigger=st.one_of(st.just(""), _patterns),
    sec=st.integers(0, 2**40),
)
def test_assembled_wakeup_equals_the_lxml_wakeup(
    stored: Message,
    retrieved: list[Message],
    phase: Phase | None,
    whiteboard: str,
    module: str,
    lasttrigger: str,
    sec: int,
) -> None:
    posted = AirTime(sec=sec, msec=sec % 1000)
    try:
        reference = build_wakeup(
            stored=stored,
            whiteboard=whiteboard,
            module=module,
            retrieved=retrieved,
            phase=phase or Phase(),
            lasttrigger=lasttrigger,
        )
    except ApiMisuseError:
        return  # nothing to compare: the router never builds such a wakeup
    expected = derive(reference, posted=posted, id="fixed-id")
    copies = EncodedCopies(size=2)
    for _ in range(2):  # the second round reads the cache
        msg, wire = assemble_wakeup(
            trigger_xml=copies.xml(stored),
            retrieved_xml=collection_xml(retrieved, copies),
            phase_xml=phase_spec_xml(phase, module=module, lasttrigger=lasttrigger),
            whiteboard=whiteboard,
            module=module,
            id="fixed-id",
            posted=posted,
        )
        assert msg == expected
        assert wire is not None
        assert wire == frame_bytes(encode_with_lxml(expected))
