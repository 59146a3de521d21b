"""psySpec configuration: valid files, refused files with their line, the default (spec 12)."""

from __future__ import annotations

from pathlib import Path

import pytest

from openair.protocol.content import DEFAULT_CONTEXT, RegistrationForm
from openair.server.core.config import (
    AIRCENTRAL,
    ConfigError,
    ServerLimits,
    default_config,
    load_config,
    parse_config,
)

DEMO = """\
<psySpec name="Demo" version="1.2">
  <global>
    <title>Demo system</title>
    <description>Two whiteboards and one module</description>
    <port>10000</port>
    <htmldir>html</htmldir>
    <satellites/>
  </global>
  <whiteboard name="WB1" maxcount="15000" priority="1.5">
    <description>Perception results</description>
    <streams>
      <stream name="Video" maxsize="10"/>
    </streams>
  </whiteboard>
  <whiteboard name="WB2"/>
  <module name="Reader" priority="2.0" allowselftriggering="yes">
    <description>Reads pings, writes pongs</description>
    <context name="Psyclone.System.Ready">
      <phase name="Main">
        <triggers from="WB1">
          <trigger type="Test.Ping.*" after="25"/>
        </triggers>
        <retrieves>
          <retrieve from="WB1" type="Test.Data.*"><latest>2</latest></retrieve>
        </retrieves>
      </phase>
    </context>
  </module>
  <catalog name="Cat"/>
</psySpec>
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "spec.xml"
    path.write_text(text, encoding="utf-8")
    return path


def test_demo_file_is_read(tmp_path: Path) -> None:
    config = load_config(_write(tmp_path, DEMO))
    assert config.name == "Demo"
    assert config.source.endswith("spec.xml")
    names = [wb.name for wb in config.whiteboards]
    assert names == [AIRCENTRAL, "WB1", "WB2"]  # OA-CONF-4: AIRCentral added
    wb1, wb2 = config.whiteboards[1], config.whiteboards[2]
    assert (wb1.maxcount, wb1.priority) == (15000, 1.5)
    assert (wb2.maxcount, wb2.priority) == (10000, 1.0)  # OA-CONF-2 defaults
    assert [s.name for s in wb1.streams] == ["Video"]
    assert config.port == 10000  # OA-CONF-7
    assert config.global_entry("title") == "Demo system"


def test_module_supplies_registration_and_xml(tmp_path: Path) -> None:
    module = load_config(_write(tmp_path, DEMO)).module("Reader")
    assert module is not None
    reg = module.registration
    assert reg.form is RegistrationForm.CONFIG
    assert reg.allow_self_triggering  # OA-REG-6
    phase = reg.active_phase
    assert phase is not None and phase.context == DEFAULT_CONTEXT and phase.name == "Main"
    assert [(t.pattern, t.after_ms) for t in reg.triggers] == [("Test.Ping.*", 25)]
    assert [r.pattern for r in reg.retrieves] == ["Test.Data.*"]
    assert module.spec_xml.startswith('<module name="Reader"')  # OA-SESS-12
    assert module.spec_xml.rstrip().endswith("</module>")


def test_unimplemented_elements_are_reported(tmp_path: Path) -> None:
    ignored = load_config(_write(tmp_path, DEMO)).ignored  # OA-CONF-6
    assert any("<catalog>" in item for item in ignored)
    assert any("<satellites>" in item for item in ignored)


def test_aircentral_declared_is_not_duplicated() -> None:
    text = '<psySpec name="X" version="1.2"><whiteboard name="AIRCentral" maxcount="5"/></psySpec>'
    config = parse_config(text.encode(), source="x.xml")
    assert [(wb.name, wb.maxcount) for wb in config.whiteboards] == [(AIRCENTRAL, 5)]


def test_default_config() -> None:
    config = default_config()  # OA-WB-1, spec 12.1
    assert [wb.name for wb in config.whiteboards] == [AIRCENTRAL, "WB1", "WB2"]
    assert all(wb.maxcount == 10000 and wb.priority == 1.0 for wb in config.whiteboards)
    assert config.modules == ()
    assert config.name == "Default built-in"
    assert config.global_entry("title") == "Psyclone Default"
    assert config.global_entry("description") == "Default built-in PsySpec"
    assert config.source == ""
    assert config.port is None


@pytest.mark.parametrize(
    ("text", "line", "words"),
    [
        # not well-formed: the mismatched tag is on line 3
        ('<psySpec name="X" version="1.2">\n<whiteboard name="A"/>\n<oops></psySpec>\n', 3, ""),
        # invalid against the XSD: maxcount must be a positive integer, on line 2
        ('<psySpec name="X" version="1.2">\n<whiteboard name="A" maxcount="-3"/>\n</psySpec>', 2,
         "maxcount"),
        # an unknown child of psySpec on line 4
        ('<psySpec name="X" version="1.2">\n<whiteboard name="A"/>\n\n<bogus/>\n</psySpec>', 4,
         "bogus"),
        # the wrong root
        ('\n<module name="M"/>', 2, "psySpec"),
        # a DOCTYPE is refused (OA-SEC-1), reported where it stands
        ('<?xml version="1.0"?>\n<!DOCTYPE psySpec []>\n<psySpec name="X" version="1.2"/>', 2,
         "XML_FORBIDDEN"),
        # duplicate names break the XSD key
        ('<psySpec name="X" version="1.2">\n<whiteboard name="A"/>\n<whiteboard name="A"/>\n'
         "</psySpec>", 3, ""),
        # a name CNS could not serve (OA-SESS-30)
        ('<psySpec name="X" version="1.2">\n<whiteboard name="CNS"/>\n</psySpec>', 2, "CNS"),
        # an invalid trigger pattern (the XSD already refuses it, on its line)
        ('<psySpec name="X" version="1.2">\n<module name="M">\n<trigger type="A..B"/>\n'
         "</module>\n</psySpec>", 3, "A..B"),
    ],
)  # fmt: skip
def test_invalid_config_names_file_and_line(
    tmp_path: Path, text: str, line: int, words: str
) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError) as caught:
        load_config(path)  # OA-CONF-3
    message = str(caught.value)
    assert message.startswith(f"{path}:{line}: "), message
    assert words in message


def test_registration_refusal_is_a_config_error() -> None:
    text = (
        '<psySpec name="X" version="1.2">\n<whiteboard name="A"/>\n<module name="M">'
        '<trigger type="A"/><trigger type="B"/></module>\n</psySpec>'
    )
    with pytest.raises(ConfigError) as caught:
        parse_config(text.encode(), source="x.xml", max_triggers=1)  # OA-LIM-6
    assert str(caught.value).startswith("x.xml:3: module 'M': LIMIT_EXCEEDED")


def test_missing_file_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "absent.xml")


def test_limits_advertised_in_table_order() -> None:
    limits = ServerLimits(max_queue=7)
    names = [name for name, _ in limits.advertised()]
    assert names == [
        "max-frame-xml",
        "max-frame-binary",
        "max-xml-depth",
        "max-in-flight",
        "max-queue",
        "delivery-retries",
        "retry-deadline-ms",
        "ack-deadline-ms",
        "max-triggers",
        "max-type-bytes",
        "max-type-segments",
        "frame-deadline-ms",
        "max-queue-bytes",
        "max-wakeup-results",
        "max-wakeup-result-bytes",
        "max-history-bytes",
        "max-connections",
        "max-connections-per-peer",
        "max-partial-bytes",
        "frame-total-deadline-ms",
        "max-held-bytes",
        "module-retention-ms",
        "stream-push-buffer-bytes",
        "max-created-streams",
        "max-created-stream-bytes",
    ]  # OA-LIM-4
    assert dict(limits.advertised())["max-queue"] == 7
    assert limits.frame_limits().max_xml == 16 * 1024 * 1024
    assert limits.xml_limits().max_depth == 64
    with pytest.raises(ValueError):
        ServerLimits(max_in_flight=0)
