"""Sessions 08-09: KEEPALIVE and the callback connection, and the spec's walkthrough."""

from __future__ import annotations

from tools.sessionvectors.common import (
    ACCEPT,
    Session,
    jmsg,
    made_id,
    post,
)
from tools.sessionvectors.s06_s07 import raw


def s08_keepalive_callback() -> Session:
    s = Session(
        "08-keepalive-callback",
        "Client KEEPALIVE (empty from and to); a module bound with BIND_NOLISTEN gets its wakeups "
        "over the Receive callback connection, answering any PING the server sends first.",
        "psyclone-wire/06-keepalive.txt (part C), 08-callback-fallback.txt (parts B and C)",
    )
    s.request(
        "K",
        jmsg("KEEPALIVE", "44c91fff-e23d-47a5-8d39-94a239859a03", "", "", t=(1795328622, 734)),
        "JavaOpenAIR KEEPALIVE after 60 s idle",
        ["OA-KEEP-2", "OA-SESS-1"],
        type="KEEPALIVESUCCESS",
    )
    s.request(
        "M1",
        raw("BIND_NOLISTEN", made_id("08/nolisten"), "RawMod", "CNS", (1795329509, 624)),
        "BIND_NOLISTEN (frame of part B with the type of part C)",
        ["OA-SESS-5"],
        type="BIND_ACCEPT",
        content_regex="^-1$",
        **{"from": "CNS"},
    )
    s.send(
        "M2",
        raw(
            "RECEIVE_NAME_NOTIFICATION",
            "828c9ba5-a89e-4f97-975f-6fff971a25bf",
            "RawMod",
            "",
            (1795329509, 639),
        ),
        "Receive callback",
        tag="Receive",
        requirements=["OA-SESS-7"],
    )
    s.request(
        "M1",
        raw("PING", made_id("08/sync"), "RawMod", "CNS", (1795329509, 640)),
        "PING (the Receive frame has no reply)",
        ["OA-SESS-10"],
        type="PING_SUCCESS",
    )
    s.request(
        "M3",
        raw(
            "AIR.Subscribe",
            "5a8dbc6a-c860-464d-86e4-50116c6410ad",
            "RawMod",
            "AIRCentral",
            (1795329509, 645),
            '<triggers><trigger from="WB1" type="Raw.Wake.*"/></triggers>',
            "xml",
        ),
        "subscribe Raw.Wake.*",
        ["OA-REG-7"],
        type=ACCEPT,
    )
    for i, (id_, t) in enumerate(
        (
            ("cba95fd5-76d1-464d-a6a3-8a69eee73a9d", (1795329511, 663)),
            (made_id("08/wake2"), (1795329515, 690)),
        ),
        start=1,
    ):
        n = post(s, "C8", "RawPoster", "WB1", f"Raw.Wake.{i}", id_, t, f"wake {i}")
        s.wakeup(
            "RawMod",
            ["OA-DELIV-1", "OA-SESS-5", "OA-DELIV-4"],
            trigger=f"$msg-of-step-{n}",
            type=f"Raw.Wake.{i}",
            lasttrigger="Raw.Wake.*",
            path="callback",
            **{"from": "WB1"},
        )
    s.request(
        "M1",
        raw("KEEPALIVE", made_id("08/keepalive"), "", "", (1795329570, 0)),
        "KEEPALIVE on the primary connection",
        ["OA-KEEP-2", "OA-SESS-1"],
        type="KEEPALIVESUCCESS",
    )
    return s


def spec_msg(
    type_: str,
    id_: str,
    frm: str,
    to: str,
    t: tuple[int, int],
    content: str = "",
    lang: str = "",
    extra: str = "",
) -> str:
    """A message in the canonical form of spec 3.5, as appendix B writes it."""
    return (
        f'<message priority="2.0"><type>{type_}</type><id>{id_}</id><from>{frm}</from><to>{to}</to>'
        f"<cc></cc><stored></stored><isresponse></isresponse>"
        f'<postedTime sec="{t[0]}" msec="{t[1]}"/><content language="{lang}">{content}</content>'
        f"{extra}</message>"
    )


