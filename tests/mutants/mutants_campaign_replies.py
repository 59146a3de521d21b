"""Mutants from the campaign's survivors of router_commands.py (issue #15), one fault each.

Secure-mode faults register with `mutants_auth.auth_mutant` (test_mutants_auth.py runs them
against a server in secure mode): a gate that opens the CNS commands only for an empty `to`
(caught by AUTH-040), and AUTH_REQUIRED refusals of posts always sent from CNS (AUTH-042).
"""

from __future__ import annotations

from dataclasses import replace

import pytest
from mutants_auth import auth_mutant
from mutants_core import Fn, wrap

from openair.protocol.message import Message
from openair.server.core.auth import AuthGate, Refusal
from openair.server.core.outcome import Outcome
from openair.server.core.router_commands import ComponentCommands


@auth_mutant(
    "auth-cns-only-empty-to",
    "GET_CAPABILITIES and AUTH_* are open only with an empty to, not to='CNS'",
    "OA-AUTH-5",
    "OA-SESS-26",
)
def _cns_only_empty(mp: pytest.MonkeyPatch) -> None:
    def make(screen: Fn) -> Fn:
        def strict(
            self: AuthGate, conn: int, msg: Message, *, receive: bool, cns: bool, post: bool
        ) -> Refusal | None:
            refusal: Refusal | None = screen(
                self, conn, msg, receive=receive, cns=cns and not msg.to, post=post
            )
            return refusal

        return strict

    wrap(mp, AuthGate, "screen", make)


@auth_mutant(
    "auth-refusal-from-cns",
    "an AUTH_REQUIRED refusal of a post to a whiteboard comes from CNS",
    "OA-SESS-32",
)
def _refusal_from_cns(mp: pytest.MonkeyPatch) -> None:
    def make(auth_screen: Fn) -> Fn:
        def from_cns(self: ComponentCommands, *args: object) -> Outcome | None:
            out: Outcome | None = auth_screen(self, *args)
            if out is None:
                return None
            replies = tuple(replace(r, sender="CNS") for r in out.replies)
            return replace(out, replies=replies)

        return from_cns

    wrap(mp, ComponentCommands, "_auth_screen", make)
