#!/usr/bin/env python3
"""Generate the session vectors (spec/vectors/sessions/*.json) from the facts embedded below.

Usage: gen_session_vectors.py [--check]. With --check, exit 1 if a vector file is stale.

Every frame a client sends is rendered in the exact layout JavaOpenAIR writes (tab-indented,
`priority`/`timetolive` root attributes, lower-case `postedtime`), with the ids, names, times and
contents copied from the Psyclone wire transcripts (`psyclone-wire/NN-*.txt`); the README of the
vectors lists the origin of every frame. The transcripts are not read here or at test time. The
expected answers are the ones the spec requires, with the requirement IDs per step.
"""

from __future__ import annotations

import argparse
import json
import sys
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "spec" / "vectors" / "sessions"
FORMAT = "openair-session-vectors/1"
_NS = uuid.UUID("6f0e6a2c-1d1b-4c8e-9a57-0a1f0c0ffee0")

Step = dict[str, Any]


def made_id(label: str) -> str:
    """Return a stable UUID for a frame whose id the transcript does not show."""
    return str(uuid.uuid5(_NS, label))


def jmsg(
    type_: str,
    id_: str,
    frm: str,
    to: str,
    *,
    t: tuple[int, int],
    content: str = "",
    lang: str = "",
    cc: str = "",
    prio: str = "0.0",
    extra: str = "",
) -> str:
    """Render a message exactly as JavaOpenAIR's `Message.toXML()` writes it."""
    return (
        f'<message priority="{prio}" timetolive="0.0">\n'
        f"\t<type>{type_}</type>\n\t<id>{id_}</id>\n\t<from>{frm}</from>\n\t<to>{to}</to>\n"
        f"\t<cc>{cc}</cc>\n\t<stored></stored>\n\t<isresponse></isresponse>\n"
        f'\t<postedtime sec="{t[0]}" msec="{t[1]}" />\n'
        f'\t<content language="{lang}">{content}</content>\n{extra}</message>\n'
    )


def xml_content(inner: str) -> str:
    """Indent embedded XML content the way JavaOpenAIR does (two tabs, closing tab)."""
    return f"\n\t\t{inner}\n\t"


@dataclass
class Session:
    """A session under construction: numbered steps, 1-based."""

    name: str
    description: str
    origin: str
    steps: list[Step] = field(default_factory=list)

    def add(self, step: Step) -> int:
        self.steps.append(step)
        return len(self.steps)

    def send(self, conn: str, xml: str, origin: str, *, tag: str = "Message", **kw: Any) -> int:
        return self.add({"conn": conn, "send": {"tag": tag, "xml": xml}, "origin": origin, **kw})

    def expect(self, conn: str, reqs: list[str], **expect: Any) -> int:
        return self.add({"conn": conn, "expect": expect, "requirements": reqs})

    def request(
        self, conn: str, xml: str, origin: str, reqs: list[str], **expect: Any
    ) -> tuple[int, int]:
        n = self.send(conn, xml, origin)
        return n, self.expect(conn, reqs, isresponse=f"$id-of-step-{n}", **expect)

    def wakeup(self, module: str, reqs: list[str], **expect: Any) -> int:
        return self.add({"module": module, "expect_wakeup": expect, "requirements": reqs})

    def to_json(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "name": self.name,
            "description": self.description,
            "origin": self.origin,
            "steps": self.steps,
        }


ACCEPT = "RECEIVE_ACCEPT"
EMPTY = "^$"


def java_bind(s: Session, conn: str, cb: str, name: str, ids: tuple[str, str], t: int) -> None:
    """BIND on `conn`, then the Receive callback on `cb` (JavaOpenAIR init steps 1-3)."""
    s.request(
        conn,
        jmsg("BIND", ids[0], name, "CNS", t=(t, 877)),
        "BIND",
        ["OA-SESS-3", "OA-SESS-1"],
        type="BIND_ACCEPT",
        content_regex="^[0-9]+$",
        **{"from": "CNS", "to": name},
    )
    s.send(
        cb,
        jmsg("RECEIVE_NAME_NOTIFICATION", ids[1], name, "", t=(t, 908)),
        "Receive callback; no reply (OA-SESS-7)",
        tag="Receive",
        requirements=["OA-SESS-7", "OA-FRAME-10"],
    )


