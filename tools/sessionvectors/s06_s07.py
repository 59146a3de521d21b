"""Sessions 06-07: posts to oneself and to many, and the error cases (psyclone-wire/06-07)."""

from __future__ import annotations

from tools.sessionvectors.common import (
    ACCEPT,
    EMPTY,
    Session,
    java_bind,
    jmsg,
    made_id,
    post,
    retrieve,
    xml_content,
)


def raw(
    type_: str,
    id_: str,
    frm: str,
    to: str,
    t: tuple[int, int],
    content: str = "",
    lang: str = "",
    cc: str = "",
) -> str:
    """A frame as the raw Python client of the transcripts writes it (JavaOpenAIR layout)."""
    return jmsg(type_, id_, frm, to, t=t, content=content, lang=lang, cc=cc, prio="2.0")


def s06_self_and_multi() -> Session:
    s = Session(
        "06-self-and-multi",
        "Two matching triggers, trigger plus cc, self-posting with and without "
        "allowselftriggering, self cc, lastmsec against receivedTime, takeover by a second BIND.",
        "psyclone-wire/11-misc.txt (frames rebuilt from its summary lines)",
    )
    java_bind(s, "M1", "M2", "RawMod", (made_id("06/bind"), made_id("06/recv")), 1795330200)
    two = (
        '<triggers><trigger from="WB1" type="Multi.*"/><trigger from="WB1" type="Multi.Ping.*"/>'
        "</triggers>"
    )
    s.request(
        "M4",
        raw(
            "AIR.Subscribe",
            made_id("06/sub1"),
            "RawMod",
            "AIRCentral",
            (1795330200, 600),
            two,
            "xml",
        ),
        "subscribe two overlapping triggers",
        ["OA-REG-7"],
        type=ACCEPT,
    )
    plan = [
        ("Multi.Ping.A", "RawPoster", "", "Multi.*", ["OA-WAKE-5", "OA-WAKE-6"]),
        ("Multi.Ping.B", "RawPoster", "RawMod", "Multi.*", ["OA-WAKE-5", "OA-WAKE-6"]),
        ("Multi.Self.1", "RawMod", "", None, ["OA-TRIG-4"]),
    ]
    for i, (type_, frm, cc, last, reqs) in enumerate(plan):
        n = post(
            s, "C3", frm, "WB1", type_, made_id(f"06/{type_}"), (1795330203, 10 * i), "c", cc=cc
        )
        if last is not None:
            s.wakeup(
                "RawMod",
                reqs,
                trigger=f"$msg-of-step-{n}",
                type=type_,
                lasttrigger=last,
                **{"from": "WB1"},
            )
    selfreg = (
        '<module name="RawMod" allowselftriggering="yes"><trigger from="WB1" type="Multi.*"/>'
        "</module>"
    )
    s.request(
        "M7",
        raw(
            "AIR.Subscribe",
            made_id("06/sub2"),
            "RawMod",
            "AIRCentral",
            (1795330210, 106),
            selfreg,
            "xml",
        ),
        "re-register with allowselftriggering",
        ["OA-REG-1", "OA-REG-6"],
        type=ACCEPT,
    )
    n = post(s, "C3", "RawMod", "WB1", "Multi.Self.2", made_id("06/self2"), (1795330212, 624), "c")
    s.wakeup(
        "RawMod",
        ["OA-REG-6", "OA-TRIG-4"],
        trigger=f"$msg-of-step-{n}",
        type="Multi.Self.2",
        lasttrigger="Multi.*",
        **{"from": "WB1"},
    )
    n = post(
        s,
        "C3",
        "RawMod",
        "WB1",
        "Other.Self.3",
        made_id("06/self3"),
        (1795330215, 129),
        "c",
        cc="RawMod",
    )
    s.wakeup(
        "RawMod",
        ["OA-CC-4"],
        trigger=f"$msg-of-step-{n}",
        type="Other.Self.3",
        lasttrigger="",
        **{"from": "WB1"},
    )
    post(s, "C3", "RawPoster", "WB1", "Time.Old", made_id("06/old"), (1795326636, 633), "c")
    post(s, "C3", "RawPoster", "WB1", "Time.New", made_id("06/new"), (1795330236, 637), "c")
    for i, (spec, want, reqs) in enumerate(
        [
            (
                '<retrieve from="WB1" type="Time.*"><lastmsec>5000</lastmsec></retrieve>',
                ["Time.New"],
                ["OA-RET-5", "OA-RET-4"],
            ),
            (
                '<retrieve from="WB1" type="Time.*"><latest>0</latest></retrieve>',
                ["Time.New", "Time.Old"],
                ["OA-RET-6"],
            ),
        ]
    ):
        s.request(
            "C8",
            raw(
                "AIR.Retrieve",
                made_id(f"06/ret{i}"),
                "RawMod",
                "AIRCentral",
                (1795330237, i),
                spec,
                "xml",
            ),
            f"AIR.Retrieve {spec}",
            reqs,
            type="AIR.Retrieve.Success",
            results=[[t, "c"] for t in want],
        )
    s.request(
        "M10",
        raw("BIND", made_id("06/bind2"), "RawMod", "CNS", (1795330237, 860)),
        "a second BIND for the bound name RawMod",
        ["OA-SESS-6", "OA-SESS-3"],
        type="BIND_ACCEPT",
        content_regex="^[0-9]+$",
    )
    s.add({"conn": "M1", "expect_closed": True, "requirements": ["OA-SESS-6"]})
    s.add({"conn": "M2", "expect_closed": True, "requirements": ["OA-SESS-6"]})
    s.request(
        "C8",
        raw(
            "AIR.Retrieve",
            made_id("06/ret-restored"),
            "RawPoster",
            "AIRCentral",
            (1795330237, 900),
            '<retrieve from="AIRCentral" type="Psyclone.Module.*.RawMod">'
            "<latest>0</latest></retrieve>",
            "xml",
        ),
        "the takeover posted Restored (and no Lost)",
        ["OA-SESS-6"],
        type="AIR.Retrieve.Success",
        results=[["Psyclone.Module.Restored.RawMod", None]],
    )
    s.request(
        "M10",
        raw(
            "BIND",
            made_id("06/bind3"),
            "RawMod2",
            "CNS",
            (1795330237, 875),
            '<tcplocation port="10555"/>',
            "xml",
        ),
        "BIND asking for port 10555",
        ["OA-SESS-4"],
        type_in=["BIND_ACCEPT", "BIND_ERROR"],
        content_regex="^(10555|BIND_REFUSED(: .*)?)$",
    )
    return s


