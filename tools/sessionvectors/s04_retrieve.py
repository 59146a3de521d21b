"""Session 04: retrieve, every criterion against the posts of psyclone-wire/04."""

from __future__ import annotations

from tools.sessionvectors.common import (
    Session,
    jmsg,
    made_id,
    post,
    retrieve,
)

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
