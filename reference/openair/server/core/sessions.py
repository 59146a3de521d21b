"""Module sessions: BIND, the callback connection, takeover and loss (spec 6.3, 6.5, 6.9).

`Sessions` is the router's table of bound modules and their connections. It decides, and the
router turns the decisions into replies, notices and Outcome fields. Sans-I/O: connections are
plain ids given by the adapter.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

from openair.protocol.content import Registration
from openair.protocol.errors import BindRefusedError, OpenAIRError
from openair.protocol.message import Message
from openair.protocol.objects import parse_tcplocation
from openair.server.core.commands import declared_extensions
from openair.server.core.config import name_problem

__all__ = ["FIRST_MODULE_PORT", "NOLISTEN_PORT", "Bound", "ConnId", "ModuleInfo", "Sessions"]

ConnId = int
NOLISTEN_PORT = -1  # OA-SESS-5
FIRST_MODULE_PORT = 10114  # Psyclone counts up from here (spec 6.3 notes)
MAX_PORT = 65535


@dataclass(frozen=True, slots=True, kw_only=True)
class ModuleInfo:
    """A bound module: its connections, port, declared extensions and registration in force."""

    name: str
    conn: ConnId | None  # the primary connection (OA-SESS-3)
    callback: ConnId | None = None  # the callback connection (OA-SESS-7)
    port: int = NOLISTEN_PORT  # -1 after BIND_NOLISTEN (OA-SESS-5)
    address: str = ""  # the peer address of the primary connection, if the adapter told it
    extensions: frozenset[str] = frozenset()  # OA-SESS-19; empty = legacy
    registration: Registration | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class Bound:
    """What a BIND did: the port, connections to close, and whether it took a name over."""

    port: int
    close: tuple[ConnId, ...] = ()
    took_over: bool = False


class Sessions:
    """The bound modules and what each connection is (primary, callback or neither)."""

    def __init__(
        self,
        *,
        reserved: Callable[[str], bool],
        port_allocator: Callable[[int], int] | None = None,
    ) -> None:
        self.modules: dict[str, ModuleInfo] = {}
        self.generation = 0  # changes whenever a name is bound or unbound (the route cache)
        self._reserved = reserved  # whiteboard, stream and component names (OA-SESS-30)
        self._allocate = port_allocator
        self._next_port = FIRST_MODULE_PORT
        self._primary: dict[ConnId, list[str]] = {}  # conn -> the names bound on it
        self._callbacks: dict[ConnId, str] = {}  # callback conn -> name
        self._pending: dict[str, ConnId] = {}  # callbacks of names not bound yet
        self._conn_extensions: dict[ConnId, frozenset[str]] = {}
        self._conn_address: dict[ConnId, str] = {}

    def opened(self, conn: ConnId, address: str) -> None:
        """Note the peer address of a connection (OA-DELIV-1, OA-SESS-4)."""
        self._conn_address[conn] = address

    def extensions_of(self, conn: ConnId, sender: str) -> frozenset[str]:
        """Return what the requester declared: on this connection, else as a bound module."""
        declared = self._conn_extensions.get(conn)
        if declared is not None:
            return declared
        info = self.modules.get(sender)
        return info.extensions if info is not None else frozenset()

    def set_registration(self, name: str, reg: Registration | None) -> None:
        """Record the registration in force of a bound module."""
        info = self.modules.get(name)
        if info is not None:
            self.modules[name] = replace(info, registration=reg)

    def bind(self, conn: ConnId, msg: Message, reg: Registration | None) -> Bound:
        """Bind `msg.sender` to `conn` (OA-SESS-3..6, OA-SESS-19); raise BindRefusedError."""
        name = msg.sender
        problem = name_problem(name)  # OA-SESS-30
        if problem is None and self._reserved(name):
            problem = f"{name!r} is the name of a whiteboard, stream or system component"
        if problem is not None:
            raise BindRefusedError(problem)
        port = self._port(conn, msg)
        declared = declared_extensions(msg)
        if declared is not None:
            self._conn_extensions[conn] = declared  # OA-SESS-19: for this connection too
        old = self.modules.get(name)
        close = self._take_over(old, conn) if old is not None else ()
        callback = old.callback if old is not None and old.conn == conn else None
        if callback is None:
            callback = self._pending.pop(name, None)
        self.generation += 1
        self.modules[name] = ModuleInfo(
            name=name,
            conn=conn,
            callback=callback,
            port=port,
            address=self._conn_address.get(conn, ""),
            extensions=declared if declared is not None else frozenset(),
            registration=reg,
        )
        names = self._primary.setdefault(conn, [])
        if name not in names:
            names.append(name)
        took_over = old is not None and old.conn != conn
        return Bound(port=port, close=close, took_over=took_over)

    def notify(self, conn: ConnId, msg: Message) -> tuple[ConnId, ...] | None:
        """Make `conn` the callback connection of `msg.sender` (OA-SESS-7).

        Return the older callback connection to close, or None when the name can never be
        bound (the caller closes `conn`).
        """
        name = msg.sender
        if name_problem(name) is not None:
            return None
        declared = declared_extensions(msg)
        if declared is not None:
            self._conn_extensions[conn] = declared  # OA-SESS-19
        info = self.modules.get(name)
        older = info.callback if info is not None else self._pending.get(name)
        if older is not None:
            self._callbacks.pop(older, None)  # OA-SESS-7: the newer one replaces it
        self._callbacks[conn] = name
        if info is None:
            self._pending[name] = conn  # kept until the name is bound
        else:
            extensions = declared if declared is not None else info.extensions
            self.modules[name] = replace(info, callback=conn, extensions=extensions)
        return (older,) if older is not None and older != conn else ()

    def closed(self, conn: ConnId) -> tuple[list[str], tuple[ConnId, ...]]:
        """Forget `conn`; return the names it loses and their callbacks to close (OA-SESS-15)."""
        self._conn_extensions.pop(conn, None)
        self._conn_address.pop(conn, None)
        self._drop_callback(conn)
        names = self._primary.pop(conn, [])
        close: list[ConnId] = []
        for name in names:
            info = self.modules.pop(name)
            self.generation += 1
            if info.callback is not None:
                self._callbacks.pop(info.callback, None)
                close.append(info.callback)
        return names, tuple(close)

    def _take_over(self, old: ModuleInfo, conn: ConnId) -> tuple[ConnId, ...]:
        """Detach a bound name from its old session and return what to close (OA-SESS-6)."""
        if old.conn == conn:
            return ()  # the same session binding again: nothing to take over
        close: list[ConnId] = []
        if old.conn is not None:
            names = self._primary.get(old.conn, [])
            if old.name in names:
                names.remove(old.name)
            close.append(old.conn)
        if old.callback is not None and old.callback != conn:
            self._callbacks.pop(old.callback, None)
            close.append(old.callback)
        return tuple(close)

    def _drop_callback(self, conn: ConnId) -> None:
        name = self._callbacks.pop(conn, None)
        if name is None:
            return
        info = self.modules.get(name)
        if info is not None and info.callback == conn:
            self.modules[name] = replace(info, callback=None)
        if self._pending.get(name) == conn:
            del self._pending[name]

    # --- ports ----------------------------------------------------------------------------

    def _port(self, conn: ConnId, msg: Message) -> int:
        """Return the port of a BIND (OA-SESS-3/4) or -1 for BIND_NOLISTEN (OA-SESS-5)."""
        if msg.type == "BIND_NOLISTEN":
            return NOLISTEN_PORT
        if not msg.content.strip():
            return self._free_port(conn, msg.sender)
        try:
            wanted = parse_tcplocation(msg.content).port
        except OpenAIRError as exc:
            raise BindRefusedError(f"the content is not a tcplocation: {exc}") from None
        if not 1 <= wanted <= MAX_PORT:  # OA-SESS-4
            raise BindRefusedError(f"port {wanted} is not in 1-{MAX_PORT}")
        if self._port_taken(wanted, conn, msg.sender):
            raise BindRefusedError(f"port {wanted} is in use by another module")  # OA-SESS-4
        return wanted

    def _port_taken(self, port: int, conn: ConnId, name: str) -> bool:
        address = self._conn_address.get(conn, "")
        return any(
            m.port == port and m.address == address and m.name != name
            for m in self.modules.values()
        )

    def _free_port(self, conn: ConnId, name: str) -> int:
        """Choose a port for a BIND without one (DESIGN-NOTES: a free port on the server host)."""
        if self._allocate is not None:
            try:
                return self._allocate(0)
            except (OSError, ValueError) as exc:
                raise BindRefusedError(f"no free port: {exc}") from None
        for _ in range(MAX_PORT):
            port = self._next_port
            self._next_port = port + 1 if port < MAX_PORT else FIRST_MODULE_PORT
            if not self._port_taken(port, conn, name):
                return port
        raise BindRefusedError("no free port")
