"""The cluster node's parts that need no cluster: options, placement in the psySpec, the copy
encoding, and the errors of a node that cannot join (issue #22, spec 17)."""

from __future__ import annotations

import builtins
import logging
import socket
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from openair.cluster import open_cluster_store
from openair.cluster.store import decode_copy, encode_copy, parse_spec, stream_name, subject
from openair.protocol.message import Message
from openair.server.aio.stores import open_store
from openair.server.cli_serve import serve
from openair.server.core.config import ConfigError, parse_config
from openair.server.core.store import StoreSpecError


def _spec(attrs: str) -> bytes:
    return f'<psySpec name="P" version="1.2"><whiteboard name="V" {attrs}/></psySpec>'.encode()


def test_placement_attributes_are_read_and_checked() -> None:
    wb = {w.name: w for w in parse_config(_spec('host="m3" replicas="3"'), source="t").whiteboards}
    assert (wb["V"].host, wb["V"].replicas) == ("m3", 3)
    remote = {w.name: w for w in parse_config(_spec('remote="m2"'), source="t").whiteboards}
    assert (remote["V"].host, remote["V"].replicas) == ("m2", 1)  # Psyclone's spelling
    for bad in ('replicas="0"', 'replicas="6"', 'replicas="two"'):
        with pytest.raises(ConfigError):
            parse_config(_spec(bad), source="t")


def test_a_lone_server_warns_that_it_hosts_a_placed_whiteboard(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    import asyncio

    from openair.server.aio.app import ServerOptions, start_server

    config = parse_config(_spec('host="m3"'), source="t")

    async def body() -> None:
        server = await start_server(ServerOptions(port=0, monitor=False, config=config))
        await server.stop()

    with caplog.at_level(logging.WARNING, logger="openair.server"):
        asyncio.run(body())
    assert "event=placement_ignored whiteboard=V host=m3" in caplog.text


def test_cluster_addresses_are_parsed_and_bad_ones_refused() -> None:
    spec = parse_spec("m1@nats://10.0.0.1:4222, nats://10.0.0.2:4222")
    assert spec.node == "m1" and spec.urls == ("nats://10.0.0.1:4222", "nats://10.0.0.2:4222")
    for bad in ("m1@", "m1@http://x:1", "m1@nats://a:1,10.0.0.2:4222"):
        with pytest.raises(StoreSpecError):
            parse_spec(bad)


def test_stream_names_and_subjects_take_any_whiteboard_name() -> None:
    for name in ("WB1", "a.b*c>d", "Ünïcode wb"):
        assert all(c.isalnum() or c == "_" for c in stream_name(name))
        assert subject(name).count(".") == 2 and " " not in subject(name)
    assert stream_name("a") != stream_name("A")


def test_copies_survive_the_payload_encoding_with_their_chunks() -> None:
    msg = Message(type="T.X", sender="s", to="WB1", content="héllo <&>", binary=(b"\0\1", b""))
    copy = decode_copy(encode_copy(msg), 42)
    assert copy is not None and copy.wbid == 42
    assert (copy.type, copy.content, copy.binary) == ("T.X", "héllo <&>", (b"\0\1", b""))
    assert decode_copy(b"\0\0\0\x05junk", 1) is None
    assert decode_copy(b"", 1) is None
    assert decode_copy(encode_copy(msg) + b"extra", 1) is None  # chunks must add up


def test_a_missing_client_library_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    real_import = builtins.__import__

    def no_nats(name: str, *args: Any, **kwargs: Any) -> Any:
        if name == "nats" or name.startswith("nats."):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_nats)
    with pytest.raises(StoreSpecError, match=r"pip install 'openair-kit\[cluster\]'"):
        open_cluster_store("n@nats://127.0.0.1:4222")


def test_serve_refuses_bad_combinations_and_an_unreachable_cluster() -> None:
    runner = CliRunner()
    result = runner.invoke(serve, ["--port", "0", "--node", "m1"])
    assert result.exit_code == 2 and "--node needs --cluster" in result.output
    result = runner.invoke(
        serve, ["--port", "0", "--cluster", "nats://127.0.0.1:1", "--store", "sqlite:x.db"]
    )
    assert result.exit_code == 2 and "no --store" in result.output
    with socket.socket() as sock:  # a port nobody listens on
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    result = runner.invoke(
        serve, ["--port", "0", "--no-monitor", "--cluster", f"nats://127.0.0.1:{port}"]
    )
    assert result.exit_code == 2, result.output
    assert "cannot join the cluster" in result.output
    with pytest.raises(StoreSpecError):
        open_store("cluster:n@ftp://x")
