"""One fuzzing example against the server under test: its modules, its steps and their checks.

An example owns up to three modules (`m0` … `m2`, named `C<run>_FUZZ001_E<n>_M<i>`), an unbound
connection (`stranger`) that posts with any `from` and retrieves, and a `checker` module that is
woken by the `Psyclone.Module.Lost.*` notices of the example's modules. Its types live under
`<type_prefix>.E<n>`, so examples never see each other's messages.

Every step ends in a sync: the checker posts a sentinel (priority 6.999) to the whiteboard of the
step, cc'd to every live module; every registration also carries a trigger for the sentinel's
type, so the sentinel arrives even on a server whose cc or wildcard matching is broken. By
OA-PRIO-1 every wakeup the step caused arrives before the sentinel; those wakeups are compared
with the routing model. No sleeps: absence is proven by the sentinel.

Step values (`Bind`, `Subscription`, `Post`, `Retrieval`, `Disconnect`) describe themselves in
short labels (`m0`, `A.B`, `WB1`) that do not depend on the run, so a replay prints the same steps.
"""

from __future__ import annotations

import asyncio
import html
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from openair.protocol.message import Message
from openair_conformance.fuzz.model import LOST_SENDER, RoutingModel, Stored, Trigger
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.harness.checks import (
    WakeupUnreadable,
    WakeupView,
    message_collection,
    triggered_by,
    wakeup_view,
)
from openair_conformance.harness.peer import BARRIER_PRIORITY
from openair_conformance.model import Inconclusive, TraceEntry

__all__ = [
    "LOST",
    "MODULES",
    "Bind",
    "Disconnect",
    "Divergence",
    "Example",
    "Post",
    "Retrieval",
    "Subscription",
]

#: Labels of the modules an example may bind.
MODULES = ("m0", "m1", "m2")
#: Trigger pattern key for `Psyclone.Module.Lost.<the example's module names>*` (OA-SESS-15).
LOST = "LOST"
#: `cc` token: m0's name with its case swapped, which names nobody (OA-CC-1).
SWAPPED = "m0~"