def s09_walkthrough() -> Session:
    s = Session(
        "09-walkthrough",
        "The complete session of spec appendix B: Reader binds declaring extensions, asks for "
        "capabilities, registers a trigger with a retrieve, is woken by Poster, retrieves, exits.",
        "spec/openair-1.0.md appendix B",
    )
    s.request(
        "C1",
        spec_msg(
            "BIND",
            "id-1",
            "Reader",
            "CNS",
            (1795328337, 877),
            extra="<extensions>pipelining usec</extensions>",
        ),
        "step 1 BIND declaring extensions",
        ["OA-SESS-3", "OA-SESS-19"],
        type="BIND_ACCEPT",
        content_regex="^[0-9]+$",
        **{"from": "CNS", "to": "Reader"},
    )
    s.send(
        "C2",
        spec_msg("RECEIVE_NAME_NOTIFICATION", "id-3", "Reader", "", (1795328337, 908)),
        "step 3 Receive callback",
        tag="Receive",
        requirements=["OA-SESS-7"],
    )
    s.request(
        "C1",
        spec_msg("GET_CAPABILITIES", "id-4", "Reader", "CNS", (1795328338, 0)),
        "step 4 GET_CAPABILITIES",
        ["OA-SESS-23", "OA-CAP-1", "OA-LIM-4"],
        type="CAPABILITIES",
        content_root="capabilities",
        content_regex='.*protocol="OpenAIR/1.0".*name="max-frame-xml".*',
    )
    reg = (
        '<module name="Reader"><triggers from="WB1"><trigger type="Test.Ping.*"/></triggers>'
        '<retrieves><retrieve from="WB1" type="Test.Data.*"><latest>2</latest></retrieve>'
        "</retrieves></module>"
    )
    s.request(
        "C1",
        spec_msg("AIR.Subscribe", "id-5", "Reader", "AIRCentral", (1795328370, 845), reg, "xml"),
        "step 5 registration, form 2",
        ["OA-REG-3", "OA-REG-5", "OA-REG-7"],
        type=ACCEPT,
        **{"from": "AIRCentral"},
    )
    for id_, type_, text, t in (
        ("id-b", "Test.Data.1", "one", (1795328370, 940)),
        ("id-a", "Test.Data.2", "two", (1795328370, 990)),
    ):
        s.request(
            "C3",
            spec_msg(type_, id_, "Poster", "WB1", t, text),
            f"post {type_}",
            ["OA-SESS-16", "OA-WB-3"],
            type=ACCEPT,
            **{"from": "WB1"},
        )
    n, _ = s.request(
        "C3",
        spec_msg("Test.Ping.A", "id-7", "Poster", "WB1", (1795328371, 396), "hello ping"),
        "step 7 post",
        ["OA-WB-3", "OA-SESS-1"],
        type=ACCEPT,
        **{"from": "WB1"},
    )
    s.wakeup(
        "Reader",
        ["OA-WAKE-1", "OA-WAKE-2", "OA-WAKE-3", "OA-WAKE-4", "OA-WAKE-7"],
        trigger=f"$msg-of-step-{n}",
        type="Test.Ping.A",
        lasttrigger="Test.Ping.*",
        retrieved=["Test.Data.2", "Test.Data.1"],
        **{"from": "WB1"},
    )
    s.request(
        "C1",
        spec_msg(
            "AIR.Retrieve",
            "id-11",
            "Reader",
            "AIRCentral",
            (1795328375, 361),
            '<retrieve from="WB1" type="Test.*"/>',
            "xml",
        ),
        "step 11 retrieve (latest defaults to 1)",
        ["OA-RET-4", "OA-RET-6", "OA-RET-7"],
        type="AIR.Retrieve.Success",
        results=[["Test.Ping.A", "hello ping"]],
    )
    s.request(
        "C1",
        spec_msg("KEEPALIVE", "id-12", "", "", (1795328435, 361)),
        "step 12 KEEPALIVE",
        ["OA-KEEP-2"],
        type="KEEPALIVESUCCESS",
    )
    s.add({"conn": "C1", "close": True, "origin": "step 12 Reader exits"})
    s.add({"conn": "C2", "expect_closed": True, "requirements": ["OA-SESS-15"]})
    s.request(
        "C3",
        spec_msg(
            "AIR.Retrieve",
            "id-13",
            "Poster",
            "AIRCentral",
            (1795328436, 0),
            '<retrieve type="Psyclone.Module.Lost.Reader"/>',
            "xml",
        ),
        "the server posted Lost to AIRCentral",
        ["OA-SESS-15"],
        type="AIR.Retrieve.Success",
        results=[["Psyclone.Module.Lost.Reader", None]],
    )
    return s
