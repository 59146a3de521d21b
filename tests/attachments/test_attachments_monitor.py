"""The web monitor shows attachments: sizes in the detail, bytes behind the download link."""

from __future__ import annotations

import asyncio
import json

from openair.client import Module
from openair.server.aio.app import ServerOptions, start_server


async def _get(port: int, path: str) -> tuple[int, dict[str, str], bytes]:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    writer.write(f"GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n".encode())
    data = await reader.read()
    writer.close()
    head, _, body = data.partition(b"\r\n\r\n")
    lines = head.decode().split("\r\n")
    headers = {k.lower(): v.strip() for k, _, v in (ln.partition(":") for ln in lines[1:])}
    return int(lines[0].split()[1]), headers, body


def test_monitor_lists_and_serves_attachments() -> None:
    async def go() -> None:
        server = await start_server(ServerOptions(host="127.0.0.1", port=0, grace_s=0.5))
        try:
            async with Module("Writer", port=server.port, keepalive=None) as writer:
                await writer.post("WB1", "Mon.Att", "x", binary=[b"\x00\x01\x02", b"zz"])

            status, _, body = await _get(server.port, "/api/messages/WB1/1")
            assert status == 200
            assert json.loads(body)["slots"]["binarysizes"] == [3, 2]
            status, headers, body = await _get(server.port, "/api/messages/WB1/1/attachments/1")
            assert (status, body) == (200, b"\x00\x01\x02")
            assert headers["content-type"] == "application/octet-stream"
            assert headers["content-disposition"].startswith("attachment;")
            status, _, body = await _get(server.port, "/api/messages/WB1/1/attachments/2")
            assert (status, body) == (200, b"zz")
            for missing in (
                "/api/messages/WB1/1/attachments/3",
                "/api/messages/WB1/9/attachments/1",
            ):
                assert (await _get(server.port, missing))[0] == 404
            status, _, body = await _get(server.port, "/api/whiteboards/WB1/messages")
            (row,) = json.loads(body)["messages"]
            assert (row["attachments"], row["attachment_bytes"]) == (2, 5)
        finally:
            await server.stop()

    asyncio.run(asyncio.wait_for(go(), 20))