class Divergence(AssertionError):
    """The server did what the model does not allow; hypothesis shrinks the steps to it."""

    def __init__(self, message: str, *, expected: str, trace_index: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.expected = expected
        self.trace_index = trace_index
        #: The example's steps up to the divergence (set by the state machine).
        self.steps: tuple[str, ...] = ()
        #: The example's trace when it diverged (set by the state machine), for a report made
        #: without hypothesis' final replay.
        self.entries: tuple[TraceEntry, ...] = ()


# -- step values ---------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class Bind:
    """Bind a module: BIND with a listening port, or BIND_NOLISTEN (both open a callback)."""

    module: str
    listen: bool

    def describe(self) -> str:
        """Return the step as a line."""
        how = "BIND with a listening port" if self.listen else "BIND_NOLISTEN"
        return f"bind {self.module} ({how})"


@dataclass(frozen=True, slots=True, kw_only=True)
class Subscription:
    """Replace a module's registration: triggers (pattern key, `from`), form and self flag."""

    module: str
    triggers: tuple[tuple[str, str | None], ...]
    form: str  # "bare" (OA-REG-2) or "module" (OA-REG-3)
    flag: str | None = None  # allowselftriggering, module form only (OA-REG-6)

    def describe(self) -> str:
        """Return the step as a line."""
        shape = "<triggers>" if self.form == "bare" else "<module>"
        if self.flag is not None:
            shape += f" allowselftriggering={self.flag!r}"
        items = ", ".join(p if b is None else f"{p} from {b!r}" for p, b in self.triggers)
        return f"{self.module} subscribes {shape}: {items or 'no trigger'}"


@dataclass(frozen=True, slots=True, kw_only=True)
class Post:
    """Post a message of type `<prefix>.<suffix>` with `from` = the poster's name."""

    poster: str  # a module label or "stranger"
    via_stranger: bool  # sent on the unbound connection (from taken on trust, OA-SESS-16)
    board: str
    suffix: str
    cc: tuple[str, ...] = ()  # labels: modules, "stranger", "nobody", SWAPPED
    sep: str = ";"

    def describe(self) -> str:
        """Return the step as a line."""
        how = " on the unbound connection" if self.via_stranger and self.poster in MODULES else ""
        cc = f", cc {self.sep.join(self.cc)!r}" if self.cc else ""
        return f"{self.poster} posts {self.suffix} to {self.board}{how}{cc}"


@dataclass(frozen=True, slots=True, kw_only=True)
class Retrieval:
    """Retrieve `<prefix>.<pattern>` from a whiteboard, with sender and latest criteria."""

    board: str
    pattern: str
    sender: str | None = None
    latest: int | None = None
    as_attr: bool = False  # latest as an attribute, else as an element (OA-RET-4)
    addressed: bool = False  # sent to the whiteboard without `from` (OA-RET-2)

    def describe(self) -> str:
        """Return the step as a line."""
        parts = [f"retrieve {self.pattern} from {self.board}"]
        if self.sender is not None:
            parts.append(f"sender {self.sender}")
        if self.latest is not None:
            parts.append(f"latest {self.latest} ({'attribute' if self.as_attr else 'element'})")
        if self.addressed:
            parts.append("addressed to the whiteboard, no from")
        return ", ".join(parts)


@dataclass(frozen=True, slots=True, kw_only=True)
class Disconnect:
    """Close every connection of a module (the server posts its Lost notice, OA-SESS-15)."""

    module: str

    def describe(self) -> str:
        """Return the step as a line."""
        return f"disconnect {self.module}"


# -- the example ---------------------------------------------------------------------------------


def _attr(value: str) -> str:
    return html.escape(value, quote=True)


class Example:
    """The modules, model and checks of one example (all methods run on the case's loop)."""

    def __init__(self, ctx: CaseContext, index: int) -> None:
        self.ctx = ctx
        self.index = index
        self.step = 0  # the step being run, 1-based (set by `begin`)
        self.step_entry: int | None = None  # the trace entry where that step began
        self.model = RoutingModel()
        self.live: dict[str, TestModule] = {}
        self.prefix = ctx.type(f"E{index}")
        self.sentinel = ctx.barrier_type(f"E{index}")
        self.names = {label: self._name(f"M{i}") for i, label in enumerate(MODULES)}
        self.names |= {"stranger": self._name("X"), "nobody": self._name("Nobody")}
        self.names[SWAPPED] = self.names["m0"].swapcase()
        self.labels = {name: label for label, name in self.names.items()}
        self.labels[self._name("Chk")] = "checker"
        self.lost_pattern = f"Psyclone.Module.Lost.{self._name('M')}*"
        self.events: dict[str, str] = {}  # message id -> what it was, for messages
        self._opened: list[TestModule] = []
        self._checker: TestModule | None = None
        self._stranger: TestModule | None = None

    def _name(self, suffix: str) -> str:
        return self.ctx.name(f"E{self.index}_{suffix}")

    @property
    def checker(self) -> TestModule:
        """The module woken by Lost notices; it also posts the sync sentinels."""
        assert self._checker is not None, "example not started"
        return self._checker

    @property
    def stranger(self) -> TestModule:
        """The unbound connection (posts with any `from`, retrieves)."""
        assert self._stranger is not None, "example not started"
        return self._stranger

    def unbound(self) -> list[str]:
        """Labels of the modules not bound now."""
        return [label for label in MODULES if label not in self.live]

    def bound(self) -> list[str]:
        """Labels of the modules bound now."""
        return [label for label in MODULES if label in self.live]

    async def start(self) -> None:
        """Open the checker (registered for the example's Lost notices) and the stranger."""
        self._checker = self._track(await self.ctx.module(f"E{self.index}_Chk"))
        content = f'<triggers><trigger type="{self.lost_pattern}" from="AIRCentral"/></triggers>'
        reply = await self.checker.subscribe(content)
        if reply.type != "RECEIVE_ACCEPT":
            raise Inconclusive(f"setup: AIR.Subscribe was answered {reply.type} {reply.content!r}")
        self._stranger = self._track(await self.ctx.module(f"E{self.index}_X", bind=False))

    def _track(self, module: TestModule) -> TestModule:
        self._opened.append(module)
        return module

    async def close(self) -> None:
        """Close every connection the example opened."""
        for module in reversed(self._opened):
            await module.close()

    # -- names and text ----------------------------------------------------------------------

    def type(self, suffix: str) -> str:
        """Return the full type or pattern for a short key (`A.B`, `*`, LOST)."""
        return self.lost_pattern if suffix == LOST else f"{self.prefix}.{suffix}"

    def short(self, text: str) -> str:
        """Replace the example's prefixes and names in `text` by their short labels."""
        text = text.replace(self.lost_pattern, LOST).replace(f"{self.prefix}.", "")
        for name, label in sorted(self.labels.items(), key=lambda kv: -len(kv[0])):
            text = text.replace(name, label)
        return text

    def begin(self, step: int) -> None:
        """Note that step number `step` begins (a divergence points at its first frame)."""
        self.step = step
        self.step_entry = len(self.ctx.trace)

    def diverge(self, message: str, expected: str) -> Divergence:
        """Build a Divergence pointing at the first trace entry of the step."""
        size = len(self.ctx.trace)
        index = None if self.step_entry is None or not size else min(self.step_entry, size - 1)
        return Divergence(self.short(message), expected=self.short(expected), trace_index=index)

    def _what(self, message_id: str) -> str:
        return self.events.get(message_id, f"a message the example did not send ({message_id})")

    # -- steps --------------------------------------------------------------------------------

    async def bind(self, step: Bind) -> None:
        """Bind a module and register the sentinel trigger alone (no fuzz trigger yet)."""
        self._bound(step, await self._open_module(step))
        await self._register(step.module, self._registration(step.module, (), "bare", None))
        if not step.listen:  # the callback connection must be in use before the next step
            await self.settle("WB1", None, {})

    async def open_all(self, steps: Sequence[tuple[Bind, Subscription]]) -> None:
        """Bind modules at once, each then registered; sync once if one used BIND_NOLISTEN."""
        modules = await asyncio.gather(*(self._open_module(bind) for bind, _ in steps))
        for (bind, _), module in zip(steps, modules, strict=True):
            self._bound(bind, module)
        await asyncio.gather(*(self.subscribe(subscription) for _, subscription in steps))
        if not all(bind.listen for bind, _ in steps):
            await self.settle("WB1", None, {})

    async def _open_module(self, step: Bind) -> TestModule:
        suffix = f"E{self.index}_M{MODULES.index(step.module)}"
        return self._track(await self.ctx.module(suffix, listen=step.listen))

    def _bound(self, step: Bind, module: TestModule) -> None:
        self.live[step.module] = module
        self.model.bind(self.names[step.module])

    async def subscribe(self, step: Subscription) -> None:
        """Replace a module's registration (OA-REG-1) and tell the model."""
        triggers = tuple(Trigger(pattern=self.type(p), board=b) for p, b in step.triggers)
        xml = self._registration(step.module, triggers, step.form, step.flag)
        await self._register(step.module, xml)
        self_ok = step.form == "module" and (step.flag or "").lower() == "yes"  # OA-REG-6
        self.model.subscribe(self.names[step.module], triggers, self_ok=self_ok)

    def _registration(
        self, label: str, triggers: tuple[Trigger, ...], form: str, flag: str | None
    ) -> str:
        items = "".join(
            f'<trigger type="{_attr(t.pattern)}"'
            + ("" if t.board is None else f' from="{_attr(t.board)}"')
            + "/>"
            for t in (*triggers, Trigger(pattern=self.sentinel))  # the sync trigger, last
        )
        if form == "bare":
            return f"<triggers>{items}</triggers>"  # OA-REG-2
        self_flag = "" if flag is None else f' allowselftriggering="{_attr(flag)}"'
        head = f'<module name="{self.names[label]}"{self_flag}>'
        return f"{head}<triggers>{items}</triggers></module>"  # OA-REG-3

    async def _register(self, label: str, xml: str) -> None:
        reply = await self.live[label].subscribe(xml)
        if reply.type != "RECEIVE_ACCEPT":
            raise self.diverge(
                f"AIR.Subscribe of {label} was answered {reply.type} {reply.content!r}",
                "RECEIVE_ACCEPT to a valid registration (OA-REG-7)",
            )

    async def post(self, step: Post) -> None:
        """Post, then check who was woken and with which lasttrigger."""
        sender = self.names[step.poster]
        poster = self.stranger if step.via_stranger else self.live[step.poster]
        cc = step.sep.join(self.names[token] for token in step.cc)
        type_ = self.type(step.suffix)
        reply = await poster.post(step.board, type_, step.suffix, cc=cc, sender=sender, check=False)
        assert poster.last_sent is not None
        msg_id = poster.last_sent.id
        self.events[msg_id] = f"the post of step {self.step} ({step.suffix} to {step.board})"
        if reply.type != "RECEIVE_ACCEPT":
            raise self.diverge(
                f"the post was answered {reply.type} {reply.content!r}",
                "RECEIVE_ACCEPT: a valid post is stored whatever its cc names (OA-WB-3, OA-CC-3)",
            )
        stored = Stored(id=msg_id, type=type_, sender=sender, board=step.board)
        await self.settle(step.board, msg_id, self.model.post(stored, cc))

    async def retrieve(self, step: Retrieval) -> None:
        """Retrieve on the unbound connection and compare the ids, in order, with the model."""
        attrs = "" if step.addressed else f' from="{step.board}"'
        attrs += f' type="{_attr(self.type(step.pattern))}"'
        sender = None if step.sender is None else self.names[step.sender]
        if sender is not None:
            attrs += f' sender="{sender}"'
        body = ""
        if step.latest is not None and step.as_attr:
            attrs += f' latest="{step.latest}"'
        elif step.latest is not None:
            body = f"<latest>{step.latest}</latest>"
        to = step.board if step.addressed else "AIRCentral"
        reply = await self.stranger.retrieve(f"<retrieve{attrs}>{body}</retrieve>", to=to)
        if reply.type != "AIR.Retrieve.Success":
            raise self.diverge(
                f"the retrieve was answered {reply.type} {reply.content!r}",
                "AIR.Retrieve.Success (OA-RET-1, OA-RET-7)",
            )
        try:
            got = [m.id for m in message_collection(reply)]
        except WakeupUnreadable as exc:
            raise self.diverge(f"the retrieve result is unreadable: {exc}", "OA-RET-7") from exc
        want = self.model.retrieve(
            step.board, self.type(step.pattern), sender=sender, latest=step.latest
        )
        if got != want:
            raise self.diverge(
                f"the retrieve returned {self._list(got)}",
                f"{self._list(want)}: the matching messages, newest first, at most `latest` "
                "(OA-RET-3, OA-RET-4, OA-RET-6)",
            )

    def _list(self, ids: Sequence[str]) -> str:
        return "[" + ", ".join(self._what(i) for i in ids) + "]" if ids else "nothing"

    async def disconnect(self, step: Disconnect) -> None:
        """Close a module, wait for its Lost notice, then check who the notice woke."""
        module = self.live.pop(step.module)
        name = self.names[step.module]
        await module.close()
        lost_type = f"Psyclone.Module.Lost.{name}"
        wakeup = await self.checker.expect_wakeup(
            _trigger_type_is(lost_type), what=f"{lost_type} notice (OA-SESS-15)"
        )
        trigger = self._view(wakeup, "checker").trigger
        assert trigger is not None  # _trigger_type_is found it
        self.model.unbind(name)
        self.events[trigger.id] = f"the Lost notice of {step.module} (step {self.step})"
        if trigger.sender != LOST_SENDER:
            raise self.diverge(
                f"{lost_type} came from {trigger.sender!r}", f"from {LOST_SENDER!r} (OA-SESS-15)"
            )
        stored = Stored(id=trigger.id, type=lost_type, sender=LOST_SENDER, board="AIRCentral")
        await self.settle("AIRCentral", trigger.id, self.model.post(stored, ""))

    # -- sync and comparison ------------------------------------------------------------------

    async def settle(self, board: str, msg_id: str | None, want: dict[str, str]) -> None:
        """Sync every live module and compare its wakeups with `want` (name -> lasttrigger)."""
        if not self.live:
            return
        seen = await self._sync(board)
        for label, wakeups in seen.items():
            self._compare(label, msg_id, want.get(self.names[label]), wakeups)

    async def _sync(self, board: str) -> dict[str, list[Message]]:
        """Post the sentinel and return, per live module, the wakeups that came before it."""
        cc = ";".join(self.names[label] for label in self.live)
        reply = await self.checker.post(
            board, self.sentinel, "sync", cc=cc, priority=BARRIER_PRIORITY, check=False
        )
        assert self.checker.last_sent is not None
        sentinel = self.checker.last_sent.id
        self.events[sentinel] = f"the sync message after step {self.step}"
        if reply.type != "RECEIVE_ACCEPT":
            raise self.diverge(
                f"the sync post was answered {reply.type} {reply.content!r}", "RECEIVE_ACCEPT"
            )
        seen: dict[str, list[Message]] = {}
        for label, module in self.live.items():
            await module.expect_wakeup(
                triggered_by(sentinel), what="sync wakeup (cc and trigger, OA-CC-2, OA-TRIG-1)"
            )
            seen[label] = [await module.expect_wakeup(_is(m)) for m in module.pending_wakeups()]
        return seen

    def _view(self, wakeup: Message, label: str) -> WakeupView:
        try:
            return wakeup_view(wakeup)
        except WakeupUnreadable as exc:
            raise self.diverge(f"a wakeup of {label} is unreadable: {exc}", "OA-WAKE-1") from exc

    def _compare(
        self, label: str, msg_id: str | None, want: str | None, wakeups: list[Message]
    ) -> None:
        """Check one module's wakeups of a step: exactly `want`, or none (want None)."""
        got: list[str | None] = []
        for wakeup in wakeups:
            view = self._view(wakeup, label)
            trigger_id = view.trigger.id if view.trigger is not None else "?"
            if trigger_id != msg_id:
                raise self.diverge(
                    f"{label} was woken by {self._what(trigger_id)}",
                    "no wakeup but those of the step, each once (OA-WAKE-5)",
                )
            got.append(view.phase_attr("lasttrigger"))
        what = self._what(msg_id) if msg_id is not None else "nothing"
        if want is None and got:
            raise self.diverge(
                f"{label} was woken by {what} (lasttrigger {got[0]!r})",
                f"no wakeup: {self._why_not(label)}",
            )
        if want is None:
            return
        if want == "":
            because = "cc names it and no trigger fires (OA-CC-2, OA-CC-4, OA-WAKE-4)"
        else:
            because = f"trigger {want} is the first that fires (OA-TRIG-1, OA-WAKE-4, OA-WAKE-6)"
        if not got:
            expected = f"one wakeup with lasttrigger {want!r}: {because}"
            raise self.diverge(f"{label} was not woken by {what}", expected)
        if len(got) > 1 or got[0] != want:
            raise self.diverge(
                f"{label} was woken {len(got)} time(s) by {what}, lasttrigger {got}",
                f"one wakeup (OA-WAKE-5) with lasttrigger {want!r}: {because}",
            )

    def _why_not(self, label: str) -> str:
        """Say why the model wakes no one: the module's registration, for the reader."""
        registration = self.model.registration(self.names[label])
        if registration is None:
            return f"{label} is not bound"
        triggers = ", ".join(
            t.pattern if t.board is None else f"{t.pattern} from {t.board!r}"
            for t in registration[0]
        )
        self_ok = "on" if registration[1] else "off"
        return (
            f"no trigger of {label} fires ({triggers or 'none'}; self-triggering {self_ok}; "
            "OA-TRIG-1, OA-TRIG-2, OA-TRIG-4) and cc does not name it (OA-CC-1)"
        )


def _is(target: Message) -> Callable[[Message], bool]:
    return lambda msg: msg is target


def _trigger_type_is(type_: str) -> Callable[[Message], bool]:
    def predicate(msg: Message) -> bool:
        try:
            trigger = wakeup_view(msg).trigger
        except WakeupUnreadable:
            return False
        return trigger is not None and trigger.type == type_

    return predicate
