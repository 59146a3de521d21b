"""Mutants of secure mode (spec 14.3, extension `auth`), one deliberate fault each.

They are not in the shared `CATALOGUE`: the cases that catch them run only against a server in
secure mode, which test_mutants_auth.py starts. Seams are server-only names: `AuthGate` and the
names openair.server.core.auth imports (the suite's client side computes proofs with
openair.protocol.auth).
"""

from __future__ import annotations

from typing import Any

import pytest
from mutants_core import Fn, Mutant, Patch, wrap

from openair.server.aio import app
from openair.server.core import auth as server_auth
from openair.server.core.auth import AuthGate, Refusal

AUTH_MUTANTS: dict[str, Mutant] = {}


def auth_mutant(id: str, description: str, *requirements: str) -> Any:
    """Register the decorated patch as a secure-mode mutant."""

    def register(patch: Patch) -> Patch:
        AUTH_MUTANTS[id] = Mutant(
            id=id, description=description, requirements=requirements, patch=patch
        )
        return patch

    return register


@auth_mutant("auth-nonce-constant", "every AUTH_CHALLENGE answers the same nonce", "OA-AUTH-2")
def _constant(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(AuthGate, "challenge", lambda self, conn: self._nonces.setdefault(conn, "0" * 64))


@auth_mutant("auth-any-proof", "any well-formed proof verifies", "OA-AUTH-3")
def _any_proof(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(server_auth, "verify", lambda secret, nonce, name, offered: True)


@auth_mutant("auth-nonce-kept", "a nonce is not used up by AUTH_RESPONSE", "OA-AUTH-3")
def _kept(mp: pytest.MonkeyPatch) -> None:
    def make(respond: Fn) -> Fn:
        def kept(self: AuthGate, conn: int, name: str, offered: str) -> None:
            nonce = self._nonces.get(conn)
            try:
                respond(self, conn, name, offered)
            finally:
                if nonce is not None:
                    self._nonces[conn] = nonce

        return kept

    wrap(mp, AuthGate, "respond", make)


@auth_mutant("auth-nonce-shared", "one pending nonce for the whole server", "OA-AUTH-2")
def _shared(mp: pytest.MonkeyPatch) -> None:
    wrap(mp, AuthGate, "challenge", lambda f: lambda self, conn: f(self, 0))
    wrap(mp, AuthGate, "respond", lambda f: lambda self, conn, name, offered: (
        self._proved.setdefault(conn, set()).update(_proved_on_zero(f, self, name, offered))
    ))  # fmt: skip


def _proved_on_zero(respond: Fn, gate: AuthGate, name: str, offered: str) -> set[str]:
    respond(gate, 0, name, offered)
    return {name}


@auth_mutant("auth-any-name", "a connection that proved one name acts for every name", "OA-AUTH-5")
def _any_name(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(AuthGate, "proved", lambda self, conn, name: bool(self._proved.get(conn)))


@auth_mutant("auth-anonymous", "a connection that proved nothing is let through", "OA-AUTH-5")
def _anonymous(mp: pytest.MonkeyPatch) -> None:
    wrap(mp, AuthGate, "screen", lambda f: lambda self, conn, msg, **kw: (
        f(self, conn, msg, **kw) if self._proved.get(conn) else None
    ))  # fmt: skip


@auth_mutant("auth-bind-open", "BIND and BIND_NOLISTEN need no proof (takeover)", "OA-AUTH-7")
def _bind_open(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(server_auth, "_OPEN_CNS", server_auth._OPEN_CNS | {"BIND", "BIND_NOLISTEN"})


@auth_mutant("auth-receive-open", "a Receive frame needs no proof", "OA-AUTH-6")
def _receive_open(mp: pytest.MonkeyPatch) -> None:
    wrap(mp, AuthGate, "screen", lambda f: lambda self, conn, msg, **kw: (
        None if kw["receive"] else f(self, conn, msg, **kw)
    ))  # fmt: skip


@auth_mutant("auth-receive-stays-open", "a refused Receive frame keeps its connection", "OA-AUTH-6")
def _receive_kept(mp: pytest.MonkeyPatch) -> None:
    def make(screen: Fn) -> Fn:
        def kept(self: AuthGate, conn: int, msg: Any, **kw: Any) -> Refusal | None:
            refusal = screen(self, conn, msg, **kw)
            return Refusal(error=refusal.error, reply_type=refusal.reply_type) if refusal else None

        return kept

    wrap(mp, AuthGate, "screen", make)


@auth_mutant("auth-server-types", "modules may post wakeups and lifecycle notices", "OA-AUTH-8")
def _server_types(mp: pytest.MonkeyPatch) -> None:
    mp.setattr(server_auth, "server_only_type", lambda type_, sender: False)


@auth_mutant("auth-server-types-case", "server-only types compared case-sensitively", "OA-AUTH-8")
def _server_types_case(mp: pytest.MonkeyPatch) -> None:
    wrap(mp, server_auth, "server_only_type", lambda f: lambda type_, sender: (
        type_.startswith(("AIR.", "Psyclone.")) and f(type_, sender)
    ))  # fmt: skip


@auth_mutant("auth-monitor-on", "the web monitor stays on in secure mode", "OA-AUTH-11")
def _monitor_on(mp: pytest.MonkeyPatch) -> None:
    def make(init: Fn) -> Fn:
        def with_monitor(self: app.Server, *args: Any, **kw: Any) -> None:
            init(self, *args, **kw)
            self.extensions = self.extensions | {"monitor"}

        return with_monitor

    wrap(mp, app.Server, "__init__", make)
