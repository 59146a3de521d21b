"""Secure mode end to end: the reference server with TLS and secrets, the Python Module.

The certificate is made at test time with the system's `openssl req` (spec 14.3, OA-AUTH-10).
"""

from __future__ import annotations

import asyncio
import shutil
import ssl
import subprocess
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import replace
from pathlib import Path

import pytest
from click.testing import CliRunner

from openair.client import Module
from openair.client.auth import AuthRefusedError, client_tls_context
from openair.protocol.auth import secrets_xml
from openair.protocol.content import Trigger
from openair.protocol.errors import OpenAIRError
from openair.server.aio.app import ServerOptions, start_server
from openair.server.cli_serve import serve

SECRETS = {"Alice": "alice-secret-0123456789", "Bob": "bob-secret-0123456789ab"}


@pytest.fixture(scope="module")
def cert(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A self-signed certificate for 127.0.0.1 and its key, made by `openssl req`."""
    openssl = shutil.which("openssl")
    if openssl is None:
        pytest.skip("openssl is not installed")
    where = tmp_path_factory.mktemp("tls")
    crt, key = where / "cert.pem", where / "key.pem"
    subprocess.run(
        [openssl, "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
         "-subj", "/CN=127.0.0.1", "-addext", "subjectAltName=IP:127.0.0.1",
         "-keyout", str(key), "-out", str(crt)],
        check=True, capture_output=True, timeout=60,
    )  # fmt: skip
    return crt, key


def server_tls(crt: Path, key: Path) -> ssl.SSLContext:
    context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    context.load_cert_chain(crt, key)
    return context


@asynccontextmanager
async def server(**options: object) -> AsyncIterator[int]:
    srv = await start_server(ServerOptions(host="127.0.0.1", port=0, **options))  # type: ignore[arg-type]
    try:
        yield srv.port
    finally:
        await srv.stop()


def run(coro: object) -> None:
    asyncio.run(asyncio.wait_for(coro, 30))  # type: ignore[arg-type]


def test_proved_modules_work_over_tls(cert: tuple[Path, Path]) -> None:
    crt, key = cert
    client = client_tls_context(cafile=str(crt))

    async def scenario() -> None:
        async with server(auth_secrets=SECRETS, tls=server_tls(crt, key)) as port:
            alice = Module("Alice", port=port, listen=False, secret=SECRETS["Alice"], tls=client)
            bob = Module("Bob", port=port, listen=False, secret=SECRETS["Bob"], tls=client)
            async with alice, bob:
                assert alice.capabilities is not None
                assert "auth" in alice.capabilities.extensions
                await alice.subscribe(Trigger(pattern="Tls.Ping", whiteboard="WB1"))
                await bob.post("WB1", "Tls.Ping", "over TLS")
                while True:  # phase updates first; the wakeup comes over the callback
                    event = await alice.next_wakeup(timeout=10)
                    assert event is not None
                    if event.wakeup.trigger is not None:
                        break
                assert event.wakeup.trigger.sender == "Bob"

    run(scenario())


def test_streams_prove_their_connections_over_tls(cert: tuple[Path, Path]) -> None:
    crt, key = cert
    client = client_tls_context(cafile=str(crt))

    async def scenario() -> None:
        async with server(auth_secrets=SECRETS, tls=server_tls(crt, key)) as port:
            alice = Module("Alice", port=port, listen=False, secret=SECRETS["Alice"], tls=client)
            async with alice, alice.subscribe_stream("Stream1") as pushed:
                assert await alice.stream("Stream1").add(b"secret sample") == 1
                sample = await pushed.next(timeout=10)
                assert sample is not None and bytes(sample.sample.payload) == b"secret sample"

    run(scenario())


def test_a_secure_module_proves_again_after_reconnecting(cert: tuple[Path, Path]) -> None:
    crt, key = cert
    options = ServerOptions(
        host="127.0.0.1", port=0, auth_secrets=SECRETS, tls=server_tls(crt, key)
    )

    async def scenario() -> None:
        first = await start_server(options)
        port = first.port
        alice = Module(
            "Alice",
            port=port,
            listen=False,
            secret=SECRETS["Alice"],
            tls=client_tls_context(cafile=str(crt)),
            reconnect_delay=0.02,
        )
        try:
            await alice.connect()
            await first.stop()  # the server drops the primary connection
            again = await start_server(replace(options, port=port))
            try:
                await alice.wait_connected(2, timeout=10)  # proved again, Reconnect posted
                assert (await alice.post("WB1", "Tls.Again", "x")).type == "Tls.Again"
            finally:
                await again.stop()
        finally:
            await alice.close()

    run(scenario())


def test_a_wrong_secret_is_refused(cert: tuple[Path, Path]) -> None:
    crt, key = cert

    async def scenario() -> None:
        async with server(auth_secrets=SECRETS, tls=server_tls(crt, key)) as port:
            mod = Module(
                "Alice",
                port=port,
                secret="not-alice-secret-0123",
                tls=client_tls_context(cafile=str(crt)),
                reconnect=False,
            )
            with pytest.raises(AuthRefusedError, match="AUTH_FAILED"):
                await mod.connect()

    run(scenario())


def test_a_secret_is_never_used_with_a_legacy_server() -> None:
    async def scenario() -> None:
        async with server() as port:
            mod = Module("Alice", port=port, secret=SECRETS["Alice"], reconnect=False)
            with pytest.raises(AuthRefusedError, match="OA-AUTH-12"):
                await mod.connect()

    run(scenario())


def test_plain_tcp_gets_nothing_from_a_tls_port(cert: tuple[Path, Path]) -> None:
    crt, key = cert

    async def scenario() -> None:
        async with server(auth_secrets=SECRETS, tls=server_tls(crt, key)) as port:
            mod = Module("Alice", port=port, secret=SECRETS["Alice"], reconnect=False)
            with pytest.raises((OSError, OpenAIRError, TimeoutError)):
                await asyncio.wait_for(mod.connect(), 5)
            assert not mod.connected

    run(scenario())


def test_serve_refuses_a_weak_secrets_file(tmp_path: Path) -> None:
    path = tmp_path / "secrets.xml"
    path.write_text(secrets_xml({"Alice": "short"}))
    result = CliRunner().invoke(serve, ["--port", "0", "--auth", str(path)])
    assert result.exit_code == 2
    assert "shorter than 16 bytes" in result.output


def test_serve_wants_cert_and_key_together(tmp_path: Path) -> None:
    result = CliRunner().invoke(serve, ["--port", "0", "--tls-cert", str(tmp_path / "c.pem")])
    assert result.exit_code == 2
    assert "--tls-key" in result.output


def test_options_never_show_the_secrets() -> None:
    shown = repr(ServerOptions(auth_secrets=SECRETS))
    assert all(secret not in shown for secret in SECRETS.values())