def subscribe(s: Session, conn: str, name: str, id_: str, inner: str, t: tuple[int, int]) -> int:
    """AIR.Subscribe to AIRCentral as JavaOpenAIR sends it; the spec wants RECEIVE_ACCEPT."""
    n, _ = s.request(
        conn,
        jmsg(
            "AIR.Subscribe",
            id_,
            name,
            "AIRCentral",
            t=t,
            content=xml_content(inner),
            lang="xml",
            prio="2.0",
        ),
        f"AIR.Subscribe from {name}",
        ["OA-REG-7", "OA-REG-1"],
        type=ACCEPT,
        **{"from": "AIRCentral"},
    )
    return n


def post(
    s: Session,
    conn: str,
    frm: str,
    to: str,
    type_: str,
    id_: str,
    t: tuple[int, int],
    content: str,
    cc: str = "",
    reqs: list[str] | None = None,
) -> int:
    """A post as JavaOpenAIR's postMessage writes it, acknowledged by the whiteboard."""
    n, _ = s.request(
        conn,
        jmsg(type_, id_, frm, to, t=t, content=content, cc=cc, prio="2.0"),
        f"post {type_} to {to}" + (f" cc={cc}" if cc else ""),
        reqs or ["OA-WB-2", "OA-WB-3", "OA-SESS-16"],
        type=ACCEPT,
        content_regex=EMPTY,
        **{"from": to},
    )
    return n


def retrieve(
    s: Session,
    conn: str,
    frm: str,
    id_: str,
    t: tuple[int, int],
    spec: str,
    reqs: list[str],
    results: list[list[str | None]] | None,
    *,
    to: str = "AIRCentral",
    cmd: str = "AIR.Retrieve",
    failed: str = "",
) -> int:
    """A retrieve as JavaOpenAIR sends it, with the results (type, content) the spec requires."""
    expect: dict[str, Any] = {"from": to}
    if failed:
        expect.update(type=f"{cmd}.Failed", content_regex=f"^{failed}(: .*)?$")
    else:
        expect.update(type=f"{cmd}.Success", results=results)
    n, _ = s.request(
        conn,
        jmsg(cmd, id_, frm, to, t=t, content=xml_content(spec) if spec else "", lang="xml"),
        f"{cmd} {spec or '(empty)'}",
        reqs,
        **expect,
    )
    return n


# --- the sessions ------------------------------------------------------------------------------

PERFSTAT = (
    '<perfstat name="Poster" count="0" received="0" posted="0" max="0" stored="0" sent="0" '
    'woken="0" processed="0" streamscount="0" streamssize="0" streamsratein="0.0" '
    'streamsrateout="0.0" streamsever="0.0" currentcpu="0.0" totalrun="0.0" totalcpu="0.0" '
    'delta="0.0" deltarun="0.0" deltacpu="0.0" currentsystem="0.0" averagesystem="0.0" '
    'totalsystem="0.0">\n\t\t\t<time sec="1795328339" msec="624" />\n'
    '\t\t\t<time sec="1795328344" msec="748" />\n\t\t</perfstat>'
)
GLOBAL_ENTRIES = ["spec", "name", "title", "description", "datastorefile", "htmldir"]


