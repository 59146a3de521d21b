"""Hand-written bases of the generated error classes (style rule 5: blame-split errors).

`errors.py` is generated from `spec/errors.xml`; these bases give every generated class the
behaviour it shares. `RemoteProtocolError` means the peer broke the protocol,
`LocalProtocolError` means this side's API was misused, `PeerError` means the peer refused a
well-formed request (its state or a resource said no).
"""

from __future__ import annotations

import enum
from typing import ClassVar


class Blame(enum.Enum):
    """Who is at fault for an error condition (spec/errors.xml `blame`)."""

    REMOTE = "remote"
    LOCAL = "local"
    PEER = "peer"


class OpenAIRError(Exception):
    """Base of every OpenAIR error; `detail` is the human-readable part of `NAME: detail`."""

    code: ClassVar[int] = 0
    name: ClassVar[str] = "OPENAIR_ERROR"
    blame: ClassVar[Blame] = Blame.REMOTE
    reply: ClassVar[str | None] = None
    closes: ClassVar[bool] = False
    requirements: ClassVar[tuple[str, ...]] = ()

    def __init__(self, detail: str = "") -> None:
        super().__init__(detail)
        self.detail = detail

    def wire_text(self) -> str:
        """Return the `RECEIVE_ERROR` content for this error: `NAME: detail` (OA-ERR-2)."""
        return f"{self.name}: {self.detail}" if self.detail else self.name

    def __str__(self) -> str:
        return self.wire_text()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.detail!r})"


class RemoteProtocolError(OpenAIRError):
    """The peer sent something the protocol does not allow."""

    blame = Blame.REMOTE


class PeerError(OpenAIRError):
    """The peer refused a well-formed request, or a resource ran out."""

    blame = Blame.PEER


class LocalProtocolError(OpenAIRError):
    """This side's API was used in a way the protocol does not allow."""

    blame = Blame.LOCAL
