"""The whole conformance suite against the server on each data path (issue #20).

tests/conformance/test_suite_reference.py runs the suite on the process default (native when
the extension is built, else python); here the same suite runs once on each other path
(reference, and python or native), the server in a background thread as there. A case that is not
applicable must say why (as there); every other case must pass.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import pytest
from datapath_harness import datapaths
from server_thread import ServerThread
from suite_runs import run_suite

from openair.server.aio.app import Server, ServerOptions, start_server
from openair.server.aio.datapath import DataPath, select
from openair_conformance.engine import RunOptions
from openair_conformance.model import Verdict
from openair_conformance.registry import all_cases

#: The process default (native when built, else python) serves tests/conformance already.
_DEFAULT = select()
_PATHS = {
    name: path
    for name, path in datapaths().items()
    if (path.name if path is not None else "reference") != getattr(_DEFAULT, "name", "reference")
}


@contextlib.contextmanager
def _serving(path: DataPath | None) -> Iterator[tuple[str, int]]:
    async def factory() -> Server:
        server = await start_server(ServerOptions(host="127.0.0.1", port=0))
        server.datapath = path  # type: ignore[attr-defined]  # before any connection is accepted
        return server

    thread = ServerThread(factory)
    try:
        yield ("127.0.0.1", thread.port)
    finally:
        thread.stop()


@pytest.mark.parametrize("name", sorted(_PATHS))
def test_every_case_passes_on_the_data_path(name: str) -> None:
    with _serving(_PATHS[name]) as target:
        summary, results = run_suite(RunOptions(target=target, jobs=4))  # late: rerun alone
    assert summary.total == len(all_cases())
    bad = [
        f"{r.info.id} {r.verdict.value}: {r.message}"
        for r in results
        if r.verdict is not Verdict.PASS
        and not (r.verdict is Verdict.NOT_APPLICABLE and r.message.strip())
    ]
    assert not bad, "\n".join(bad)
    assert sum(r.verdict is Verdict.PASS for r in results) > len(all_cases()) // 2


def test_native_is_built_where_a_compiler_is() -> None:
    """`make datapath-native` builds the extension; the selector picks it when nothing is forced
    (and so test_suite_reference runs the suite on it)."""
    chosen: Any = select({})
    if "native" not in datapaths():
        pytest.skip("the native extension is not built in this environment")
    assert chosen.name == "native"
