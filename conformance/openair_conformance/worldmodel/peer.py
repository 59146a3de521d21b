"""The checker's side of the whiteboard: a module that posts and collects `WM.` messages."""

from __future__ import annotations

import asyncio
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import xmlschema
from lxml import etree

from openair.client import Module, WakeupEvent
from openair.protocol.content import RetrieveSpec, Trigger
from openair.protocol.message import Message
from openair_conformance.model import Fail
from openair_worldmodel.wire import TYPE_ACK, TYPE_REPORT, PlanAck, decode_ack

XSD = Path(__file__).resolve().parents[3] / "schemas" / "worldmodel.xsd"
_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)


class CaseFailure(Fail):
    """The implementation did not do what a requirement says (judged FAIL, like any `Fail`)."""


@dataclass(slots=True)
class Schema:
    """The worldmodel XSD, compiled once."""

    pure: Any = None

    def check(self, content: str, what: str) -> None:
        """Raise CaseFailure when `content` is not valid against worldmodel.xsd."""
        if self.pure is None:
            self.pure = xmlschema.XMLSchema10(str(XSD))
        error = next(iter(self.pure.iter_errors(content)), None)
        if error is not None:
            raise CaseFailure(f"{what} is not valid against worldmodel.xsd: {error.reason}")


class Peer:
    """A connected checker module on `whiteboard`, collecting acks and reports."""

    def __init__(self, name: str, host: str, port: int, whiteboard: str, bound: float) -> None:
        self.whiteboard, self.bound = whiteboard, bound
        self.module = Module(name, host, port, on_wakeup=self._on_wakeup)
        self.acks: list[tuple[PlanAck, str]] = []
        self.reports: list[str] = []
        self.schema = Schema()
        self._changed = asyncio.Condition()

    async def start(self) -> None:
        await self.module.connect()
        await self.module.subscribe(
            [Trigger(pattern=t, whiteboard=self.whiteboard) for t in (TYPE_ACK, TYPE_REPORT)]
        )

    async def close(self) -> None:
        await self.module.close()

    async def _on_wakeup(self, event: WakeupEvent) -> None:
        msg = event.wakeup.trigger
        if msg is None:
            return
        if msg.type == TYPE_ACK:
            self.acks.append((decode_ack(msg.content), msg.content))
        elif msg.type == TYPE_REPORT:
            self.reports.append(msg.content)
        async with self._changed:
            self._changed.notify_all()

    async def post(self, type_: str, content: str) -> None:
        await self.module.post(self.whiteboard, type_, content, content_is_xml=True)

    async def wait(self, predicate: Any, what: str) -> None:
        """Wait (bounded) until `predicate()` holds, else fail naming `what`."""
        try:
            async with asyncio.timeout(self.bound), self._changed:
                await self._changed.wait_for(predicate)
        except TimeoutError:
            raise CaseFailure(f"no {what} within {self.bound} s") from None

    def acks_of(self, plan: str) -> list[PlanAck]:
        """The acknowledgements of `plan` so far, each checked against the XSD."""
        out = []
        for ack, content in self.acks:
            if ack.ack.plan == plan:
                self.schema.check(content, f"the WM.Plan.Ack {content}")
                out.append(ack)
        return out

    async def final_acks(self, plan: str) -> list[str]:
        """Wait for a final acknowledgement of `plan`; return all its statuses."""
        await self.wait(
            lambda: any(a.ack.status in ("terminated", "failed") for a in self.acks_of(plan)),
            f"final acknowledgement of {plan}",
        )
        return [a.ack.status for a in self.acks_of(plan)]

    async def stored(self, pattern: str) -> list[Message]:
        return await self.module.retrieve(
            RetrieveSpec(whiteboard=self.whiteboard, pattern=pattern, latest=0), to=self.whiteboard
        )