def resolve(s: Session, conn: str, frm: str, id_: str, t: tuple[int, int], name: str) -> None:
    """RESOLVE_REQUEST as JavaOpenAIR sends it (language English), answered with a tcplocation."""
    s.request(
        conn,
        jmsg("RESOLVE_REQUEST", id_, frm, "CNS", t=t, content=name, lang="English"),
        f"RESOLVE_REQUEST {name}",
        ["OA-SESS-8"],
        type="RESOLVE_SUCCESS",
        content_root="tcplocation",
        content_regex=f'.*\\bname="{name}".*',
        **{"from": "CNS"},
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


RET_POSTS = [
    ("Ret.A.1", "WB1", "c1"),
    ("Ret.A.2", "WB1", "c2"),
    ("Ret.B.1", "WB1", "green tomato"),
    ("Ret.A.3", "WB1", "c3"),
    ("Other.X", "WB1", "x1"),
    ("Ret.A.4", "WB2", "c4 on WB2"),
    ("Ret.A.5", "WB1", "red tomato"),
    ("Ret.A.6", "WB1", "c6"),
    ("Ret.a.7", "WB1", "c7 lower"),
    ("Ret.A.8", "WB1", "c8"),
]
_CONTENT = {t: c for t, _, c in RET_POSTS}
WB1_NEWEST = [t for t, wb, _ in reversed(RET_POSTS) if wb == "WB1"]
RET_NEWEST = [t for t in WB1_NEWEST if t.lower().startswith("ret.")]


def res(*types: str) -> list[list[str | None]]:
    """Expected retrieve results: (type, content) pairs, newest first."""
    return [[t, _CONTENT[t]] for t in types]


#: (id, time, spec, requirements, result types or failure name) in the order of file 05 part B.
RET_MATRIX: list[tuple[str, tuple[int, int], str, list[str], list[str] | str]] = [
    (
        "a59713ee-1be5-46dc-bdd6-e6bbded33969",
        (1795329327, 759),
        '<retrieve from="WB1" type="Ret.A.*"><latest>3</latest></retrieve>',
        ["OA-RET-6", "OA-MATCH-1"],
        ["Ret.A.8", "Ret.a.7", "Ret.A.6"],
    ),
    (
        "9d45c7ed-3abc-4d5b-b13d-25f09dc644d3",
        (1795329327, 800),
        '<retrieve from="WB1" type="Ret.A.*"/>',
        ["OA-RET-4"],
        ["Ret.A.8"],
    ),
    (
        "b4e322ed-b901-4ae4-8490-70afc3bd8341",
        (1795329327, 828),
        '<retrieve from="WB1" type="Ret.*"><latest>100</latest></retrieve>',
        ["OA-RET-6"],
        RET_NEWEST,
    ),
    (
        "a54726f1-604f-45cf-a0ca-d90318357a10",
        (1795329327, 877),
        '<retrieve from="WB1" type="*"><latest>4</latest></retrieve>',
        ["OA-MATCH-5", "OA-WB-11"],
        WB1_NEWEST[:4],
    ),
    (
        "42cd58f0-3fa6-4c39-a7f1-f7f207ea481a",
        (1795329327, 912),
        '<retrieve from="WB1"><latest>3</latest></retrieve>',
        ["OA-RET-3"],
        WB1_NEWEST[:3],
    ),
    (
        "491fa5f0-1fcf-45ba-b38b-b9be47f73db0",
        (1795329327, 935),
        '<retrieve type="Ret.A.*"><latest>3</latest></retrieve>',
        ["OA-RET-2"],
        [],
    ),
    (
        "c16a7ff4-262e-4c88-849a-f542662cc41a",
        (1795329328, 23),
        '<retrieve from="WB2" type="Ret.A.*"><latest>3</latest></retrieve>',
        ["OA-RET-2"],
        ["Ret.A.4"],
    ),
    (
        "4225e2f1-61db-4b33-b96b-f196a41ae96d",
        (1795329328, 101),
        '<retrieve from="WB1" type="Ret.A.1"><latest>3</latest></retrieve>',
        ["OA-MATCH-2"],
        ["Ret.A.1"],
    ),
    (
        "a97902df-a0fa-479d-9aae-e91ffefaecba",
        (1795329328, 188),
        '<retrieve from="WB1" type="Ret.A"><latest>3</latest></retrieve>',
        ["OA-MATCH-2"],
        [],
    ),
    (
        "ebde4fe2-a670-4ddf-a904-d4b5f303605f",
        (1795329328, 268),
        '<retrieve from="WB1" type="Ret.A.1.Zzz*"><latest>3</latest></retrieve>',
        ["OA-MATCH-6", "OA-MATCH-8"],
        [],
    ),
    (
        "ba7dc0e5-ec20-4784-b8c8-5247f3d75735",
        (1795329328, 410),
        '<retrieve from="WB1" type="*.1"><latest>5</latest></retrieve>',
        ["OA-MATCH-3"],
        ["Ret.B.1", "Ret.A.1"],
    ),
    (
        "d54890e7-8fca-4e43-8b1e-75e2a49e01ec",
        (1795329328, 555),
        '<retrieve from="WB1" type="Ret.*" content="*tomato*"><latest>10</latest></retrieve>',
        ["OA-RET-8"],
        ["Ret.A.5", "Ret.B.1"],
    ),
    (
        "71d32ad2-8968-4d45-8c26-cc11ee49d857",
        (1795329328, 716),
        '<retrieve from="WB1" type="Ret.*" content="green*"><latest>10</latest></retrieve>',
        ["OA-RET-8"],
        ["Ret.B.1"],
    ),
    (
        "006d73d8-5477-4e8e-937c-469d6cd7ddd7",
        (1795329328, 990),
        '<retrieve from="WB1" type="Ret.*" latest="2"/>',
        ["OA-RET-4"],
        RET_NEWEST[:2],
    ),
    (
        "8287fbdb-1bf9-4a20-8d34-28811d888379",
        (1795329329, 56),
        '<retrieve from="WB1" type="Ret.*"><latest>0</latest></retrieve>',
        ["OA-RET-4"],
        RET_NEWEST,
    ),
    (
        "7ee6c125-fda3-45a6-9fc8-8714b41c785a",
        (1795329329, 203),
        '<retrieve from="WB1" type="Ret.*" sender="Poster"><latest>2</latest></retrieve>',
        ["OA-RET-3"],
        RET_NEWEST[:2],
    ),
    (
        "8e3a6d29-0460-469a-9aef-fdf36f98a22d",
        (1795329329, 299),
        '<retrieve from="WB1" type="Ret.*" sender="Nobody"><latest>2</latest></retrieve>',
        ["OA-RET-3"],
        [],
    ),
    (
        "45db5c27-40f6-46d1-9179-4b36d6b2da46",
        (1795329329, 353),
        '<retrieve from="NoSuchWB" type="*"><latest>2</latest></retrieve>',
        ["OA-RET-11"],
        "WHITEBOARD_UNKNOWN",
    ),
    (
        "d09fba2c-0ad6-4bdd-a845-e88964a115d2",
        (1795329329, 635),
        '<retrieve from="wb1" type="Ret.A.*"><latest>2</latest></retrieve>',
        ["OA-RET-11", "OA-WB-10"],
        "WHITEBOARD_UNKNOWN",
    ),
    (
        "e3cdb81c-2d08-40a6-8cd6-74e169b212fc",
        (1795329329, 849),
        '<retrieve from="WB1" type="Ret.A.*"><latest>2</latest><lastmsec>100000</lastmsec>'
        "</retrieve>",
        ["OA-RET-3", "OA-RET-5"],
        ["Ret.A.8", "Ret.a.7"],
    ),
    (
        "3258094f-47e7-4964-96fc-78e6b00c1662",
        (1795329331, 979),
        "garbage",
        ["OA-RET-10"],
        "RETRIEVE_INVALID",
    ),
]


def s04_retrieve() -> Session:
    s = Session(
        "04-retrieve",
        "Poster posts ten messages; Reader sends JavaOpenAIR's retrieves (to AIRCentral, "
        "whiteboard "
        "in from) and a raw client sends retrieves straight to WB1, as escaped text, and empty.",
        "psyclone-wire/05-retrieve.txt (parts B and C)",
    )
    for i, (type_, wb, content) in enumerate(RET_POSTS):
        id_ = "7653c0ea-b5ba-40de-a4c3-6351bc53db91" if type_ == "Ret.A.8" else made_id(type_)
        post(s, "P", "Poster", wb, type_, id_, (1795329327, 100 + 60 * i), content)
    for id_, t, spec, reqs, want in RET_MATRIX:
        if isinstance(want, str):
            retrieve(s, "R5", "Reader", id_, t, spec, reqs, None, failed=want)
        else:
            retrieve(s, "R5", "Reader", id_, t, spec, reqs, res(*want))
    s.request(
        "RC2",
        jmsg(
            "AIR.Retrieve",
            "75c13400-1c03-410b-b004-8f4f6661c1d3",
            "RawClient",
            "WB1",
            t=(1795330189, 915),
            content='<retrieve type="*"><latest>0</latest></retrieve>',
            lang="xml",
            prio="2.0",
        ),
        "AIR.Retrieve sent to WB1 without from: reads WB1",
        ["OA-RET-1", "OA-RET-2", "OA-WB-11"],
        type="AIR.Retrieve.Success",
        results=res(*WB1_NEWEST),
        **{"from": "WB1"},
    )
    escaped = (
        '&lt;retrieve from="WB1" type="Ret.A.*"&gt;&lt;latest&gt;1&lt;/latest&gt;&lt;/retrieve&gt;'
    )
    s.request(
        "RC3",
        jmsg(
            "AIR.Retrieve",
            "fe4e6104-fc9d-4dde-8818-e5ec023645f7",
            "RawClient",
            "AIRCentral",
            t=(1795330190, 148),
            content=escaped,
            prio="2.0",
        ),
        "retrieve spec as escaped text (type changed from TR.* to fit this data)",
        ["OA-RET-14"],
        type="AIR.Retrieve.Success",
        results=res("Ret.A.8"),
    )
    s.request(
        "RC3",
        jmsg(
            "AIR.Retrieve",
            "88f86c75-29bb-49e5-9f4d-a01f0b15a58f",
            "RawClient",
            "AIRCentral",
            t=(1795330190, 236),
            lang="xml",
            prio="2.0",
        ),
        "AIR.Retrieve with empty content",
        ["OA-RET-10", "OA-ERR-6"],
        type="AIR.Retrieve.Failed",
        content_regex="^RETRIEVE_INVALID(: .*)?$",
    )
    retrieves = (
        '<retrieves><retrieve from="WB1" type="Ret.B.*"><latest>1</latest></retrieve>'
        '<retrieve from="WB2" type="*"><latest>1</latest></retrieve></retrieves>'
    )
    retrieve(
        s,
        "R5",
        "Reader",
        "83735b2e-addc-4dc3-a5b3-4480b3ae63f1",
        (1795329329, 592),
        retrieves,
        ["OA-RET-12", "OA-REG-5"],
        res("Ret.B.1", "Ret.A.4"),
        cmd="AIR.Retrieves",
    )
    return s


TR_RETRIEVE = '<retrieve from="WB1" type="TR.Data.*"><latest>2</latest></retrieve>'
#: module, registration, posts that wake it (type, whiteboard), lasttrigger, retrieved, reqs
REG_FORMS: list[tuple[str, str, list[tuple[str, str]], str, list[str] | None, list[str]]] = [
    (
        "M1",
        '<module name="M1"><trigger from="WB1" type="Reg.Mary"/></module>',
        [("Reg.Mary", "WB1")],
        "Reg.Mary",
        None,
        ["OA-REG-3"],
    ),
    (
        "M2",
        '<module name="M2"><spec><context name="Psyclone.System.Ready"><phase id="M2.Main">'
        '<triggers><trigger from="WB1" type="Reg.Greta"/></triggers></phase></context></spec>'
        "</module>",
        [("Reg.Greta", "WB1")],
        "Reg.Greta",
        None,
        ["OA-REG-4"],
    ),
    (
        "M3",
        f'<triggers><trigger from="WB1" type="TR.Go"/></triggers><retrieves>{TR_RETRIEVE}'
        "</retrieves>",
        [("TR.Go", "WB1")],
        "TR.Go",
        ["TR.Data.3", "TR.Data.2"],
        ["OA-REG-2", "OA-WAKE-3"],
    ),
    (
        "M4",
        '<triggers><trigger from="WB1" type="Reg.Delay" after="1500"/></triggers>',
        [("Reg.Delay", "WB1")],
        "Reg.Delay",
        None,
        ["OA-TRIG-3"],
    ),
    (
        "M5",
        '<module name="M5"><spec><context name="Some.Other.Context"><phase id="M5.Main">'
        '<triggers><trigger from="WB1" type="Reg.Ctx"/></triggers></phase></context></spec>'
        "</module>",
        # Asleep for the first Reg.Ctx; the Psyclone.Context post puts its context in force
        # (contexts extension, on in the reference server), so the second Reg.Ctx wakes it.
        [("Reg.Ctx", "WB1")],
        "Reg.Ctx",
        None,
        ["OA-REG-10", "OA-REG-13", "OA-REG-14"],
    ),
    (
        "N1",
        f'<module name="N1"><triggers><trigger from="WB1" type="TR.Go"/></triggers><retrieves>'
        f"{TR_RETRIEVE}</retrieves></module>",
        [("TR.Go", "WB1")],
        "TR.Go",
        ["TR.Data.3", "TR.Data.2"],
        ["OA-REG-3", "OA-WAKE-3", "OA-WAKE-7"],
    ),
    (
        "N2",
        '<module name="N2"><spec><context name="Psyclone.System.Ready"><phase id="N2.Main">'
        f'<triggers><trigger from="WB1" type="TR.Go"/></triggers><retrieves>{TR_RETRIEVE}'
        "</retrieves></phase></context></spec></module>",
        [("TR.Go", "WB1")],
        "TR.Go",
        ["TR.Data.3", "TR.Data.2"],
        ["OA-REG-4", "OA-WAKE-3"],
    ),
    (
        "N3",
        f'<phase><triggers><trigger from="WB1" type="TR.Go"/></triggers><retrieves>{TR_RETRIEVE}'
        "</retrieves></phase>",
        [("TR.Go", "WB1")],
        "TR.Go",
        ["TR.Data.3", "TR.Data.2"],
        ["OA-REG-12"],
    ),
    (
        "F1",
        '<triggers><trigger from="WB1" type="From.Test"/></triggers>',
        [("From.Test", "WB1")],
        "From.Test",
        None,
        ["OA-TRIG-2"],
    ),
    (
        "F2",
        '<triggers><trigger from="wb1" type="From.Test"/></triggers>',
        [("From.Test", "WB1")],
        "From.Test",
        None,
        ["OA-TRIG-2"],
    ),
    (
        "F3",
        '<triggers><trigger from="any" type="From.Test"/></triggers>',
        [("From.Test", "WB1"), ("From.Test", "WB2")],
        "From.Test",
        None,
        ["OA-TRIG-2"],
    ),
    (
        "F4",
        '<triggers><trigger from="*" type="From.Test"/></triggers>',
        [("From.Test", "WB1"), ("From.Test", "WB2")],
        "From.Test",
        None,
        ["OA-TRIG-2"],
    ),
    (
        "F5",
        '<triggers><trigger type="From.Test"/></triggers>',
        [("From.Test", "WB1"), ("From.Test", "WB2")],
        "From.Test",
        None,
        ["OA-TRIG-2"],
    ),
    (
        "F6",
        '<triggers><trigger from="WB2" type="From.Test"/></triggers>',
        [("From.Test", "WB2")],
        "From.Test",
        None,
        ["OA-TRIG-2"],
    ),
    (
        "F7",
        '<triggers from="WB1"><trigger type="From.Test"/></triggers>',
        [("From.Test", "WB1")],
        "From.Test",
        None,
        ["OA-REG-5"],
    ),
    (
        "F8",
        '<triggers><trigger from="WB*" type="From.Test"/></triggers>',
        [],
        "",
        None,
        ["OA-TRIG-2", "OA-REG-9"],
    ),
    (
        "F9",
        '<triggers><trigger from="NoSuchWB" type="From.Test"/></triggers>',
        [],
        "",
        None,
        ["OA-REG-9"],
    ),
    (
        "F10",
        '<triggers><trigger from="WB1" type="From.Test"/><trigger from="WB2" type="From.Test"/>'
        "</triggers>",
        [("From.Test", "WB1"), ("From.Test", "WB2")],
        "From.Test",
        None,
        ["OA-WAKE-5"],
    ),
]
REG_POSTS = [
    ("TR.Data.1", "WB1"),
    ("TR.Data.2", "WB1"),
    ("TR.Data.3", "WB1"),
    ("TR.Go", "WB1"),
    ("Reg.Mary", "WB1"),
    ("Reg.Greta", "WB1"),
    ("Reg.Delay", "WB1"),
    ("Reg.Ctx", "WB1"),
    ("Psyclone.Context:Some.Other.Context", "WB1"),
    ("Reg.Ctx", "WB1"),
    ("From.Test", "WB1"),
    ("From.Test", "WB2"),
]


def s05_registration_forms() -> Session:
    s = Session(
        "05-registration-forms",
        "Every registration form JavaOpenAIR, MARY and Greta use, the trigger from variants, "
        "after, "
        "a phase in another context (woken once that context is posted), and a root phase "
        "(ignored by Psyclone, DEV-9).",
        "psyclone-wire/10-trigger-from-and-registration.txt (frames rebuilt from its MARK lines)",
    )
    for i, (name, reg, _, _, _, reqs) in enumerate(REG_FORMS):
        java_bind(
            s,
            f"{name}.1",
            f"{name}.2",
            name,
            (made_id(f"05/bind-{name}"), made_id(f"05/recv-{name}")),
            1795329820 + i,
        )
        body = jmsg(
            "AIR.Subscribe",
            made_id(f"05/sub-{name}"),
            name,
            "AIRCentral",
            t=(1795329820 + i, 500),
            content=xml_content(reg),
            lang="xml",
            prio="2.0",
        )
        n = s.send(f"{name}.1", body, f"AIR.Subscribe {reg}")
        may_refuse = "OA-REG-9" in reqs
        s.expect(
            f"{name}.1",
            [*reqs, "OA-REG-7"],
            isresponse=f"$id-of-step-{n}",
            **(
                {
                    "type_in": [ACCEPT, "RECEIVE_ERROR"],
                    "content_regex": "^(|WHITEBOARD_UNKNOWN(: .*)?)$",
                }
                if may_refuse
                else {"type": ACCEPT}
            ),
        )
    sent: dict[tuple[str, str], int] = {}
    for i, (type_, wb) in enumerate(REG_POSTS):
        n = post(
            s,
            "P",
            "Poster",
            wb,
            type_,
            made_id(f"05/post-{i}"),
            (1795329825, 100 + i),
            f"probe {type_} cc=",
        )
        sent[(type_, wb)] = n
    for name, _, wakes, last, retrieved, reqs in REG_FORMS:
        for type_, wb in wakes:
            extra: dict[str, Any] = {} if retrieved is None else {"retrieved": retrieved}
            s.wakeup(
                name,
                [*reqs, "OA-TRIG-1"],
                trigger=f"$msg-of-step-{sent[(type_, wb)]}",
                type=type_,
                lasttrigger=last,
                **extra,
                **{"from": wb},
            )
    return s


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


ALL_SESSIONS = (
    s01_connect_bind,
    s02_subscribe_post_wakeup,
    s03_cc,
    s04_retrieve,
    s05_registration_forms,
    s06_self_and_multi,
    s07_errors,
    s08_keepalive_callback,
    s09_walkthrough,
)


def render(session: Session) -> str:
    """Return the JSON text of one session file."""
    return json.dumps(session.to_json(), indent=1, ensure_ascii=False) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="fail if a file is stale")
    args = parser.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    stale = 0
    for build in ALL_SESSIONS:
        session = build()
        path = OUT / f"{session.name}.json"
        text = render(session)
        if args.check:
            if not path.exists() or path.read_text(encoding="utf-8") != text:
                print(f"stale: {path.relative_to(ROOT)}", file=sys.stderr)
                stale += 1
        else:
            path.write_text(text, encoding="utf-8")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
