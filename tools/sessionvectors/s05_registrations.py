"""Session 05: the registration forms of AIR.Subscribe (psyclone-wire/05)."""

from __future__ import annotations

from typing import Any

from tools.sessionvectors.common import (
    ACCEPT,
    Session,
    java_bind,
    jmsg,
    made_id,
    post,
    xml_content,
)

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
