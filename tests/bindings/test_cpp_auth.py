"""The C++ client in secure mode (spec 14.3) against the reference server over TLS.

`openair serve --auth secrets.xml --tls-cert --tls-key` runs with a self-signed certificate made
at test time by `openssl req`; the C++ example `poster` proves its name (--secret-file) over TLS
(--tls-ca) and posts, and a Python module (also proved) retrieves the post. A wrong secret, a
server without `auth` and an untrusted certificate each fail with one line and their exit code.
"""

from __future__ import annotations

import asyncio
import shutil
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from bindings_support import ROOT, require

from openair.protocol.auth import secrets_xml
from openair.client import Module
from openair.client.auth import client_tls_context
from openair.protocol.content import RetrieveSpec

POSTER = ROOT / "bindings" / "cpp" / "build" / "poster"
SECRETS = {"CppPoster": "cpp-poster-secret-0123456789", "PyReader": "py-reader-secret-01234567"}
TIMEOUT = 60  # seconds for one program or server start: a hang fails instead of blocking


@dataclass(frozen=True, slots=True, kw_only=True)
class Served:
    port: int
    cert: Path
    where: Path


def _openssl_cert(where: Path) -> tuple[Path, Path]:
    """A self-signed certificate for 127.0.0.1 and its key, made by `openssl req`."""
    openssl = shutil.which("openssl")
    if openssl is None:
        pytest.skip("openssl is not installed")
    crt, key = where / "cert.pem", where / "key.pem"
    subprocess.run(
        [openssl, "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
         "-subj", "/CN=127.0.0.1", "-addext", "subjectAltName=IP:127.0.0.1",
         "-keyout", str(key), "-out", str(crt)],
        check=True, capture_output=True, timeout=TIMEOUT,
    )  # fmt: skip
    return crt, key


def _start(args: list[str]) -> tuple[subprocess.Popen[str], int]:
    """Start `openair serve ARGS` on a free port; return it and the port its first line names."""
    server = subprocess.Popen(
        [sys.executable, "-m", "openair.cli", "serve", "--port", "0", "--log-level", "warning",
         *args],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert server.stdout is not None
    line = server.stdout.readline()  # "listening on 127.0.0.1:PORT (whiteboards: …)"
    if not line.startswith("listening on "):
        server.kill()
        _, err = server.communicate(timeout=TIMEOUT)
        pytest.fail(f"the reference server did not start: {line}{err}")
    return server, int(line.split()[2].rsplit(":", 1)[1])


def _stop(server: subprocess.Popen[str]) -> None:
    server.terminate()
    try:
        server.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        server.kill()
        server.communicate()


@pytest.fixture(scope="module")
def secure(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    require("C++ binding", "make test-cpp", POSTER)
    where = tmp_path_factory.mktemp("cpp-auth")
    crt, key = _openssl_cert(where)
    secrets = where / "secrets.xml"
    secrets.write_text(secrets_xml(SECRETS), encoding="utf-8")
    server, port = _start(["--auth", str(secrets), "--tls-cert", str(crt), "--tls-key", str(key)])
    try:
        yield Served(port=port, cert=crt, where=where)
    finally:
        _stop(server)


def _poster(port: int, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(POSTER), "--port", str(port), "--to", "WB1", *args],
        capture_output=True, text=True, timeout=TIMEOUT,
    )  # fmt: skip


def _secret_file(where: Path, name: str, secret: str) -> Path:
    path = where / f"{name}.secret"
    path.write_text(secret + "\n", encoding="utf-8")  # the trailing line break is not part of it
    return path


async def _retrieve(served: Served, pattern: str) -> list[str]:
    """What a proved Python module retrieves from WB1 over TLS: the contents, newest first."""
    tls = client_tls_context(cafile=str(served.cert))
    reader = Module("PyReader", port=served.port, listen=False, secret=SECRETS["PyReader"], tls=tls)
    async with reader:
        found = await reader.retrieve(RetrieveSpec(whiteboard="WB1", pattern=pattern, latest=5))
    return [m.content for m in found]


def test_the_cpp_poster_proves_its_name_over_tls(secure: Served) -> None:
    secret = _secret_file(secure.where, "CppPoster", SECRETS["CppPoster"])
    done = _poster(
        secure.port, "--name", "CppPoster", "--secret-file", str(secret),
        "--tls-ca", str(secure.cert), "--type", "CppAuth.Ping", "--content", "proved over TLS",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("posted CppAuth.Ping to WB1 id ")
    posted_id = done.stdout.split()[-1]
    contents = asyncio.run(asyncio.wait_for(_retrieve(secure, "CppAuth.Ping"), TIMEOUT))
    assert contents == ["proved over TLS"], posted_id


def test_a_wrong_secret_fails_with_one_line_and_exit_1(secure: Served) -> None:
    wrong = _secret_file(secure.where, "Wrong", "not-the-secret-0123456789")
    done = _poster(
        secure.port, "--name", "CppPoster", "--secret-file", str(wrong),
        "--tls-ca", str(secure.cert), "--type", "CppAuth.Wrong",
    )  # fmt: skip
    assert done.returncode == 1, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("poster: AUTH_FAILED: "), done.stderr
    assert "not-the-secret" not in done.stderr + done.stdout  # OA-AUTH-12: never printed
    assert asyncio.run(asyncio.wait_for(_retrieve(secure, "CppAuth.Wrong"), TIMEOUT)) == []


def test_an_untrusted_certificate_is_refused(secure: Served, tmp_path: Path) -> None:
    other, _ = _openssl_cert(tmp_path)  # a CA that did not sign the server's certificate
    secret = _secret_file(secure.where, "CppPoster", SECRETS["CppPoster"])
    done = _poster(
        secure.port, "--name", "CppPoster", "--secret-file", str(secret),
        "--tls-ca", str(other), "--type", "CppAuth.Untrusted",
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert "certificate" in done.stderr and "TLS" in done.stderr, done.stderr


def test_a_secret_is_never_offered_to_a_server_without_auth(tmp_path: Path) -> None:
    require("C++ binding", "make test-cpp", POSTER)
    server, port = _start([])
    try:
        secret = _secret_file(tmp_path, "CppPoster", SECRETS["CppPoster"])
        done = _poster(port, "--name", "CppPoster", "--secret-file", str(secret))
    finally:
        _stop(server)
    assert done.returncode == 1, done.stderr
    assert done.stderr.startswith("poster: AUTH_REQUIRED: ") and "OA-AUTH-12" in done.stderr
