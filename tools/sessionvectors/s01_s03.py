"""Sessions 01-03: connect and bind, subscribe/post/wakeup, cc (psyclone-wire/01-03)."""

from __future__ import annotations

from tools.sessionvectors.common import (
    ACCEPT,
    EMPTY,
    GLOBAL_ENTRIES,
    PERFSTAT,
    Session,
    java_bind,
    jmsg,
    made_id,
    post,
    resolve,
    retrieve,
    subscribe,
    xml_content,
)


def s01_connect_bind() -> Session:
    s = Session(
        "01-connect-bind",
        "Two JavaOpenAIR plugs start up (BIND, Receive callback, Config, CurrentPhase, Connect "
        "announce, PerfStat, PING, GET_ID, GET_NAME); Reader's JVM then exits.",
        "psyclone-wire/01-connect-bind.txt",
    )
    java_bind(
        s,
        "R1",
        "R2",
        "Reader",
        ("ddc32690-385c-49da-9f96-14aa5928de9e", "66285f8f-7767-41ff-b17a-cb6d755498db"),
        1795328337,
    )
    resolve(s, "R1", "Reader", "40e66a8f-37d0-4276-86f4-fc16cd426f41", (1795328337, 910), "Config")
    s.request(
        "R3",
        jmsg(
            "GET_ENTRY",
            "40e66a8f-37d0-4276-86f4-fc16cd426f41",
            "Reader",
            "Config",
            t=(1795328337, 910),
            content="Global",
        ),
        "GET_ENTRY Global (same id as the RESOLVE_REQUEST before it)",
        ["OA-SESS-12", "OA-MSG-8", "OA-SESS-26"],
        type="ENTRY",
        dict_entries=GLOBAL_ENTRIES,
    )
    s.request(
        "R3",
        jmsg(
            "GET_ENTRY",
            "06b72dda-3bc7-4b6a-a749-0460d8dbf0af",
            "Reader",
            "Config",
            t=(1795328337, 978),
            content="Reader",
        ),
        "GET_ENTRY Reader (not in the configuration)",
        ["OA-SESS-12"],
        type="ENTRY",
        content_regex=EMPTY,
    )
    resolve(s, "R1", "Reader", "fe0c58d8-3869-43f0-8a36-49f0fa9d5bc6", (1795328338, 26), "Psyclone")
    s.request(
        "R4",
        jmsg(
            "Psyclone.Module.Request.CurrentPhase",
            "fe0c58d8-3869-43f0-8a36-49f0fa9d5bc6",
            "Reader",
            "Psyclone",
            t=(1795328338, 26),
        ),
        "CurrentPhase for a module with no registration and no configuration",
        ["OA-SESS-13"],
        type="Psyclone.Module.CurrentPhase",
        content_regex=EMPTY,
    )
    resolve(
        s, "R1", "Reader", "dda7eadd-62a0-4e90-82a7-44bd19bddd1b", (1795328338, 71), "AIRCentral"
    )
    post(
        s,
        "R5",
        "Reader",
        "AIRCentral",
        "Psyclone.Module.Connect.Reader",
        "dda7eadd-62a0-4e90-82a7-44bd19bddd1b",
        (1795328338, 71),
        "",
    )
    java_bind(
        s,
        "P6",
        "P7",
        "Poster",
        ("45b185b9-0171-4084-81be-68ce07f52972", "e136b8b8-e0c7-47ef-88e5-86bdf6a9f87b"),
        1795328339,
    )
    post(
        s,
        "P10",
        "Poster",
        "AIRCentral",
        "Psyclone.Module.Connect.Poster",
        "640153bf-ecb3-4273-a591-5be9e1bbdec4",
        (1795328339, 881),
        "",
    )
    resolve(
        s, "P6", "Poster", "502709e6-4ab5-4e88-97cc-3e589fece223", (1795328344, 748), "AIRServer"
    )
    s.request(
        "P12",
        jmsg(
            "System.PerfStat",
            "502709e6-4ab5-4e88-97cc-3e589fece223",
            "Poster",
            "AIRServer",
            t=(1795328344, 748),
            content=xml_content(PERFSTAT),
            lang="xml",
        ),
        "System.PerfStat",
        ["OA-SESS-14"],
        type=ACCEPT,
    )
    s.request(
        "R1",
        jmsg("PING", "0725ead0-c5c7-454f-99b0-be7efd2dc3f2", "Reader", "CNS", t=(1795328345, 925)),
        "PING",
        ["OA-SESS-10"],
        type="PING_SUCCESS",
        **{"from": "CNS", "to": "Reader"},
    )
    s.request(
        "R11",
        jmsg(
            "GET_ID",
            "0f7736d1-a5f0-4ed0-a549-804a3d3bb888",
            "Reader",
            "AIRServer",
            t=(1795328345, 944),
        ),
        "GET_ID",
        ["OA-SESS-14"],
        type="ID",
        content_regex="^\\S+$",
    )
    s.request(
        "R11",
        jmsg(
            "GET_NAME",
            "f02e05d0-234d-4acd-b5e3-791b3a06e430",
            "Reader",
            "AIRServer",
            t=(1795328345, 964),
        ),
        "GET_NAME",
        ["OA-SESS-14"],
        type="NAME",
        content_regex="^.+$",
    )
    for conn in ("R1", "R3", "R4", "R5", "R11"):
        s.add({"conn": conn, "close": True, "origin": "Reader's JVM exits (RST)"})
    s.add({"conn": "R2", "expect_closed": True, "requirements": ["OA-SESS-15"]})
    retrieve(
        s,
        "P10",
        "Poster",
        made_id("01/lost"),
        (1795328350, 0),
        '<retrieve from="AIRCentral" type="Psyclone.Module.Lost.Reader"><latest>0</latest>'
        "</retrieve>",
        ["OA-SESS-15"],
        [["Psyclone.Module.Lost.Reader", None]],
    )
    return s


