"""The building blocks of the session vectors: frames as JavaOpenAIR writes them, sessions."""

from __future__ import annotations

import uuid
from dataclasses import dataclass, field
from typing import Any

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
