"""The secure-mode cases (cases/auth.py, spec 14.3) against the reference server in secure mode.

The server gets two module secrets; the suite gets the same (as `openair conform
--auth-secrets FILE` would give them). Every AUTH case must pass; without secrets the cases that
prove a name are not applicable, with a reason.
"""

from __future__ import annotations

import asyncio
import contextlib
import shutil
import ssl
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from server_thread import ServerThread

from openair.protocol.auth import secrets_xml
from openair_conformance.cli import conform
from openair_conformance.engine import RunOptions, run
from openair_conformance.model import CaseResult, RunSummary, Verdict
from openair_conformance.registry import all_cases

app = pytest.importorskip("openair.server.aio.app")

SECRETS = {"AuthCaseA": "secret-of-case-module-a-0123", "AuthCaseB": "secret-of-case-module-b-4567"}
AUTH_CASES = sorted(c.info.id for c in all_cases() if c.info.id.startswith("AUTH-"))


@contextlib.contextmanager
def _secure_server(tls: ssl.SSLContext | None = None) -> Iterator[tuple[str, int]]:
    options = app.ServerOptions(
        host="127.0.0.1", port=0, auth_secrets=SECRETS, grace_s=0.2, tls=tls
    )
    thread = ServerThread(lambda: app.start_server(options))
    try:
        yield ("127.0.0.1", thread.port)
    finally:
        thread.stop()


def _run(target: tuple[str, int], **options: Any) -> RunSummary:
    return asyncio.run(run(RunOptions(target=target, case_globs=("AUTH-*",), **options)))


def _explain(results: list[CaseResult]) -> str:
    lines = []
    for r in results:
        lines.append(f"{r.info.id} {r.verdict.value}: {r.message} (expected: {r.expected})")
        lines += [f"    {e.conn} {e.direction} {e.tag} {e.text[:200]}" for e in r.trace[-6:]]
    return "\n".join(lines)


def test_auth_cases_exist() -> None:
    assert len(AUTH_CASES) >= 8


def test_every_auth_case_passes_against_the_secure_reference_server() -> None:
    with _secure_server() as target:
        summary = _run(target, auth_secrets=SECRETS)
    results = list(summary.results)
    assert sorted(r.info.id for r in results) == AUTH_CASES
    bad = [r for r in results if r.verdict is not Verdict.PASS]
    assert not bad, _explain(bad)


def test_without_secrets_the_proving_cases_are_not_applicable() -> None:
    with _secure_server() as target:
        summary = _run(target)
    verdicts = {r.info.id: r for r in summary.results}
    for case_id in ("AUTH-002", "AUTH-004", "AUTH-005", "AUTH-006", "AUTH-007"):
        result = verdicts[case_id]
        assert result.verdict is Verdict.NOT_APPLICABLE, _explain([result])
        assert "--auth-secrets" in result.message
    assert verdicts["AUTH-003"].verdict is Verdict.PASS, _explain([verdicts["AUTH-003"]])


def test_conform_run_reads_auth_secrets(tmp_path: Path) -> None:
    path = tmp_path / "secrets.xml"
    path.write_text(secrets_xml(SECRETS))
    with _secure_server() as (host, port):
        result = CliRunner().invoke(
            conform,
            ["run", f"{host}:{port}", "--case", "AUTH-002", "--auth-secrets", str(path)],
        )
    assert result.exit_code == 0, result.output
    assert "pass" in result.output and "AUTH-002" in result.output


def test_conform_run_refuses_a_bad_secrets_file(tmp_path: Path) -> None:
    path = tmp_path / "secrets.xml"
    path.write_text("<secrets><module name='A' secret='short'/></secrets>")
    result = CliRunner().invoke(
        conform, ["run", "127.0.0.1:1", "--case", "AUTH-002", "--auth-secrets", str(path)]
    )
    assert result.exit_code == 2
    assert "shorter than 16 bytes" in result.output


def test_every_auth_case_passes_over_tls(tmp_path: Path) -> None:
    """The same run with TLS on the main port (OA-AUTH-10), as `--tls-ca FILE` gives it."""
    openssl = shutil.which("openssl")
    if openssl is None:
        pytest.skip("openssl is not installed")
    crt, key = tmp_path / "cert.pem", tmp_path / "key.pem"
    subprocess.run(
        [openssl, "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
         "-subj", "/CN=127.0.0.1", "-addext", "subjectAltName=IP:127.0.0.1",
         "-keyout", str(key), "-out", str(crt)],
        check=True, capture_output=True, timeout=60,
    )  # fmt: skip
    server_tls = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    server_tls.load_cert_chain(crt, key)
    with _secure_server(server_tls) as target:
        summary = _run(
            target, auth_secrets=SECRETS, tls=ssl.create_default_context(cafile=str(crt))
        )
    bad = [r for r in summary.results if r.verdict is not Verdict.PASS]
    assert not bad, _explain(bad)
    assert len(summary.results) == len(AUTH_CASES)


def test_conform_run_refuses_a_bad_tls_ca(tmp_path: Path) -> None:
    path = tmp_path / "ca.pem"
    path.write_text("not a certificate")
    result = CliRunner().invoke(
        conform, ["run", "127.0.0.1:1", "--case", "AUTH-001", "--tls-ca", str(path)]
    )
    assert result.exit_code == 2
    assert "--tls-ca" in result.output