def hexframe(tag: bytes, body: bytes, *, length: bytes | None = None) -> str:
    """Hex of a frame header (tag padded to 7 bytes, NUL, length) and body."""
    size = length if length is not None else len(body).to_bytes(4, "little")
    return (tag.ljust(7, b"\0")[:7] + b"\0" + size + body).hex()


RAW_PING = raw("PING", "09162616-54cf-4e64-80bf-2fc0ea4830a3", "RawClient", "CNS", (1795329419, 75))


def s07_errors() -> Session:
    s = Session(
        "07-errors",
        "The raw-socket error probes E1-E20 and JavaOpenAIR's post, subscribe and retrieve to a "
        "whiteboard that does not exist, answered as the spec requires (Psyclone: DEV-16-DEV-21).",
        "psyclone-wire/07-errors.txt",
    )
    s.request(
        "E",
        raw("PING", "a01848d2-1587-4658-8bd6-6d55e86ebc78", "RawClient", "CNS", (1795329389, 879)),
        "E1 PING without BIND",
        ["OA-SESS-10", "OA-SESS-16"],
        type="PING_SUCCESS",
        content_regex=EMPTY,
    )
    s.request(
        "E",
        raw(
            "RESOLVE_REQUEST",
            "7b6fc015-4e41-4dca-b912-9933dbf00d3b",
            "RawClient",
            "CNS",
            (1795329389, 903),
            "NoSuchWB",
            "English",
        ),
        "E2 RESOLVE_REQUEST NoSuchWB",
        ["OA-SESS-8"],
        type="RESOLVE_FAILED",
    )
    s.request(
        "W",
        raw(
            "Raw.Test.Post",
            "7c7a619f-15eb-4dc1-8814-29d81241e719",
            "RawClient",
            "WB1",
            (1795329389, 909),
            "hello raw",
        ),
        "E3 post from a client that never bound",
        ["OA-SESS-16", "OA-WB-3"],
        type=ACCEPT,
        **{"from": "WB1"},
    )
    s.request(
        "E",
        raw(
            "Raw.Test.ViaCNS",
            "c1c63690-ca8b-423c-abfd-e2721bbbc60e",
            "RawClient",
            "WB1",
            (1795329389, 920),
            "via cns",
        ),
        "E4 post to=WB1 on the main connection",
        ["OA-SESS-26", "OA-WB-2"],
        type=ACCEPT,
        **{"from": "WB1"},
    )
    for conn, id_, type_ in (
        ("E", "b867985f-01ac-401c-bf99-5925717095ff", "Raw.Test.NoWB"),
        ("W", "9a1220be-cf1c-4584-8d6c-d98662ba9804", "Raw.Test.WrongTo"),
    ):
        s.request(
            conn,
            raw(type_, id_, "RawClient", "NoSuchWB", (1795329389, 924), "x"),
            f"E5/E6 {type_} to=NoSuchWB",
            ["OA-SESS-21"],
            type="FORWARD_FAILED",
            content_regex="^Could not forward message to: NoSuchWB$",
        )
    s.request(
        "W",
        raw(
            "Raw.Test.EmptyTo",
            "db7ef676-541f-40ad-85e3-a958c2f4cb9b",
            "RawClient",
            "",
            (1795329389, 960),
            "x",
        ),
        "E7 empty to: addressed to CNS, which does not know the type",
        ["OA-SESS-26", "OA-SESS-20"],
        type="UNKNOWN_COMMAND",
        content_regex="^Offending cmd: Raw.Test.EmptyTo$",
    )
    s.request(
        "W",
        raw("", "aae2e63a-9308-4f91-84d2-eaf0c5706598", "RawClient", "WB1", (1795329389, 968), "x"),
        "E8 empty type",
        ["OA-MSG-2", "OA-ERR-2", "OA-SESS-1"],
        type="RECEIVE_ERROR",
        content_regex="^MESSAGE_INVALID(: .*)?$",
    )
    s.send("W", "<message><type>Raw.Min</type></message>", "E9 minimal message, no id, no to")
    s.expect(
        "W",
        ["OA-SESS-1", "OA-SESS-26", "OA-SESS-20"],
        isresponse="",
        type="UNKNOWN_COMMAND",
        content_regex="^Offending cmd: Raw.Min$",
    )
    s.request(
        "E",
        raw(
            "FOO_BAR", "476240b6-0f13-49ff-b6a8-46e54072f812", "RawClient", "CNS", (1795329389, 983)
        ),
        "E10 unknown command to CNS",
        ["OA-SESS-20"],
        type="UNKNOWN_COMMAND",
        content_regex="^Offending cmd: FOO_BAR$",
    )
    s.send("W", "<message><type>Raw.Bad</type><to>WB1</to", "E11 malformed XML")
    s.expect(
        "W",
        ["OA-ERR-3", "OA-MSG-1", "OA-ERR-2"],
        isresponse="",
        type="RECEIVE_ERROR",
        content_regex="^XML_MALFORMED(: .*)?$",
    )
    s.request(
        "W",
        raw(
            "Raw.AfterBad",
            "95ce54ef-be93-49fc-80e0-2a059a617da8",
            "RawClient",
            "WB1",
            (1795329390, 5),
            "after bad",
        ),
        "E11b the connection is still usable",
        ["OA-ERR-3"],
        type=ACCEPT,
    )
    s.send("E12", "hello world", "E12 a Message frame whose body is not XML")
    s.expect(
        "E12",
        ["OA-ERR-3", "OA-MSG-1"],
        isresponse="",
        type="RECEIVE_ERROR",
        content_regex="^XML_MALFORMED(: .*)?$",
    )
    s.request("E12", RAW_PING, "the connection is still usable", ["OA-ERR-3"], type="PING_SUCCESS")
    s.add(
        {
            "conn": "E13",
            "send_raw_hex": hexframe(b"Garbage", b"hello"),
            "origin": "E13 unknown tag Garbage",
        }
    )
    s.add({"conn": "E13", "expect_closed": True, "requirements": ["OA-FRAME-6", "OA-FRAME-2"]})
    s.add(
        {
            "conn": "E19",
            "send_raw_hex": hexframe(b"message", RAW_PING.encode()),
            "origin": "E19 lower-case tag message",
        }
    )
    s.add({"conn": "E19", "expect_closed": True, "requirements": ["OA-FRAME-6", "OA-FRAME-2"]})
    s.add(
        {
            "conn": "E16",
            "send_raw_hex": RAW_PING.encode().hex(),
            "origin": "E16 bare <message> XML without a header",
        }
    )
    s.add({"conn": "E16", "expect_closed": True, "requirements": ["OA-FRAME-6"]})
    big_endian = len(RAW_PING.encode()).to_bytes(4, "big")
    s.add(
        {
            "conn": "E20",
            "send_raw_hex": hexframe(b"Message", RAW_PING.encode(), length=big_endian),
            "origin": "E20 length written big-endian (read as 570490880 bytes)",
        }
    )
    s.expect(
        "E20",
        ["OA-FRAME-7", "OA-LIM-1"],
        isresponse="",
        type="RECEIVE_ERROR",
        content_regex="^FRAME_TOO_LARGE(: .*)?$",
    )
    s.add({"conn": "E20", "expect_closed": True, "requirements": ["OA-FRAME-7"]})
    s.request(
        "E",
        raw("STATUS", "7d74a120-be64-441e-8987-64a7003d2aa7", "RawClient", "CNS", (1795329419, 66)),
        "E18 STATUS",
        ["OA-SESS-25"],
        type="STATUS_SUCCESS",
        dict_entries=["Name", "Created"],
    )
    s.request(
        "E",
        raw(
            "GET_ID",
            "3cd37500-0a4c-4804-b0ce-8621d7a3b081",
            "RawClient",
            "AIRServer",
            (1795329419, 73),
        ),
        "E18 GET_ID to AIRServer via CNS",
        ["OA-SESS-14", "OA-SESS-26"],
        type="ID",
        content_regex="^\\S+$",
    )
    s.request(
        "J",
        jmsg(
            "Test.Ping.A",
            "cd6d8f39-bea6-450f-b500-cebcdadc0844",
            "Poster",
            "NoSuchWB",
            t=(1795330152, 854),
            content="x",
            prio="2.0",
        ),
        "JavaOpenAIR postMessage(NoSuchWB)",
        ["OA-SESS-21"],
        type="FORWARD_FAILED",
        content_regex="^Could not forward message to: NoSuchWB$",
    )
    body = jmsg(
        "AIR.Subscribe",
        "15c50337-1a71-47eb-8909-948e9d30f02f",
        "Poster",
        "AIRCentral",
        t=(1795330152, 932),
        lang="xml",
        prio="2.0",
        content=xml_content(
            '<triggers>\n\t\t\t<trigger from="NoSuchWB" type="Test.Ping.*" />\n\t\t</triggers>'
        ),
    )
    s.request(
        "J",
        body,
        "JavaOpenAIR addTrigger(NoSuchWB, Test.Ping.*)",
        ["OA-REG-9"],
        type_in=[ACCEPT, "RECEIVE_ERROR"],
        content_regex="^(|WHITEBOARD_UNKNOWN(: .*)?)$",
    )
    retrieve(
        s,
        "J",
        "Poster",
        "799cc224-7996-4612-8e3b-a883a6a2c9db",
        (1795330152, 960),
        '<retrieve from="NoSuchWB" type="*"><latest>5</latest></retrieve>',
        ["OA-RET-11"],
        None,
        failed="WHITEBOARD_UNKNOWN",
    )
    return s