def s02_subscribe_post_wakeup() -> Session:
    s = Session(
        "02-subscribe-post-wakeup",
        "Reader subscribes with JavaOpenAIR's addTrigger; Poster posts a matching message, then "
        "one that only names Reader in cc, then one that concerns nobody.",
        "psyclone-wire/02-subscribe.txt, 03-post-wakeup.txt, 04-cc.txt (first part)",
    )
    java_bind(s, "R1", "R2", "Reader", (made_id("02/bind-r"), made_id("02/recv-r")), 1795328369)
    java_bind(s, "P6", "P7", "Poster", (made_id("02/bind-p"), made_id("02/recv-p")), 1795328369)
    subscribe(
        s,
        "R5",
        "Reader",
        "657f39ee-6d8f-47e6-bce2-c710d4e51463",
        '<triggers>\n\t\t\t<trigger from="WB1" type="Test.Ping.*" />\n\t\t</triggers>',
        (1795328370, 845),
    )
    resolve(s, "P6", "Poster", "f8f2d4e0-5514-4c04-aba2-58149b08ed39", (1795328371, 397), "WB1")
    n = post(
        s,
        "P12",
        "Poster",
        "WB1",
        "Test.Ping.A",
        "e5d1dae0-b5c8-4cbf-b65f-f1e8c87fd86c",
        (1795328371, 396),
        "hello ping",
    )
    s.wakeup(
        "Reader",
        ["OA-TRIG-1", "OA-WAKE-1", "OA-WAKE-2", "OA-WAKE-3", "OA-WAKE-4"],
        trigger=f"$msg-of-step-{n}",
        type="Test.Ping.A",
        lasttrigger="Test.Ping.*",
        retrieved=[],
        **{"from": "WB1"},
    )
    n = post(
        s,
        "P12",
        "Poster",
        "WB1",
        "Other.Unsubscribed.Type",
        "3473ffd9-891c-4a30-a293-8c9af54ed4f3",
        (1795328371, 987),
        "cc test",
        cc="Reader",
    )
    s.wakeup(
        "Reader",
        ["OA-CC-2", "OA-WAKE-4"],
        trigger=f"$msg-of-step-{n}",
        type="Other.Unsubscribed.Type",
        lasttrigger="",
        **{"from": "WB1"},
    )
    post(
        s,
        "P12",
        "Poster",
        "WB1",
        "Other.Unsubscribed.Type2",
        "2c7ea4c6-e76f-4740-a254-fdb2ab688713",
        (1795328372, 319),
        "control",
    )
    return s


def s03_cc() -> Session:
    s = Session(
        "03-cc",
        "cc separators, case and unknown names: CcA-CcC registered a trigger that never matches, "
        "CcD bound without a registration (the spec wakes it; Psyclone does not, DEV-12).",
        "psyclone-wire/04-cc.txt (second part; frames rebuilt from its summary lines)",
    )
    for i, name in enumerate(("CcA", "CcB", "CcC", "CcD")):
        java_bind(
            s,
            f"{name}1",
            f"{name}2",
            name,
            (made_id(f"03/bind-{name}"), made_id(f"03/recv-{name}")),
            1795329000 + i,
        )
        if name != "CcD":
            subscribe(
                s,
                f"{name}1",
                name,
                made_id(f"03/sub-{name}"),
                '<triggers>\n\t\t\t<trigger from="WB1" type="Never.Matches" />\n\t\t</triggers>',
                (1795329000 + i, 500),
            )
    cases = [
        ("Cc.One", "WB1", "CcA", ["CcA"]),
        ("Cc.Two", "WB1", "CcA,CcB", []),
        ("Cc.Three", "WB1", "CcA;CcB", ["CcA", "CcB"]),
        ("Cc.Four", "WB1", "CcA CcB", []),
        ("Cc.Five", "WB1", "cca", []),
        ("Cc.Six", "WB1", "Nobody", []),
        ("Cc.Seven", "WB1", "CcB, CcC", []),
        ("Cc.Eight", "WB2", "CcC", ["CcC"]),
        ("Cc.Nine", "WB1", "CcD", ["CcD"]),
    ]
    for i, (type_, wb, cc, woken) in enumerate(cases):
        n = post(
            s,
            "P",
            "Poster",
            wb,
            type_,
            made_id(f"03/{type_}"),
            (1795329004, 100 + i),
            f"probe {type_} cc={cc}",
            cc=cc,
            reqs=["OA-CC-3", "OA-WB-3"],
        )
        for module in woken:
            s.wakeup(
                module,
                ["OA-CC-1", "OA-CC-2"],
                trigger=f"$msg-of-step-{n}",
                type=type_,
                lasttrigger="",
                **{"from": wb},
            )
    return s
