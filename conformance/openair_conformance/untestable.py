"""Requirements the server suite cannot check over TCP, each with the reason.

`openair conform coverage` prints the reason beside each of them, and
tests/conformance/test_suite_coverage.py keeps the table honest in both directions (a listed
requirement that a case now cites, or that is no longer in the catalogue, fails it).
"""

from __future__ import annotations

_CLIENT = "a rule for clients or modules; the suite plays the client, the server is judged"
_CONFIG = "about reading a configuration at start-up: not observable over TCP"

NOT_CHECKED: dict[str, str] = {
    "OA-MSG-19": _CLIENT + " (reading legacy spellings; client tests and spec/vectors/legacy)",
    "OA-MSG-20": _CLIENT + " (counting an unreadable delivery)",
    "OA-GEN-1": "the definition of conformance itself; the other requirements check it",
    "OA-GEN-6": "how the checker judges time (the fail threshold); tests/conformance checks it",
    "OA-GEN-7": "how the checker judges a vacuous pass (inconclusive); tests/conformance checks it",
    "OA-GEN-3": _CLIENT + " (a library's error classes)",
    "OA-GEN-5": "about a client library's shim and its standard input and output, not the wire",
    "OA-MSG-14": _CLIENT + " (refusing to encode characters XML cannot carry)",
    "OA-SESS-33": _CLIENT + " (pairing replies; the harness does it)",
    "OA-SESS-27": _CLIENT + " (a requester's reply timeout)",
    "OA-SESS-11": _CLIENT + " (a module answering the server's requests)",
    "OA-DELIV-2": _CLIENT + " (a module accepting deliveries on both paths)",
    "OA-DELIV-10": _CLIENT + " (a module keeping its port open)",
    "OA-DELIV-4": _CLIENT + " (a module acknowledging deliveries)",
    "OA-WAKE-8": _CLIENT + " (a module accepting phase updates)",
    "OA-PRIO-4": _CLIENT + " (what a module or test may expect)",
    "OA-PRIO-5": (
        "which of two modules' deliveries leaves first is not observable over TCP (they travel on "
        "different connections), and a server's turn budget is its own; the reference server is "
        "checked by tests/server_core/test_server_turns.py and bench/bench_priority.py"
    ),
    "OA-PRIO-6": _CONFIG + " (whiteboards of different priorities need a psySpec; "
    "tests/server_core/test_server_turns.py)",
    "OA-ERR-8": _CLIENT + " (a requester classifying RECEIVE_ERROR)",
    "OA-LIM-7": _CLIENT + " (a peer staying within advertised limits)",
    "OA-CAP-2": _CLIENT + " (a client treating a legacy server as legacy; the probe does it)",
    "OA-KEEP-1": "needs 60 s without traffic before the server's KEEPALIVE is due",
    "OA-KEEP-3": "needs 60 s without traffic before the server sends a KEEPALIVE to ignore",
    "OA-SESS-24": (
        "needs the server to be shut down, which the suite cannot request; the reference "
        "server's shutdown is tested by tests/product/test_product_shutdown.py"
    ),
    "OA-CONF-1": _CONFIG,
    "OA-CONF-3": _CONFIG,
    "OA-CONF-5": _CONFIG + " (needs a configured module, which the suite cannot know of)",
    "OA-CONF-6": _CONFIG,
    "OA-CONF-7": _CONFIG
    + "; the reference server's order (--port, then <global><port>, then 10000) is tested by "
    "tests/product/test_product_serve.py",
    "OA-WM-5": "active functions are code inside the implementation; a peer cannot attach one",
    "OA-WM-8": "about the writer's clock; a peer sees timestamps, not how they were taken",
    "OA-WM-9": "report filters are the implementation's own configuration, not set by a peer",
    "OA-WM-13": "about what a module does when it joins, before the checker can talk to it",
    "OA-AUTH-9": "the checker runs on one host: it cannot tell the address the server connects "
    "to from its own; tests/server_core/test_server_auth_router.py checks the proved BIND",
    "OA-AUTH-10": "a SHOULD about deployment: the checker speaks TLS when given --tls-ca, but a "
    "server in secure mode without TLS is still conformant; tests/client/test_client_auth_tls.py",
    "OA-AUTH-12": _CLIENT + " (a client never binds with a secret at a server without auth; "
    "tests/client/test_client_auth_tls.py)",
    **{
        f"OA-CLU-{n}": "a cluster's guarantees (spec 17) need several servers and faults (a node "
        "killed or cut off) that a checker talking to one server cannot cause; the reference "
        "server's nodes are tested by tests/cluster/"
        for n in range(1, 9)
    },
}

_BUDGET = (
    "a byte budget of the server (issue #19); no case yet reaches it over TCP, which at the "
    "defaults takes hundreds of MiB or a thousand connections and needs a server started with "
    "small budgets; the reference server's is tested by "
)

#: Requirements a case could check over TCP but none does yet: gaps in the suite, said as such
#: (`openair conform coverage` prints them as NOT CHECKED with the reason), never hidden.
KNOWN_GAPS: dict[str, str] = {
    # OA-LIM-8, -9, -10, -14, -15 and -17 have cases (LIM-001..004, LIM-014..016, LIM-040,
    # LIM-041, XSTREAM-06x) at small advertised bounds or the defaults (issue #15).
    "OA-LIM-11": _BUDGET + "tests/server_io/test_server_io_budgets.py",
    "OA-LIM-12": _BUDGET + "tests/server_io/test_server_io_budgets.py",
    "OA-LIM-13": _BUDGET + "tests/server_io/test_server_io_budgets.py",
    "OA-LIM-16": _BUDGET + "tests/streams_core/test_stream_budgets.py",
}
