"""The role-neutral OpenAIR protocol core: no sockets, no threads, no clock (issue #17).

Framing (`framing`), hardened XML (`xmlsafe`), the message model and its codec (`message`,
`codec`, `fastcodec`), types and patterns (`types`, `matching`), content objects (`content`,
`objects`, `contentmatch`, `attachments`, `datasample`), registrations and wakeups
(`registration`, `wakeup`), the generated error table (`errors`, `_errors_base`), the `auth`
computations, `address` and `times`. Server, client and conformance suite build on it; nothing
here imports them. Whatever needs the time takes it as an argument. This package module imports
nothing so that importing any part stays cheap.
"""

from __future__ import annotations
